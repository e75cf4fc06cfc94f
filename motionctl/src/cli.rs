//! The command line: argument parsing, job loading and the subcommands.

use crate::convert::{self, Program};
use crate::gcode;
use crate::job::{self, Job};
use crate::plan::{self, Summary};
use crate::transport::{self, LinkTarget};
use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(name = "motionctl", version, about = "Plan and run motion-board jobs")]
pub struct Cli {
    #[command(subcommand)]
    pub command: Cmd,
}

#[derive(Subcommand, Debug)]
pub enum Cmd {
    /// Stream a job to the board.
    Run {
        #[command(flatten)]
        job: JobArgs,
        #[command(flatten)]
        link: LinkArgs,
        /// Write the board's position reports to this CSV file.
        #[arg(long, value_name = "FILE")]
        log_csv: Option<PathBuf>,
    },
    /// Parse and plan a job offline and run it through the host model of the firmware.
    Plan {
        #[command(flatten)]
        job: JobArgs,
    },
    /// Show the board's motion state.
    Status {
        #[command(flatten)]
        link: LinkArgs,
    },
    /// Feed hold: decelerate and stop on the path.
    Hold {
        #[command(flatten)]
        link: LinkArgs,
    },
    /// Leave a feed hold.
    Resume {
        #[command(flatten)]
        link: LinkArgs,
    },
    /// Stop at once and drop the queued motion.
    Abort {
        #[command(flatten)]
        link: LinkArgs,
    },
    /// Set the feed override factor (0..=2).
    Override {
        #[arg(value_parser = parse_override)]
        factor: f64,
        #[command(flatten)]
        link: LinkArgs,
    },
}

#[derive(Args, Debug)]
pub struct JobArgs {
    /// Job file: .toml, or G-code (.gcode, .nc, .ngc).
    pub job: PathBuf,
    /// Read the job as this format whatever its extension.
    #[arg(long, value_enum)]
    pub format: Option<JobFormat>,
    /// Machine for a G-code job: a job TOML whose `[machine]` is used
    /// [default: machine.toml beside the G-code file].
    #[arg(long, value_name = "FILE")]
    pub machine: Option<PathBuf>,
}

#[derive(Args, Debug)]
pub struct LinkArgs {
    /// Serial port of the board (or, with --qemu, the UART socket path).
    #[arg(long, value_name = "PATH")]
    pub port: Option<String>,
    #[arg(long, value_name = "N", default_value_t = 115_200)]
    pub baud: u32,
    /// Talk to the QEMU board instead of a serial port.
    #[arg(long)]
    pub qemu: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum JobFormat {
    Toml,
    Gcode,
}

fn parse_override(s: &str) -> Result<f64, String> {
    let f: f64 = s.parse().map_err(|_| format!("expected a number, found {s:?}"))?;
    if !(0.0..=job::MAX_OVERRIDE).contains(&f) {
        return Err(format!("must be within 0..=2, got {f}"));
    }
    Ok(f)
}

impl LinkArgs {
    pub fn target(&self) -> Result<LinkTarget> {
        if self.qemu {
            return Ok(LinkTarget::Qemu { socket: self.port.clone() });
        }
        match &self.port {
            Some(port) => Ok(LinkTarget::Serial { port: port.clone(), baud: self.baud }),
            None => bail!("no link given: pass --port PATH or --qemu"),
        }
    }
}

/// The format of `path` by its extension.
pub fn format_of(path: &Path) -> Result<JobFormat> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("toml") => Ok(JobFormat::Toml),
        Some("gcode" | "nc" | "ngc") => Ok(JobFormat::Gcode),
        _ => bail!(
            "{}: unknown job format (extension .toml, .gcode, .nc or .ngc, or pass --format)",
            path.display()
        ),
    }
}

fn read(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))
}

/// Reads and parses a job. A G-code job takes its machine from `machine`, or from `machine.toml`
/// beside it.
pub fn load_job(path: &Path, format: Option<JobFormat>, machine: Option<&Path>) -> Result<Job> {
    let format = match format {
        Some(f) => f,
        None => format_of(path)?,
    };
    let src = read(path)?;
    let name = path.display();
    match format {
        JobFormat::Toml => job::parse_toml(&src).with_context(|| name.to_string()),
        JobFormat::Gcode => {
            let machine_path = match machine {
                Some(m) => m.to_path_buf(),
                None => {
                    let beside = path.with_file_name("machine.toml");
                    if !beside.exists() {
                        bail!(
                            "{name}: a G-code job needs a machine: pass --machine FILE \
                             (or put machine.toml beside it)"
                        );
                    }
                    beside
                }
            };
            let machine = job::parse_machine_toml(&read(&machine_path)?)
                .with_context(|| machine_path.display().to_string())?;
            let items = gcode::parse(&src, &machine).with_context(|| name.to_string())?;
            Ok(Job { machine, items, feed_commands: Vec::new() })
        }
    }
}

