//! Prints a G-code file's canonical calls in rs274's text form, then its diagnostics:
//! `cargo run -p motion-gcode --example moves -- FILE [--check]`.

use motion_gcode::{render, Event, Interpreter, Options};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: moves FILE [--check] [--strict]");
        std::process::exit(2);
    };
    let strict = args.iter().any(|a| a == "--strict");
    let opts = if strict { Options::strict() } else { Options::default() };
    let interp = match Interpreter::open(std::path::Path::new(path), opts) {
        Ok(i) => i.keep_going(args.iter().any(|a| a == "--check")),
        Err(e) => {
            eprintln!("{path}: {e}");
            std::process::exit(2);
        }
    };
    let mut n = 1;
    for e in interp {
        match e {
            Event::Call(c) => {
                println!("{n:5} L{:<5} {}", c.line, render(&c.canon));
                n += 1;
            }
            Event::Diagnostic(d) => eprintln!("{}", d.display_with_file(path)),
        }
    }
}
