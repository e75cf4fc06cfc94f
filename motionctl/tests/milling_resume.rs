//! A constant-force milling job cut by a power loss at seeded points along its move, on the
//! in-process simulated force board (the firmware's DDA and force job, the simulated plant),
//! then resumed from its journal as `milling run --resume` does: the resumed run homes, turns
//! the spindle on, approaches along the slot already cut and re-arms the force loop; it ends at
//! the uncut run's final position, steps the uncut run's path from the resume point on (each
//! position once, in order), and its force loop holds the force at the job's nominal value
//! after the resume as in the uncut run. `--resume` with no journal, or with another kind of
//! run's journal, fails before the link with a message naming the journal.

use motion::milling::link_params::ForcePhase;
use motion::protocol::{HostConfig, SimForceFault};
use motionctl::journal;
use motionctl::milling::job::{self, MillingJob};
use motionctl::milling::resume::MillingResume;
use motionctl::milling::run::{self, BoardPoint, MillingRunOptions, MillingRunReport};
use motionctl::milling::sim_board::MillingSimBoard;
use motionctl::runner::Unattended;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

const JOB: &str = include_str!("../examples/case_a_milling.toml");
/// Machine time per wall time on the simulated board.
const SPEED: f64 = 4.0;
/// The cuts, from a fixed seed.
const CUTS: usize = 4;
const SEED: u32 = 0x5eed;
/// The force is compared over this stretch before the move's end (mm before the end): past
/// the re-entry's and the depth step's transients, before the final deceleration.
const STEADY_FROM_END_MM: (f64, f64) = (1.5, 0.3);
/// Cuts fall at least this far before the move's end, so the resumed run has a steady stretch.
const CUT_BEFORE_END_MM: f64 = 2.5;
/// The journal trails the cut by at most this much, steps: the board runs only inside the
/// host's calls, at most 50 ms of machine time per call, and streams a status every 10 ms; at the
/// 12.7 mm/s rapid feed that is under 0.8 mm whatever the load.
const JOURNAL_LAG_STEPS: i64 = 1_500;
/// The settling band: +-10 % of the nominal force.
const BAND: f64 = 0.10;

fn options() -> MillingRunOptions {
    MillingRunOptions {
        host: HostConfig { rto_ms: 100, window: 8 },
        home: true,
        progress: false,
        fault: SimForceFault::None,
    }
}

/// Runs the job file on `board` as `milling run [--resume]` does: the journal kept at every
/// status, the resume point read back from it.
fn run_job(
    file: &Path,
    resume: bool,
    board: &mut MillingSimBoard,
) -> Result<MillingRunReport, String> {
    let job = job::read(file).unwrap();
    let plan = if resume {
        let e = journal::read_kind(file, run::JOURNAL_KIND).map_err(|e| format!("{e:#}"))?;
        Some(MillingResume::new(&job, e.feed_axis_steps.unwrap()).unwrap())
    } else {
        None
    };
    let w = journal::Writer::new(file, 1).unwrap().of_kind(run::JOURNAL_KIND).every(Duration::ZERO);
    run::run_resumable(board, &job, &options(), Some(w), plan.as_ref(), &mut Unattended)
        .map_err(|e| format!("{e:#}"))
}

fn board(cut_at_steps: Option<i64>) -> MillingSimBoard {
    let mut b = MillingSimBoard::new(SPEED);
    b.power_cut_at_steps = cut_at_steps;
    b.path = Some(Vec::new());
    b
}

