//! `motionctl check` and `motionctl gcode moves`.

use super::{machine_diag, Converter, Loaded};
use crate::job::{self, Item, Machine, Target};
use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand};
use motion_gcode::{render, Diagnostic, Event, Interpreter, Options};
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct CheckArgs {
    /// The G-code file.
    pub file: PathBuf,
    /// Also check against this machine (a job TOML's `[machine]`): axes it lacks, soft limits,
    /// and what its board cannot do yet.
    #[arg(long, value_name = "FILE")]
    pub machine: Option<PathBuf>,
    /// rs274's rules exactly: grbl habits (no program end, sender lines, K0 off-plane, long
    /// lines) are errors instead of warnings.
    #[arg(long)]
    pub strict: bool,
    /// The summary as one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Subcommand, Debug)]
pub enum GcodeCmd {
    /// Print the canonical machining calls, one per line as LinuxCNC's rs274 prints them,
    /// each after its source line number (0: the interpreter's set-up).
    Moves {
        /// The G-code file.
        file: PathBuf,
        /// rs274's rules exactly (grbl habits are errors).
        #[arg(long)]
        strict: bool,
    },
}

fn options(strict: bool) -> Options {
    if strict {
        Options::strict()
    } else {
        Options::default()
    }
}

fn open(
    file: &Path,
    strict: bool,
) -> Result<Interpreter<motion_gcode::source::SeekSource<std::io::BufReader<std::fs::File>>>> {
    Interpreter::open(file, options(strict)).with_context(|| format!("reading {}", file.display()))
}

/// `gcode moves`: calls on stdout, diagnostics on stderr; fails on an error.
pub fn run(cmd: GcodeCmd) -> Result<()> {
    let GcodeCmd::Moves { file, strict } = cmd;
    let name = file.display().to_string();
    let mut errors = 0;
    for e in open(&file, strict)? {
        match e {
            Event::Call(c) => crate::outln!("{:>6} {}", c.line, render(&c.canon)),
            Event::Diagnostic(d) => {
                errors += d.is_error() as usize;
                eprintln!("{}", d.display_with_file(&name));
            }
        }
    }
    crate::out::finish().map_err(anyhow::Error::msg)?;
    if errors > 0 {
        bail!("{name}: stopped at an error (see above)");
    }
    Ok(())
}

/// `check`: every error and warning, then a summary; fails when there is an error.
pub fn check(a: CheckArgs) -> Result<()> {
    let name = a.file.display().to_string();
    let machine = match &a.machine {
        Some(m) => Some(
            job::parse_machine_toml(
                &std::fs::read_to_string(m).with_context(|| format!("reading {}", m.display()))?,
            )
            .with_context(|| m.display().to_string())?,
        ),
        None => None,
    };
    let mut interp = open(&a.file, a.strict)?.keep_going(true);
    let mut diags: Vec<Diagnostic> = Vec::new();
    let mut conv = machine.as_ref().map(Converter::new);
    let mut limits = machine.as_ref().map(Limits::new);
    let (mut moves, mut lines, mut machine_error_line) = (0usize, 0u32, 0u32);
    while let Some(e) = interp.next_event() {
        match e {
            Event::Diagnostic(d) => {
                lines = lines.max(d.line);
                diags.push(d);
            }
            Event::Call(c) => {
                lines = lines.max(c.line);
                moves += c.canon.is_motion() as usize;
                if let (Some(conv), Some(lim)) = (conv.as_mut(), limits.as_mut()) {
                    let mut out = Loaded::default();
                    let mut found = conv.call(c.line, &c.canon, &mut out).err();
                    for it in &out.items {
                        let over = lim.check(it);
                        found = found.or(over);
                    }
                    // One machine error per line is enough (an arc's segments all cross).
                    if let Some(m) = found.filter(|_| machine_error_line != c.line) {
                        machine_error_line = c.line;
                        diags.push(machine_diag(c.line, m));
                    }
                }
            }
        }
    }
    if let Some(conv) = &conv {
        for (line, m) in &conv.notes {
            let mut d = machine_diag(*line, m.clone());
            d.severity = motion_gcode::Severity::Warning;
            diags.push(d);
        }
        diags.sort_by_key(|d| d.line);
    }
    let errors = diags.iter().filter(|d| d.is_error()).count();
    let warnings = diags.len() - errors;
    for d in &diags {
        crate::outln!("{}", d.display_with_file(&name));
    }
    if a.json {
        crate::outln!(
            "{{\"file\":{:?},\"lines\":{lines},\"moves\":{moves},\"errors\":{errors},\"warnings\":{warnings}}}",
            name
        );
    } else {
        crate::outln!("{name}: {lines} lines, {moves} moves, {errors} errors, {warnings} warnings");
    }
    crate::out::finish().map_err(anyhow::Error::msg)?;
    if errors > 0 {
        bail!("{name}: {errors} error{} (listed above)", if errors == 1 { "" } else { "s" });
    }
    Ok(())
}

/// Soft limits, checked on every target that moves an axis.
struct Limits<'a> {
    machine: &'a Machine,
    pos: Vec<f64>,
}

impl<'a> Limits<'a> {
    fn new(machine: &'a Machine) -> Self {
        Limits { machine, pos: vec![0.0; machine.axes.len()] }
    }

    fn check(&mut self, item: &Item) -> Option<String> {
        let (Item::Move(m) | Item::Probe { mv: m, .. }) = item else { return None };
        let Target::Absolute(t) = &m.target else { return None };
        let mut problem = None;
        for (i, (a, v)) in self.machine.axes.iter().zip(t).enumerate() {
            let Some(v) = *v else { continue };
            if v != self.pos[i] && problem.is_none() {
                if v < a.min_mm {
                    problem = Some(format!(
                        "axis {} target {v:.4} mm is below its soft limit min_mm = {}",
                        a.name, a.min_mm
                    ));
                } else if v > a.max_mm {
                    problem = Some(format!(
                        "axis {} target {v:.4} mm is above its soft limit max_mm = {}",
                        a.name, a.max_mm
                    ));
                }
            }
            self.pos[i] = v;
        }
        problem
    }
}