/// Loads and converts a job to planner terms.
pub fn load_program(args: &JobArgs) -> Result<(Job, Program)> {
    let job = load_job(&args.job, args.format, args.machine.as_deref())?;
    let program = convert::convert(&job).with_context(|| args.job.display().to_string())?;
    Ok((job, program))
}

/// `plan`: the offline run. Fails when the model does not end where the job does.
pub fn plan_job(args: &JobArgs) -> Result<(Job, Program, Summary)> {
    let (job, program) = load_program(args)?;
    let planned = plan::plan(&program).with_context(|| args.job.display().to_string())?;
    // A bar for long runs only; indicatif draws nothing when stderr is not a terminal.
    let bar = if planned.segments.len() > 2_000 {
        indicatif::ProgressBar::new(planned.segments.len() as u64)
    } else {
        indicatif::ProgressBar::hidden()
    };
    let summary = plan::simulate_plan(&program, planned, |done| bar.set_position(done as u64))
        .with_context(|| args.job.display().to_string())?;
    bar.finish_and_clear();
    if !summary.finished {
        bail!(
            "{}: the model stopped after {:.3} s of machine time before the job ended \
             (a hold never resumed, or override 0?)",
            args.job.display(),
            summary.seconds()
        );
    }
    let n = job.machine.axes.len();
    if summary.report.positions[..n] != program.final_steps[..n] {
        bail!(
            "{}: the model ended at {:?} steps but the job ends at {:?}",
            args.job.display(),
            &summary.report.positions[..n],
            &program.final_steps[..n]
        );
    }
    Ok((job, program, summary))
}

/// The `plan` summary as text.
pub fn summary_text(path: &Path, job: &Job, program: &Program, s: &Summary) -> String {
    use std::fmt::Write;
    let mut t = String::new();
    let m = &job.machine;
    let r = &s.report;
    let _ = writeln!(t, "job        {}", path.display());
    let _ =
        writeln!(t, "machine    {} axes ({}), tick {} Hz", m.axes.len(), m.axis_names(), m.tick_hz);
    let _ = writeln!(
        t,
        "moves      {} ({} skipped: no steps after rounding)",
        s.moves, s.skipped_moves
    );
    let _ = writeln!(
        t,
        "events     {} spindle, {} pause, {} feed commands",
        s.plan.spindle_events,
        s.plan.pauses,
        program.commands.len()
    );
    let _ = writeln!(
        t,
        "segments   {} planned, {} run by the model, {} underruns",
        s.plan.segments.len(),
        r.segments,
        r.underruns
    );
    let _ = writeln!(
        t,
        "time       {:.4} s ({} ticks); nominal {:.4} s",
        s.seconds(),
        r.ticks,
        s.plan.nominal_ticks as f64 / m.tick_hz as f64
    );
    let _ = writeln!(
        t,
        "{:<6} {:>12} {:>12} {:>12} {:>10} {:>10}",
        "axis", "final_steps", "final_mm", "steps_run", "peak_hz", "peak_mm_s"
    );
    for (i, a) in m.axes.iter().enumerate() {
        let _ = writeln!(
            t,
            "{:<6} {:>12} {:>12.4} {:>12} {:>10} {:>10.2}",
            a.name,
            r.positions[i],
            r.positions[i] as f64 / a.steps_per_mm,
            r.steps[i],
            r.peak_rate_hz[i],
            r.peak_rate_hz[i] as f64 / a.steps_per_mm
        );
    }
    t
}

/// Runs a parsed command line.
pub fn execute(cli: Cli) -> Result<()> {
    match cli.command {
        Cmd::Plan { job } => {
            let (parsed, program, summary) = plan_job(&job)?;
            print!("{}", summary_text(&job.job, &parsed, &program, &summary));
            Ok(())
        }
        Cmd::Run { job, link, log_csv } => {
            // Check the whole job before touching the link.
            let (_, program) = load_program(&job)?;
            plan::plan(&program).with_context(|| job.job.display().to_string())?;
            let _ = log_csv;
            let _link = transport::connect(&link.target()?)?;
            bail!("streaming a job is not implemented yet")
        }
        Cmd::Status { link } | Cmd::Hold { link } | Cmd::Resume { link } | Cmd::Abort { link } => {
            let _link = transport::connect(&link.target()?)?;
            bail!("link commands are not implemented yet")
        }
        Cmd::Override { factor, link } => {
            let _ = factor;
            let _link = transport::connect(&link.target()?)?;
            bail!("link commands are not implemented yet")
        }
    }
}

/// The binary's entry: one line on stderr and a non-zero exit code for any error.
pub fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            // --help, --version
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            let text = e.to_string();
            let first = text.lines().next().unwrap_or("invalid arguments");
            let first = first.strip_prefix("error: ").unwrap_or(first);
            eprintln!("motionctl: error: {first} (see motionctl --help)");
            return ExitCode::from(2);
        }
    };
    match execute(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let msg = format!("{e:#}").replace('\n', " ");
            eprintln!("motionctl: error: {msg}");
            ExitCode::FAILURE
        }
    }
}
