//! The command line: argument parsing, job loading and the subcommands.

use crate::board_link;
pub use crate::board_link::LinkArgs;
use crate::convert::{self, Program};
use crate::gcode;
use crate::job::{self, Job};
use crate::link::{describe_rejection, Session};
use crate::plan::{self, Summary};
use crate::runner;
use anyhow::{anyhow, bail, Context, Result};
use clap::{Args, Parser, Subcommand, ValueEnum};
use motion::protocol::{Reply, RequestBody, MAX_OVERRIDE_BITS};
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
        /// Write every board status report to this CSV file (also `--log-csv`).
        #[arg(long = "csv", alias = "log-csv", value_name = "FILE")]
        log_csv: Option<PathBuf>,
        /// Never wait for the operator: a program pause (M0) continues at once.
        #[arg(long, short = 'y')]
        yes: bool,
        /// Board status report period, ms (0 = off; else >= 10).
        #[arg(long, value_name = "MS", default_value_t = runner::DEFAULT_STATUS_PERIOD_MS)]
        status_ms: u16,
        /// Go on from where the last run of this file stopped (its `FILE.journal`): Z up to the
        /// safe height, across, Z down, then the program from that G-code line (TOML: move).
        #[arg(long, conflicts_with = "resume_line")]
        resume: bool,
        /// Run from this G-code line, or a TOML job's move N counted from 1 (as --resume).
        #[arg(long, value_name = "LINE")]
        resume_line: Option<usize>,
        /// Print the summary as one JSON object instead of text.
        #[arg(long)]
        json: bool,
        /// A simulated board's probe surface for G38.x probe moves (--sim, --qemu): the probe
        /// touches while a machine axis is at or below (`z=-3.2` or `z<=-3.2`) or at or above
        /// (`x>=40`) that many mm from the job's origin.
        #[arg(long, value_name = "AXIS=MM")]
        sim_probe: Option<board_link::SimProbeSpec>,
    },
    /// The capabilities' subcommands (`polar`, `turning`, `milling`, `wire`): see
    /// [`crate::capabilities`].
    #[command(flatten)]
    Capability(crate::capabilities::CapabilityCmd),
    /// List every error and warning of a G-code program, file:line:column (exit 1 on an error).
    Check(crate::gcode::cli::CheckArgs),
    /// G-code tools: `moves` prints the canonical machining calls.
    #[command(subcommand)]
    Gcode(crate::gcode::cli::GcodeCmd),
    /// Speak grbl 1.1 to G-code senders (UGS, cncjs, bCNC, Candle) on a pseudo-terminal or
    /// TCP, with the board behind it.
    Grbl(crate::grbl::GrblArgs),
    /// Parse and plan a job offline and run it through the host model of the firmware.
    Plan {
        #[command(flatten)]
        job: JobArgs,
        /// Check and plan only: skip the host model's tick-by-tick run of every segment (most
        /// of the time on a long file); the summary then has the planned figures only.
        #[arg(long)]
        no_model: bool,
        /// Draw the programmed toolpath (3-D and from above, rapids apart from feeds, mm):
        /// FILE.svg or FILE.png.
        #[arg(long, value_name = "FILE")]
        plot: Option<PathBuf>,
        /// Print the summary as one JSON object instead of text.
        #[arg(long)]
        json: bool,
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
    /// Run the homing sequence and wait until the board is homed.
    Home {
        #[command(flatten)]
        link: LinkArgs,
    },
    /// Unlatch the board's faults (refused while a cause is still present).
    ClearFault {
        #[command(flatten)]
        link: LinkArgs,
    },
    /// After a limit fault: move the tripped axes slowly off their switches (then clear-fault).
    JogOffLimit {
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
    let name = path.display();
    match format {
        JobFormat::Toml => job::parse_toml(&read(path)?).with_context(|| name.to_string()),
        JobFormat::Gcode => {
            let machine = gcode_machine(path, machine)?;
            let loaded = gcode::load(path, &machine)?;
            for w in &loaded.warnings {
                eprintln!("motionctl: {w}");
            }
            Ok(Job { machine, items: loaded.items, feed_commands: Vec::new() })
        }
    }
}

/// A G-code job's machine: `machine`, or `machine.toml` beside the file.
fn gcode_machine(path: &Path, machine: Option<&Path>) -> Result<job::Machine> {
    let machine_path = match machine {
        Some(m) => m.to_path_buf(),
        None => {
            let beside = path.with_file_name("machine.toml");
            if !beside.exists() {
                bail!(
                    "{}: a G-code job needs a machine: pass --machine FILE \
                     (or put machine.toml beside it)",
                    path.display()
                );
            }
            beside
        }
    };
    job::parse_machine_toml(&read(&machine_path)?)
        .with_context(|| machine_path.display().to_string())
}

fn is_gcode(args: &JobArgs) -> Result<bool> {
    Ok(match args.format {
        Some(f) => f == JobFormat::Gcode,
        None => format_of(&args.job)? == JobFormat::Gcode,
    })
}

/// The first pass over a G-code job, streamed: every error, the plan and the host model's run,
/// in bounded memory (nothing of the job kept but counts). Warnings are printed.
pub fn check_gcode(args: &JobArgs) -> Result<(Job, gcode::stream::Checked)> {
    check_gcode_from(args, None)
}

/// [`check_gcode`] of the job run from `resume_line` (with the approach to it).
pub fn check_gcode_from(
    args: &JobArgs,
    resume_line: Option<usize>,
) -> Result<(Job, gcode::stream::Checked)> {
    let machine = gcode_machine(&args.job, args.machine.as_deref())?;
    let mut items = gcode::stream::items(&args.job, &machine)?;
    if let Some(line) = resume_line {
        items = items.resume_from(gcode::resume::ResumeAt::new(&machine, line)?);
    }
    // A bar for long files only; indicatif draws nothing when stderr is not a terminal.
    let long = std::fs::metadata(&args.job).is_ok_and(|m| m.len() > 1 << 20);
    let bar = if long {
        let bar = indicatif::ProgressBar::new_spinner();
        if let Ok(style) =
            indicatif::ProgressStyle::with_template("{spinner} checking: {pos} segments run")
        {
            bar.set_style(style);
        }
        bar
    } else {
        indicatif::ProgressBar::hidden()
    };
    let checked = gcode::stream::check_and_plan(items, |done| bar.set_position(done as u64));
    bar.finish_and_clear();
    let checked = accepted(args, checked)?;
    if let Some(line) = resume_line.filter(|_| checked.totals.segments == 0) {
        bail!("{}: nothing to resume: no move at or after line {line}", args.job.display());
    }
    print_warnings(args, &checked.warnings, checked.warnings_omitted);
    Ok((Job { machine, items: Vec::new(), feed_commands: Vec::new() }, checked))
}

/// A check's verdict with the whole-program path's messages (the G-code's errors as they are,
/// anything else after the file's name).
fn accepted<T>(args: &JobArgs, r: Result<T, gcode::stream::CheckError>) -> Result<T> {
    use gcode::stream::{CheckError, Refusal};
    match r {
        Ok(c) => Ok(c),
        Err(CheckError::Refused(Refusal::Gcode(e))) => Err(e.into()),
        Err(e) => Err(anyhow!(e).context(args.job.display().to_string())),
    }
}

fn print_warnings(args: &JobArgs, warnings: &[String], omitted: usize) {
    for w in warnings {
        eprintln!("motionctl: {w}");
    }
    if omitted > 0 {
        eprintln!("motionctl: {}: {omitted} more warnings not shown", args.job.display());
    }
}

/// `plan --no-model`: check and plan, without the host model's tick-by-tick run (G-code
/// streamed as for `plan`). The summary says what was planned and where the job ends.
fn plan_without_model(args: &JobArgs, json: bool) -> Result<String> {
    let (machine, commands, totals, final_steps) = if is_gcode(args)? {
        let machine = gcode_machine(&args.job, args.machine.as_deref())?;
        let items = gcode::stream::items(&args.job, &machine)?;
        let p = accepted(args, gcode::stream::check_and_plan_only(items))?;
        print_warnings(args, &p.warnings, p.warnings_omitted);
        (machine, 0, p.totals, p.program.final_steps)
    } else {
        let (job, program) = load_program(args)?;
        let planned = plan::plan(&program).with_context(|| args.job.display().to_string())?;
        let totals = plan::Totals {
            moves: program.moves().count(),
            skipped_moves: program.skipped_moves,
            segments: planned.segments.len(),
            spindle_events: planned.spindle_events,
            pauses: planned.pauses,
            dwells: planned.dwells,
            dwell_ms: planned.dwell_ms,
            probes: planned.probes,
            nominal_ticks: planned.nominal_ticks,
        };
        (job.machine, program.commands.len(), totals, program.final_steps)
    };
    if json {
        let v = plan::summary_json(&args.job, &machine, &totals, None, &final_steps);
        return Ok(format!("{v}\n"));
    }
    Ok(plan::plan_text(&args.job, &machine, commands, &totals, &final_steps))
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
    plan::summary_text(path, &job.machine, program.commands.len(), &s.totals(), &s.report)
}

/// `plan --plot FILE`: the job's programmed toolpath (the job was checked already).
fn plot_toolpath(args: &JobArgs, plot: Option<&Path>) -> Result<()> {
    let Some(p) = plot else { return Ok(()) };
    let job = load_job(&args.job, args.format, args.machine.as_deref())?;
    let title = format!(
        "plan {}: toolpath on {} axes ({})",
        args.job.display(),
        job.machine.axes.len(),
        job.machine.axis_names()
    );
    crate::plan_figure::toolpath_figure(&job.machine, &job.items, &title).save(p)
}

/// Runs a parsed command line.
pub fn execute(cli: Cli) -> Result<()> {
    match cli.command {
        Cmd::Plan { job, no_model: true, plot, json } => {
            crate::out!("{}", plan_without_model(&job, json)?);
            plot_toolpath(&job, plot.as_deref())
        }
        Cmd::Plan { job, plot, json, .. } if is_gcode(&job)? => {
            let (parsed, c) = check_gcode(&job)?;
            if json {
                let v = plan::summary_json(
                    &job.job,
                    &parsed.machine,
                    &c.totals,
                    Some(&c.report),
                    &c.program.final_steps,
                );
                crate::outln!("{v}");
            } else {
                let text = plan::summary_text(&job.job, &parsed.machine, 0, &c.totals, &c.report);
                crate::out!("{text}");
            }
            plot_toolpath(&job, plot.as_deref())
        }
        Cmd::Plan { job, plot, json, .. } => {
            let (parsed, program, summary) = plan_job(&job)?;
            if json {
                let v = plan::summary_json(
                    &job.job,
                    &parsed.machine,
                    &summary.totals(),
                    Some(&summary.report),
                    &program.final_steps,
                );
                crate::outln!("{v}");
            } else {
                crate::out!("{}", summary_text(&job.job, &parsed, &program, &summary));
            }
            plot_toolpath(&job, plot.as_deref())
        }
        Cmd::Run { job, link, log_csv, yes, status_ms, resume, resume_line, json, sim_probe } => {
            let from = match (resume, resume_line) {
                (true, _) => Some(crate::journal::read(&job.job)?.line),
                (false, line) => line,
            };
            let how = board_link::Reporting {
                log_csv: log_csv.as_deref(),
                yes,
                status_ms,
                json,
                journal: None,
                sim_probe,
            };
            run_job(&job, &link, how, from)
        }
        Cmd::Check(args) => crate::gcode::cli::check(args),
        Cmd::Gcode(cmd) => crate::gcode::cli::run(cmd),
        Cmd::Grbl(args) => crate::grbl::run(args),
        Cmd::Capability(cmd) => crate::capabilities::run(cmd),
        Cmd::Status { link } => one_request(&link, RequestBody::GetStatus, "status"),
        Cmd::Hold { link } => one_request(&link, RequestBody::Hold, "hold"),
        Cmd::Resume { link } => one_request(&link, RequestBody::Resume, "resume"),
        Cmd::Abort { link } => one_request(&link, RequestBody::Abort, "abort"),
        Cmd::ClearFault { link } => one_request(&link, RequestBody::ClearFault, "clear-fault"),
        Cmd::JogOffLimit { link } => one_request(&link, RequestBody::JogOffLimit, "jog-off-limit"),
        Cmd::Home { link } => home_board(&link),
        Cmd::Override { factor, link } => {
            let rate_bits = ((factor * (1u64 << 30) as f64).round() as u32).min(MAX_OVERRIDE_BITS);
            one_request(&link, RequestBody::SetOverride { rate_bits }, "override")
        }
    }
}

/// `run`: plan (and check on the host model), then stream and verify.
fn run_job(
    job: &JobArgs,
    link: &LinkArgs,
    how: board_link::Reporting<'_>,
    resume_line: Option<usize>,
) -> Result<()> {
    if is_gcode(job)? {
        return run_gcode(job, link, how, resume_line);
    }
    // Check the whole job, and learn where it must end, before touching the link.
    let (parsed, program, _) = plan_job(job)?;
    let label = job.job.display().to_string();
    if let Some(entry) = resume_line {
        let say = format!(
            "resume     from move {entry} (moves[{}]): Z up to the safe height, across, down to \
             its start, then the job (the machine must stand at the job's origin: home it first)",
            entry.saturating_sub(1)
        );
        if how.json {
            eprintln!("motionctl: {}", say.split_whitespace().collect::<Vec<_>>().join(" "));
        } else {
            crate::outln!("{say}");
        }
    }
    let run = crate::toml_run::TomlRun::new(&label, &parsed.machine, &program, resume_line)?;
    let journal = crate::journal::Writer::new(&job.job, run.segments())?;
    board_link::stream_outputs(
        &label,
        &parsed,
        &run.program,
        run.stream(),
        &run.expected,
        link,
        board_link::Reporting { journal: Some(journal), ..how },
    )
}

/// `run` for G-code, in two streamed passes: the first checks the whole file, plans it and runs
/// it through the host model (a file with any error is refused here, before the link is
/// touched); the second reads it again and plans it as the board takes the segments.
fn run_gcode(
    job: &JobArgs,
    link: &LinkArgs,
    how: board_link::Reporting<'_>,
    resume_line: Option<usize>,
) -> Result<()> {
    let (parsed, checked) = check_gcode_from(job, resume_line)?;
    let label = job.job.display().to_string();
    let segments = u32::try_from(checked.totals.segments).map_err(|_| {
        anyhow!("{label}: {} segments, more than a run counts", checked.totals.segments)
    })?;
    let mut items = gcode::stream::items(&job.job, &parsed.machine)?;
    if let Some(line) = resume_line {
        let at = gcode::resume::ResumeAt::new(&parsed.machine, line)?;
        let z = parsed.machine.axis_index("Z").map(|i| &parsed.machine.axes[i]);
        let say = format!(
            "resume     from line {line}: Z up to {:.3} mm, across, down to {} mm above, the \
             rest at {:.0} mm/min, then the program (the machine must stand at the job's origin: \
             home it first)",
            z.map_or(0.0, |a| a.max_mm),
            gcode::resume::PLUNGE_CLEARANCE_MM,
            z.map_or(0.0, |a| a.max_rate_mm_s * 60.0 * gcode::resume::PLUNGE_FRACTION_OF_Z_MAX)
        );
        if how.json {
            eprintln!("motionctl: {}", say.split_whitespace().collect::<Vec<_>>().join(" "));
        } else {
            crate::outln!("{say}");
        }
        items = items.resume_from(at);
    }
    let outputs = gcode::stream::outputs(items, &checked, &label, segments);
    let journal = crate::journal::Writer::new(&job.job, segments)?;
    let mut expected = [0i64; motion::MAX_AXES];
    expected.copy_from_slice(&checked.report.positions[..motion::MAX_AXES]);
    board_link::stream_outputs(
        &job.job.display().to_string(),
        &parsed,
        &checked.program,
        outputs,
        &expected,
        link,
        board_link::Reporting { journal: Some(journal), ..how },
    )
}

/// `status`, `hold`, `resume`, `abort`, `override`: one request, its answer printed.
/// `home`: Home, then wait for the board to report itself homed.
fn home_board(link: &LinkArgs) -> Result<()> {
    if link.qemu {
        bail!("--qemu starts a fresh board for `run` only (which homes it); use --tcp HOST:PORT");
    }
    let target = link.target()?;
    let (mut t, _guard) = link.open()?;
    let mut s = Session::new(&mut t, link.host_config(&target));
    let info = s.connect()?;
    runner::home(&mut s, info.tick_hz, &|m: &str| crate::outln!("motionctl: {m}"))
        .map_err(|e| anyhow!("{e}"))
}

fn one_request(link: &LinkArgs, body: RequestBody, what: &str) -> Result<()> {
    if link.qemu {
        bail!(
            "--qemu starts a fresh board for `run` only; for a QEMU already running use \
             --tcp HOST:PORT"
        );
    }
    let target = link.target()?;
    let (mut t, _guard) = link.open()?;
    let mut s = Session::new(&mut t, link.host_config(&target));
    let info = s.connect()?;
    let scale = match s.request(RequestBody::GetConfig)? {
        Ok(Reply::Config(c)) => Some(c),
        _ => None,
    };
    match s.request(body)? {
        Err(r) => bail!("{what} refused: {}", describe_rejection(&r)),
        Ok(Reply::Status(st)) => {
            crate::outln!("board      {} (protocol v{})", info.firmware.as_str(), info.version);
            let jobs: Vec<&str> =
                motion::capabilities::on_board(info.capabilities).map(|c| c.name).collect();
            crate::outln!(
                "jobs       G-code{}{}",
                if jobs.is_empty() { "" } else { ", " },
                jobs.join(", ")
            );
            if let Some(p) = &info.last_panic {
                crate::outln!(
                    "last panic {}:{}:{} (before the last reset)",
                    p.file.as_str(),
                    p.line,
                    p.column
                );
            }
            crate::outln!(
                "state      {:?} ({}), motion {:?}, tick {}",
                st.machine,
                if st.homed { "homed" } else { "not homed" },
                st.state,
                st.tick
            );
            for i in 0..info.axes as usize {
                let spm = scale
                    .map(|c| c.scale[i].steps_per_unit_milli as f64 / 1000.0)
                    .filter(|&v| v > 0.0);
                match spm {
                    Some(spm) => crate::outln!(
                        "axis {i}     {} steps ({:.4} mm)",
                        st.positions[i],
                        st.positions[i] as f64 / spm
                    ),
                    None => crate::outln!("axis {i}     {} steps", st.positions[i]),
                }
            }
            let ovr = motion::Rate::from_bits(st.override_bits).to_num::<f64>();
            crate::outln!("override   {ovr:.3}");
            crate::outln!("queue      {} queued, {} free", st.queue_depth, st.credits);
            crate::outln!("segments   {} done, last id {:?}", st.segments_done, st.last_done_id);
            crate::outln!("counters   {} (since boot)", runner::counters_text(&st.counters));
            if st.faults != 0 {
                let names: Vec<&str> = motion::protocol::FaultCode::ALL
                    .iter()
                    .filter(|f| st.faults & f.bit() != 0)
                    .map(|f| f.name())
                    .collect();
                crate::outln!("faults     {}", names.join(", "));
            }
            if st.causes != 0 {
                let names: Vec<&str> = motion::protocol::FaultCode::ALL
                    .iter()
                    .filter(|f| st.causes & f.bit() != 0)
                    .map(|f| f.name())
                    .collect();
                crate::outln!(
                    "causes     {} (present now: clear-fault waits for them)",
                    names.join(", ")
                );
            }
        }
        Ok(_) => crate::outln!("{what}: ok"),
    }
    Ok(())
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
    match execute(cli).and_then(|()| crate::out::finish().map_err(|e| anyhow!(e))) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let msg = format!("{e:#}").replace('\n', " ");
            eprintln!("motionctl: error: {msg}");
            ExitCode::FAILURE
        }
    }
}
