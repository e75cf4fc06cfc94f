//! Power cut at ten seeded points of a G-code job on the simulated board (in-process, many
//! times real time), and at five of a TOML job: each cut loses the board's state (a fresh board,
//! not homed, queue gone), `run --resume` goes on from the run journal's cursor (the G-code line,
//! the TOML move), and the resumed run ends at the whole run's final position along the whole
//! run's path from there on (each segment once, after the documented approach), while the path
//! before the cut was the whole run's too.

use motion::protocol::HostConfig;
use motion::MAX_AXES;
use motionctl::cli::{check_gcode_from, JobArgs};
use motionctl::convert::ProgramItem;
use motionctl::gcode::resume::ResumeAt;
use motionctl::gcode::stream;
use motionctl::job::Source;
use motionctl::journal;
use motionctl::runner::{self, RunOptions, RunReport};
use motionctl::sim_board::{SimBoard, SimTrouble, SIM_CAPACITY};
use motionctl::toml_run::TomlRun;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Machine time per wall time on the simulated board.
const SPEED: f64 = 20.0;
/// The cuts, from a fixed seed.
const CUTS: usize = 10;
const TOML_CUTS: usize = 5;
const SEED: u32 = 0x5eed;
/// The approach of a resumed run at most: Z up, across, rapid down, plunge, and the spindle's
/// spin-up dwell.
const APPROACH_SEGMENTS: usize = 5;
/// Passes of the job (one G-code line each).
const PASSES: usize = 18;

/// The bench router (Z's safe height 0): spindle on, plunge, then passes moving X, Y and Z
/// together, Z up, spindle off.
fn program() -> String {
    let mut s = String::from("G21 G90\nG0 X5 Y5\nM3 S8000\nG1 Z-2 F300\n");
    for i in 0..PASSES {
        let (x, y, z) = (5 + (i % 2) * 12, 5 + i * 2, -2.0 - (i % 3) as f64 * 0.5);
        s.push_str(&format!("G1 X{x} Y{y} Z{z:.1} F1500\n"));
    }
    s.push_str("G0 Z0\nM5\nM2\n");
    s
}

fn machine() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/machine.toml")
}

/// Runs the job (from `resume` when given) on `board` as `motionctl run [--resume-line]` does:
/// the checked pass, the outputs planned as the link takes them, the journal kept at every move.
/// Returns the run's result and its segment count.
fn run(
    file: &Path,
    resume: Option<usize>,
    board: &mut SimBoard,
) -> (Result<RunReport, String>, u32) {
    let args = JobArgs { job: file.to_path_buf(), format: None, machine: Some(machine()) };
    let (job, checked) = check_gcode_from(&args, resume).unwrap();
    let segments = checked.totals.segments as u32;
    let mut items = stream::items(file, &job.machine).unwrap();
    if let Some(line) = resume {
        items = items.resume_from(ResumeAt::new(&job.machine, line).unwrap());
    }
    let outputs = stream::outputs(items, &checked, "job", segments);
    let mut expected = [0i64; MAX_AXES];
    expected.copy_from_slice(&checked.report.positions[..MAX_AXES]);
    let opts = options(file, segments);
    let r = runner::run_outputs(board, &job, &checked.program, outputs, &expected, opts);
    (r.map_err(|e| e.to_string()), segments)
}

/// The run options of `run --sim`, the journal kept at every move and the status at its
/// fastest (the simulated board runs many times faster than real time).
fn options(file: &Path, segments: u32) -> RunOptions {
    RunOptions {
        host: HostConfig { rto_ms: 20, window: 8 },
        status_period_ms: motion::protocol::MIN_STATUS_PERIOD_MS,
        home: true,
        journal: Some(journal::Writer::new(file, segments).unwrap().every(Duration::ZERO)),
        ..RunOptions::default()
    }
}

/// [`run`] for a TOML job, as `motionctl run JOB.toml [--resume-line]` does.
fn run_toml(
    file: &Path,
    resume: Option<usize>,
    board: &mut SimBoard,
) -> (Result<RunReport, String>, u32) {
    let args = JobArgs { job: file.to_path_buf(), format: None, machine: None };
    let (job, program) = motionctl::cli::load_program(&args).unwrap();
    let run = TomlRun::new("job", &job.machine, &program, resume).unwrap();
    let opts = options(file, run.segments());
    let r = runner::run_outputs(board, &job, &run.program, run.stream(), &run.expected, opts);
    (r.map_err(|e| e.to_string()), run.segments())
}

/// The TOML job: the bench router's machine, spindle on, a plunge, then moves in X, Y and Z.
fn toml_job() -> String {
    let mut s = std::fs::read_to_string(machine()).unwrap();
    s.push_str(
        "\n[[moves]]\nto = { X = 5.0, Y = 5.0 }\nrapid = true\n\n[[moves]]\nspindle = \"on\"\n",
    );
    s.push_str("\n[[moves]]\nto = { Z = -2.0 }\nfeed_mm_min = 300.0\n");
    for i in 0..PASSES {
        let (x, y, z) = (5 + (i % 2) * 12, 5 + i * 2, -2.0 - (i % 3) as f64 * 0.5);
        s.push_str(&format!(
            "\n[[moves]]\nto = {{ X = {x}.0, Y = {y}.0, Z = {z:.1} }}\nfeed_mm_min = 1500.0\n"
        ));
    }
    s.push_str("\n[[moves]]\nto = { Z = 0.0 }\nrapid = true\n\n[[moves]]\nspindle = \"off\"\n");
    s
}