/// Mean force (N) of the statuses cutting within the steady stretch before the move's end.
fn steady_force_n(trace: &[BoardPoint], job: &MillingJob) -> f64 {
    let end = job.setup.move_steps as i64;
    let (far, near) = STEADY_FROM_END_MM;
    let span = (end - (far * 1e3) as i64)..(end - (near * 1e3) as i64);
    let f: Vec<f64> = trace
        .iter()
        .filter(|p| span.contains(&p.x_steps) && p.phase == ForcePhase::Cutting)
        .map(|p| p.force_n)
        .collect();
    assert!(f.len() >= 5, "{} statuses in the steady stretch", f.len());
    f.iter().sum::<f64>() / f.len() as f64
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("milling_resume_{}_{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn a_milling_job_cut_at_seeded_points_resumes_on_the_uncut_runs_path_with_its_force_loop() {
    let dir = temp_dir("cuts");
    let file = dir.join("job.toml");
    std::fs::write(&file, JOB).unwrap();
    let job = job::read(&file).unwrap();
    let end = job.setup.move_steps as i64;

    let mut b = board(None);
    let whole = run_job(&file, false, &mut b).unwrap();
    assert!(whole.ok(), "{:?}", whole.problems);
    assert_eq!(whole.x_steps, end);
    let w = b.path.take().unwrap();
    // One step at a time from the start to the end.
    assert_eq!(w, (1..=end).collect::<Vec<_>>());
    assert!(!journal::path_for(&file).exists(), "a finished run leaves no journal");
    let whole_force = steady_force_n(&whole.trace, &job);
    assert!((whole_force - job.fnom_n).abs() <= BAND * job.fnom_n, "{whole_force} N");

    let mut x = SEED;
    let latest_cut = end - (CUT_BEFORE_END_MM * 1e3) as i64;
    for k in 0..CUTS {
        x = x.wrapping_mul(1_103_515_245).wrapping_add(12_345);
        // The first cut before the wall, the others anywhere up to `latest_cut`.
        let span = if k == 0 { job.setup.plant.wall_steps } else { latest_cut };
        let cut = 1 + ((x >> 8) as i64 % (span - 1));
        let mut b = board(Some(cut));
        let e = run_job(&file, false, &mut b).unwrap_err();
        assert!(e.contains("--resume"), "cut at {cut}: {e}");
        assert_eq!(b.power_cuts, 1);
        let c = b.path.take().unwrap();
        assert_eq!(c[..], w[..c.len()], "cut at {cut}: the cut run followed the uncut one");
        assert_eq!(*c.last().unwrap(), cut);
        let entry = journal::read_kind(&file, run::JOURNAL_KIND).unwrap();
        let from = entry.feed_axis_steps.unwrap();
        // Never ahead of the cut, and kept up during it (the bound is loose: the host polls on
        // the wall clock, the board runs faster than real time).
        assert!(from <= cut && cut - from <= JOURNAL_LAG_STEPS, "cut at {cut}: journal at {from}");

        // Power back: a fresh board, homed by the resumed run.
        let mut b = board(None);
        let r = run_job(&file, true, &mut b).unwrap();
        assert!(r.ok(), "cut at {cut}, resumed at {from}: {:?}", r.problems);
        assert_eq!((r.x_steps, r.resumed_from_steps), (end, Some(from)), "cut at {cut}");
        let p = b.path.take().unwrap();
        assert_eq!(*p.last().unwrap(), end, "cut at {cut}: final position");
        // The approach, then from the resume point on the uncut run's path: every position
        // once, in order.
        let at = p.iter().position(|&x| x > from).unwrap();
        let tail = &w[(from as usize)..];
        assert_eq!(&p[at..], tail, "cut at {cut}, resumed at {from}");
        assert!(p[..at].windows(2).all(|s| s[1] == s[0] + 1), "cut at {cut}: approach path");
        // The force loop after the resume: control updates, statuses cutting, the override
        // below 1 where the force would pass Fnom, the force held at Fnom as in the uncut run.
        assert!(r.updates > 0, "cut at {cut}");
        let after: Vec<_> = r.trace.iter().filter(|q| q.x_steps >= from).collect();
        assert!(after.iter().any(|q| q.phase == ForcePhase::Cutting), "cut at {cut}");
        assert!(after.iter().any(|q| q.override_ < 0.9), "cut at {cut}: the loop never throttled");
        let force = steady_force_n(&r.trace, &job);
        assert!(
            (force - whole_force).abs() <= BAND * job.fnom_n,
            "cut at {cut}: {force:.0} N after the resume, {whole_force:.0} N uncut"
        );
        assert!(r.peak_n <= job.trip_n, "cut at {cut}: peak {:.0} N", r.peak_n);
        assert!(!journal::path_for(&file).exists(), "cut at {cut}: the journal stays");
        eprintln!(
            "cut at X {:.3} mm: resumed from {:.3} mm ({} steps up to it), steady force \
             {force:.0} N (uncut {whole_force:.0} N), {} control updates",
            cut as f64 / 1e3,
            from as f64 / 1e3,
            at,
            r.updates
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `motionctl milling run JOB --resume --sim`.
fn resume_cli_output(file: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_motionctl"))
        .args(["milling", "run"])
        .arg(file)
        .args(["--resume", "--sim"])
        .output()
        .unwrap()
}

/// [`resume_cli_output`]'s exit status and stderr.
fn resume_cli(file: &Path) -> (bool, String) {
    let out = resume_cli_output(file);
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

#[test]
fn resume_without_a_journal_or_with_another_runs_journal_is_refused() {
    let dir = temp_dir("refused");
    let file = dir.join("job.toml");
    std::fs::write(&file, JOB).unwrap();
    let (ok, err) = resume_cli(&file);
    assert!(!ok && err.contains("no journal to resume from"), "{err}");
    assert!(err.contains("job.toml.journal"), "{err}");

    // A G-code run's journal for this file (no kind): not a milling run's.
    let mut w = journal::Writer::new(&file, 3).unwrap().every(Duration::ZERO);
    assert_eq!(w.update(Some(2), 1), None);
    let (ok, err) = resume_cli(&file);
    assert!(!ok && err.contains("not a milling run's"), "{err}");

    // A milling journal of the file before it was edited: refused by its CRC.
    let mut w = journal::Writer::new(&file, 1).unwrap().of_kind(run::JOURNAL_KIND);
    assert_eq!(w.update_along(1, 0, 4_000), None);
    std::fs::write(&file, format!("{JOB}\n# edited\n")).unwrap();
    let (ok, err) = resume_cli(&file);
    assert!(!ok && err.contains("changed since the journal was written"), "{err}");

    // A position outside the job's move.
    std::fs::write(&file, JOB).unwrap();
    let mut w = journal::Writer::new(&file, 1).unwrap().of_kind(run::JOURNAL_KIND);
    assert_eq!(w.update_along(1, 0, 900_000), None);
    let (ok, err) = resume_cli(&file);
    assert!(!ok && err.contains("not inside the job's move"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `milling run --resume --sim` from a journal at 8 mm: the output says where it resumed (move,
/// X in mm) and what the force loop did after it, and the finished run removes the journal.
#[test]
fn the_resumed_run_says_where_it_went_on_and_what_the_force_loop_did() {
    let dir = temp_dir("cli");
    let file = dir.join("job.toml");
    std::fs::write(&file, JOB).unwrap();
    let mut w = journal::Writer::new(&file, 1).unwrap().of_kind(run::JOURNAL_KIND);
    assert_eq!(w.update_along(1, 0, 8_000), None);
    let out = resume_cli_output(&file);
    let (stdout, stderr) =
        (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "{stdout}\n{stderr}");
    for said in [
        "resuming at move 1 of 1, X 8.000 mm",
        "spindle on (clockwise)",
        "approach: X 0.000 -> 7.000 mm",
        "spindle off",
    ] {
        assert!(stderr.contains(said), "{said:?} not in {stderr}");
    }
    let line = stdout.lines().find(|l| l.starts_with("resumed ")).unwrap_or_default();
    assert!(
        line.contains("at move 1 of 1, X 8.000 mm; force loop re-armed (Fnom 4100 N)"),
        "{stdout}"
    );
    assert!(stdout.contains("ok=true"), "{stdout}");
    assert!(!journal::path_for(&file).exists());
    std::fs::remove_dir_all(&dir).unwrap();
}
