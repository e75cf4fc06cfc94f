//! `motion-gcode`: an RS274/NGC G-code front end that reads G-code as LinuxCNC's rs274ngc
//! interpreter does (the reference, checked move for move against LinuxCNC's `rs274`) and
//! emits canonical machining calls. grbl's dialect is a subset; grbl habits rs274 refuses
//! (no program end, sender lines, an out-of-plane `K0`, long lines) are accepted with a warning.
//!
//! ```
//! use motion_gcode::{Event, Interpreter, Options};
//! let src = std::io::Cursor::new("G21 G0 X10 Y5\nG1 Z-1 F200\nM2\n");
//! let calls: Vec<String> = Interpreter::from_seekable(src, "demo.ngc", Options::default())
//!     .filter_map(|e| match e {
//!         Event::Call(c) if c.canon.is_motion() => Some(motion_gcode::render(&c.canon)),
//!         _ => None,
//!     })
//!     .collect();
//! assert_eq!(calls[0], "STRAIGHT_TRAVERSE(10.0000, 5.0000, 0.0000, 0.0000, 0.0000, 0.0000)");
//! ```
//!
//! Entry points: [`Interpreter`] streams a file or any `BufRead` in bounded memory (it seeks,
//! or keeps lines from the first O-word label on, for loops and calls); [`check_all`] lists
//! every error of a program; [`frame::Frame`] turns the calls into machine-coordinate moves in
//! millimetres and [`curves`] flattens arcs and splines within a chord tolerance.

mod arc;
mod block;
mod check;
mod core;
pub mod curves;
mod cycles;
mod diag;
mod exec;
mod expr;
mod flow;
pub mod frame;
mod interp;
mod lexer;
mod line;
mod messages;
mod modal;
mod motion;
mod offsets;
mod oword;
mod params;
mod render;
pub mod source;
mod spline;
mod state;
mod state_view;
pub mod table;
mod tools;
mod world;

pub mod canon;

pub use crate::canon::{Call, Canon};
pub use crate::core::{Limits, Options};
pub use crate::diag::{Diagnostic, GrblHabit, Kind, Severity};
pub use crate::interp::{Event, Interpreter};
pub use crate::render::render;
pub use crate::state::{FeedMode, Side, Spindle};
pub use crate::state_view::ModalState;
pub use crate::world::{ProbeResult, ToolTable, World};

/// Every error and warning of a program (the interpreter continues past errors, as
/// `rs274 -n 0` does).
pub fn check_all<S: source::LineSource>(src: S, file: &str, opts: Options) -> Vec<Diagnostic> {
    Interpreter::new(src, file, opts)
        .keep_going(true)
        .filter_map(|e| match e {
            Event::Diagnostic(d) => Some(d),
            Event::Call(_) => None,
        })
        .collect()
}