fn board(reset_at_segment: Option<u32>) -> SimBoard {
    let mut b = SimBoard::new(SIM_CAPACITY, SPEED);
    b.trouble = SimTrouble { reset_at_segment, ..Default::default() };
    b.path = Some(Vec::new());
    b
}

/// The G-code line of every move of the whole program, in order.
fn move_lines(file: &Path) -> Vec<usize> {
    let m = motionctl::job::parse_machine_toml(&std::fs::read_to_string(machine()).unwrap());
    stream::items(file, &m.unwrap())
        .unwrap()
        .map(Result::unwrap)
        .filter_map(|i| match i {
            ProgramItem::Move { source: Source::Gcode { line }, .. } => Some(line),
            _ => None,
        })
        .collect()
}

/// Largest per-axis difference, steps.
fn off_by(a: &[i64; MAX_AXES], b: &[i64; MAX_AXES]) -> i64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).max().unwrap_or(0)
}

#[test]
fn power_cut_at_ten_seeded_points_then_resume_ends_on_the_whole_runs_path() {
    let dir = temp_dir("gcode");
    let file = dir.join("job.ngc");
    std::fs::write(&file, program()).unwrap();
    let lines = move_lines(&file);
    cut_and_resume(&file, &lines, CUTS, run);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_toml_job_cut_at_five_seeded_points_resumes_from_its_journal_move() {
    let dir = temp_dir("toml");
    let file = dir.join("job.toml");
    std::fs::write(&file, toml_job()).unwrap();
    let args = JobArgs { job: file.clone(), format: None, machine: None };
    let (job, program) = motionctl::cli::load_program(&args).unwrap();
    let whole = TomlRun::new("job", &job.machine, &program, None).unwrap();
    // Each segment's move, counted from 1.
    let moves: Vec<usize> = whole
        .outputs
        .iter()
        .filter(|(o, _)| matches!(o, motionctl::plan::Output::Segment(_)))
        .map(|(_, m)| m.unwrap())
        .collect();
    cut_and_resume(&file, &moves, TOML_CUTS, run_toml);
    // Resuming from past the last move is refused.
    let e = TomlRun::new("job", &job.machine, &program, Some(999)).err().unwrap();
    assert!(e.to_string().contains("nothing to resume"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("power_cut_{}_{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A run of a job file from its start or a resume point: its result and its segment count.
type RunFn = fn(&Path, Option<usize>, &mut SimBoard) -> (Result<RunReport, String>, u32);

/// The whole run, then `cuts` runs cut at seeded segments, each resumed from its journal's
/// cursor; `lines` = each segment's cursor (line or move) in the whole run.
fn cut_and_resume(file: &Path, lines: &[usize], cuts: usize, run: RunFn) {
    let mut b = board(None);
    let (whole, segments) = run(file, None, &mut b);
    let whole = whole.unwrap();
    assert!(whole.ok(), "{:?}", whole.problems);
    let w = b.path.take().unwrap();
    // One segment per move, so a segment's line is its move's.
    assert_eq!((w.len(), lines.len()), (segments as usize, segments as usize));
    let end = *w.last().unwrap();
    assert_eq!(whole.positions[..3], end[..3]);

    let mut x = SEED;
    for _ in 0..cuts {
        x = x.wrapping_mul(1_103_515_245).wrapping_add(12_345);
        let cut = 1 + (x >> 8) % (segments - 1);
        let mut b = board(Some(cut));
        let e = run(file, None, &mut b).0.unwrap_err();
        assert!(e.contains("the board reset"), "cut at {cut}: {e}");
        let c = b.path.take().unwrap();
        // Until the cut the machine followed the whole run.
        assert!(c.len() >= cut as usize && c.len() < w.len(), "cut at {cut}: {}", c.len());
        assert_eq!(c[..], w[..c.len()], "cut at {cut}");
        let line = journal::read(file).unwrap().line;
        // Nothing skipped: the resume line is at or before the first line not finished.
        assert!(line <= lines[c.len()], "cut at {cut}: line {line} after {}", lines[c.len()]);

        // Power back: a fresh board (positions and queue lost), homed by the run.
        let mut b = board(None);
        let (resumed, resumed_segments) = run(file, Some(line), &mut b);
        let resumed = resumed.unwrap();
        assert!(resumed.ok(), "cut at {cut}, line {line}: {:?}", resumed.problems);
        let r = b.path.take().unwrap();
        assert_eq!(r.len(), resumed_segments as usize, "every segment once");
        let from_line = lines.iter().filter(|&&l| l >= line).count();
        let approach = r.len() - from_line;
        assert!(approach <= APPROACH_SEGMENTS, "cut at {cut}: {approach} approach segments");
        // From the resume line on: the whole run's path, within one step.
        for (k, (p, q)) in r[approach..].iter().zip(&w[w.len() - from_line..]).enumerate() {
            assert!(off_by(p, q) <= 1, "cut at {cut}, line {line}, segment {k}: {p:?} {q:?}");
        }
        assert!(off_by(r.last().unwrap(), &end) <= 1, "cut at {cut}: final position");
        assert_eq!(resumed.positions[..3], end[..3], "cut at {cut}");
        let rerun = c.len() - (w.len() - from_line);
        eprintln!(
            "cut after {} segments: resumed from line {line}, {approach} approach segments, \
             {rerun} segments of the cut line(s) run again",
            c.len()
        );
        assert!(!journal::path_for(file).exists(), "a finished run leaves no journal");
    }
}
