//! `motionctl milling ...`: a milling job (its force loop, spindle, cutter and cut) through the
//! closed-loop simulation (`simulate`) or on a board as a force job (`run`), summarised in the
//! job's units, as CSV, a plot, or JSON.

use super::figure::{self, Trace};
use super::resume::MillingResume;
use super::summary::{job_json, job_lines, SimSummary};
use super::{job, run, simulate};
use crate::plot::Style;
use anyhow::Result;
use clap::Subcommand;
use serde_json::json;
use std::path::PathBuf;

#[derive(Subcommand, Debug)]
// Parsed once per process: boxing the link arguments would buy nothing.
#[allow(clippy::large_enum_variant)]
pub enum MillingCmd {
    /// Run a milling job (version 2 TOML: [force] Fnom, thresholds, gains, strategy; [spindle]
    /// rpm; [cutter] diameter, teeth, feed per tooth; [cut] Kc, depths; see
    /// motionctl/examples/case_a_milling.toml) through the closed-loop force simulation: the
    /// firmware's force chain and control law, the DDA and the eq 4.17 milling plant.
    Simulate {
        job: PathBuf,
        /// Plot force (with Fnom +-10 %), feed and override against time (.svg or .png).
        #[arg(long, value_name = "FILE")]
        plot: Option<PathBuf>,
        /// Write the trace (one row per control update: s, N, override, mm/min) to this CSV.
        #[arg(long, value_name = "FILE")]
        csv: Option<PathBuf>,
        /// Print the summary as one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Run a milling job on the board as a force job (needs CAP_MILLING_JOB): the board's force
    /// chain and control law hold the force; on a simulator board (QEMU) its milling plant
    /// cuts. Logs force, override and feed vs board time, prints the summary and a
    /// `milling-summary k=v ...` line, and checks against the host model.
    Run {
        job: PathBuf,
        #[command(flatten)]
        link: crate::board_link::LinkArgs,
        /// Write every board status of the job to this CSV.
        #[arg(long, alias = "log-csv", value_name = "FILE")]
        csv: Option<PathBuf>,
        /// Plot the board's force, feed and override (and the host model's) against time
        /// (.svg or .png).
        #[arg(long, value_name = "FILE")]
        plot: Option<PathBuf>,
        /// Print the summary as one JSON object instead of text.
        #[arg(long)]
        json: bool,
        /// Simulator board only: inject a fault 5 mm into the cut: stuck0..2, saturated0..2,
        /// spindle-stop. The run then expects the hold with that fault's code.
        #[arg(long, value_name = "FAULT", value_parser = parse_sim_fault)]
        fault: Option<motion::protocol::SimForceFault>,
        /// Go on from where the last run of this job stopped (a board reset, a brown-out, a power
        /// loss: its `JOB.journal` keeps the position along the move): home, spindle on, the
        /// approach along the slot already cut, then the force loop re-armed with the job's
        /// nominal force and settings for the rest of the move.
        #[arg(long, conflicts_with = "fault")]
        resume: bool,
    },
}

fn parse_sim_fault(s: &str) -> Result<motion::protocol::SimForceFault, String> {
    use motion::protocol::SimForceFault as F;
    let channel = |rest: &str| match rest.parse::<u8>() {
        Ok(c) if c < 3 => Ok(c),
        _ => Err(format!("{s:?}: the channel must be 0, 1 or 2")),
    };
    if s == "spindle-stop" {
        Ok(F::SpindleStop)
    } else if let Some(rest) = s.strip_prefix("stuck") {
        Ok(F::Stuck { channel: channel(rest)? })
    } else if let Some(rest) = s.strip_prefix("saturated") {
        Ok(F::Saturated { channel: channel(rest)? })
    } else {
        Err(format!("{s:?}: expected stuckN, saturatedN or spindle-stop"))
    }
}

pub fn run_milling(cmd: MillingCmd) -> Result<()> {
    match cmd {
        MillingCmd::Simulate { job, plot, csv, json } => milling_simulate(&job, plot, csv, json),
        MillingCmd::Run { job, link, csv, plot, json, fault, resume } => {
            milling_board(&job, &link, csv, plot, json, fault, resume)
        }
    }
}

/// The simulation's trace as the figure's samples.
fn samples(trace: &[simulate::TracePoint]) -> Vec<figure::Sample> {
    trace.iter().map(|p| (p.t_s, p.force_n, p.feed_mm_min, p.override_)).collect()
}

fn milling_simulate(
    path: &std::path::Path,
    plot: Option<PathBuf>,
    csv: Option<PathBuf>,
    as_json: bool,
) -> Result<()> {
    let job = job::read(path)?;
    let (report, trace) = simulate::run(&job)?;
    let s = SimSummary::new(&report, motion::milling::scenario::TICK_HZ);
    if let Some(p) = &csv {
        simulate::write_csv(p, &trace)?;
        eprintln!("motionctl: wrote {}", p.display());
    }
    if let Some(p) = &plot {
        let pts = samples(&trace);
        let fig = figure::figure(
            &job,
            "milling simulate",
            &[Trace { label: "simulation", samples: &pts, style: Style::Line }],
        );
        figure::write(&fig, p)?;
    }
    if as_json {
        crate::outln!("{}", serde_json::to_string_pretty(&s.json(&job))?);
    } else {
        for l in job_lines(&job).into_iter().chain(s.lines(&job)) {
            crate::outln!("{l}");
        }
    }
    Ok(())
}

fn milling_board(
    path: &std::path::Path,
    link: &crate::board_link::LinkArgs,
    csv: Option<PathBuf>,
    plot: Option<PathBuf>,
    as_json: bool,
    fault: Option<motion::protocol::SimForceFault>,
    resume: bool,
) -> Result<()> {
    let job = job::read(path)?;
    // The journal is read, and the resume point checked against the job, before the link.
    let from = if resume { Some(resume_point(path, &job)?) } else { None };
    // An injected fault's run ends held on purpose: it keeps no journal to resume from.
    let journal = match fault {
        Some(_) => None,
        None => Some(crate::journal::Writer::new(path, 1)?.of_kind(run::JOURNAL_KIND)),
    };
    // The plain simulated board runs no force jobs: `--sim` gets the one that does.
    let (mut t, qemu_guard) = if link.sim {
        let board: Box<dyn crate::transport::Transport> =
            Box::new(super::sim_board::MillingSimBoard::new(1.0));
        (board, None)
    } else {
        link.open()?
    };
    let opts = run::MillingRunOptions {
        host: motion::protocol::HostConfig { rto_ms: 100, window: 8 },
        // QEMU's machine has no switches: homing there takes it where it stands.
        home: link.home || link.qemu,
        progress: !as_json,
        fault: fault.unwrap_or(motion::protocol::SimForceFault::None),
    };
    let mut hook = crate::runner::Unattended;
    let result = run::run_resumable(&mut *t, &job, &opts, journal, from.as_ref(), &mut hook);
    let r = crate::qemu::finish(qemu_guard, result)?;
    if let Some(p) = &csv {
        run::write_csv(p, &r.trace)?;
        eprintln!("motionctl: wrote {}", p.display());
    }
    if let Some(p) = &plot {
        let board = run::plot_points(&r.trace);
        let (_, model_trace) = simulate::run(&job)?;
        let model = samples(&model_trace);
        let fig = figure::figure(
            &job,
            "milling run",
            &[
                Trace { label: "board", samples: &board, style: Style::Line },
                Trace { label: "host model", samples: &model, style: Style::Dashed },
            ],
        );
        figure::write(&fig, p)?;
    }
    let ms = |v: Option<f64>| v.map(|v| v * 1e3);
    let board_s = r.board_ticks as f64 / motion::milling::scenario::TICK_HZ as f64;
    let fault_names = crate::runner::fault_names(r.faults);
    if as_json {
        let mut m = job_json(&job);
        for (k, v) in [
            ("x_mm", json!(r.x_steps as f64 / 1e3)),
            ("expected_x_mm", json!(r.expected_x_steps as f64 / 1e3)),
            ("faults", json!(if r.faults == 0 { None } else { Some(&fault_names) })),
            ("peak_force_n", json!(r.peak_n)),
            ("settle_ms", json!(ms(r.settle_s))),
            ("model_settle_ms", json!(ms(r.model_settle_s))),
            ("feed_after_step_mm_min", json!(r.feed_after_mm_min)),
            ("control_updates", json!(r.updates)),
            ("statuses", json!(r.trace.len())),
            ("board_s", json!(board_s)),
            ("wall_s", json!(r.seconds)),
            ("resumed_from_x_mm", json!(r.resumed_from_steps.map(|x| x as f64 / 1e3))),
            ("after_resume", json!(after_resume(&r).map(|a| a.json()))),
            ("ok", json!(r.ok())),
            ("problems", json!(r.problems)),
        ] {
            m.insert(k.to_string(), v);
        }
        crate::outln!("{}", serde_json::to_string_pretty(&m)?);
    } else {
        let opt_ms = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{:.1} ms", v * 1e3));
        for l in job_lines(&job) {
            crate::outln!("{l}");
        }
        crate::outln!(
            "board      {} statuses over {board_s:.3} s of board time, {} control updates; {:.2} \
             s wall",
            r.trace.len(),
            r.updates,
            r.seconds
        );
        crate::outln!(
            "X          {:.3} mm; host model {:.3} mm",
            r.x_steps as f64 / 1e3,
            r.expected_x_steps as f64 / 1e3
        );
        // A run resumed inside the cut met the work again at the resume point: its trace after
        // the depth step is not the first run's, and is not judged.
        let inside = r.resumed_from_steps.is_some_and(|x| x > job.setup.plant.wall_steps);
        if inside {
            crate::outln!(
                "force      peak {:.0} N (the re-entry); settling after the depth step not \
                 judged: resumed inside the cut",
                r.peak_n
            );
        } else {
            crate::outln!(
                "force      peak {:.0} N; back within +-10 % of Fnom {} after the depth step \
                 (host model {})",
                r.peak_n,
                opt_ms(r.settle_s),
                opt_ms(r.model_settle_s)
            );
            crate::outln!(
                "feed       {} 300..400 ms after the step",
                r.feed_after_mm_min.map_or("-".into(), |v| format!("{v:.1} mm/min"))
            );
        }
        if let Some(a) = after_resume(&r) {
            crate::outln!("{}", a.line(&job));
        }
        crate::outln!("faults     {}", if r.faults == 0 { "none" } else { &fault_names });
        // One machine-readable line for scripts (xtask milling-e2e).
        crate::outln!("{}", r.summary_line());
    }
    if !r.ok() {
        for p in &r.problems {
            eprintln!("motionctl: {p}");
        }
        anyhow::bail!("the milling run failed {} check(s)", r.problems.len());
    }
    Ok(())
}

/// The resume point of `path`'s milling job from its journal, checked against the job.
fn resume_point(path: &std::path::Path, job: &job::MillingJob) -> Result<MillingResume> {
    let entry = crate::journal::read_kind(path, run::JOURNAL_KIND)?;
    let Some(x) = entry.feed_axis_steps else {
        anyhow::bail!(
            "{}: the journal holds no position along the move (written before the cut began): \
             run the job from its start",
            crate::journal::path_for(path).display()
        );
    };
    MillingResume::new(job, x).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
}

/// What a resumed run's force loop did after the resume point.
struct AfterResume {
    from_mm: f64,
    statuses: usize,
    force_n: f64,
    mean_force_n: f64,
    min_override: f64,
}

/// The trace of a resumed run past its resume point, with the loop cutting.
fn after_resume(r: &run::MillingRunReport) -> Option<AfterResume> {
    let from = r.resumed_from_steps?;
    let cut: Vec<_> = r
        .trace
        .iter()
        .filter(|p| {
            p.x_steps >= from && p.phase == motion::milling::link_params::ForcePhase::Cutting
        })
        .collect();
    let last = cut.last()?;
    Some(AfterResume {
        from_mm: from as f64 / 1e3,
        statuses: cut.len(),
        force_n: last.force_n,
        mean_force_n: cut.iter().map(|p| p.force_n).sum::<f64>() / cut.len() as f64,
        min_override: cut.iter().map(|p| p.override_).fold(f64::INFINITY, f64::min),
    })
}

impl AfterResume {
    fn line(&self, job: &job::MillingJob) -> String {
        format!(
            "resumed    at move 1 of 1, X {:.3} mm; force loop re-armed (Fnom {:.0} N): {} \
             statuses cutting after it, force {:.0} N at the last (mean {:.0} N), override down \
             to {:.2}",
            self.from_mm,
            job.fnom_n,
            self.statuses,
            self.force_n,
            self.mean_force_n,
            self.min_override
        )
    }

    fn json(&self) -> serde_json::Value {
        json!({
            "from_x_mm": self.from_mm,
            "statuses_cutting": self.statuses,
            "last_force_n": self.force_n,
            "mean_force_n": self.mean_force_n,
            "min_override": self.min_override,
        })
    }
}
