//! Going on with a G-code job from where it stopped: the program read from its top with nothing
//! sent before the resume line, an approach from the origin in its place (Z up to the safe
//! height, across, spindle and spin-up, Z down and the plunge), then the program as written to its end; the run
//! journal `FILE.journal` that `run` keeps and `run --resume` reads; a job interrupted on the
//! simulated board and resumed ends where the whole job ends.

use motion::protocol::{ProgramOutputs, SpindleDir};
use motionctl::convert::ProgramItem;
use motionctl::gcode::resume::{ResumeAt, SPIN_UP_S};
use motionctl::gcode::stream;
use motionctl::job;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// M3 alone.
const CW: ProgramOutputs = ProgramOutputs { spindle: SpindleDir::Cw, mist: false, flood: false };

/// A small fast router: Z's safe height (its upper soft limit) 5 mm.
const MACHINE: &str = r#"format = "motion-job"
version = 1

[machine]
tick_hz = 100_000

[machine.timing]
pulse_ns = 2_500
dir_setup_ns = 5_000
dir_hold_ns = 5_000

[[machine.axes]]
name = "X"
steps_per_mm = 80.0
max_rate_mm_s = 250.0
accel_mm_s2 = 4_000.0
junction_jerk_mm_s = 10.0
min_mm = -100.0
max_mm = 100.0

[[machine.axes]]
name = "Y"
steps_per_mm = 80.0
max_rate_mm_s = 250.0
accel_mm_s2 = 4_000.0
junction_jerk_mm_s = 10.0
min_mm = -100.0
max_mm = 100.0

[[machine.axes]]
name = "Z"
steps_per_mm = 400.0
max_rate_mm_s = 25.0
accel_mm_s2 = 1_000.0
junction_jerk_mm_s = 2.0
min_mm = -20.0
max_mm = 5.0
"#;

/// Lines 1-5: setup, spindle, plunge to Z -1; then `passes` lines of 10 mm zig-zag at 3000
/// mm/min (line 6 on); Z up, spindle off, end.
fn program(passes: usize) -> String {
    let mut s = String::from("G21 G90\nG0 Z2\nM3 S8000\nG4 P0.1\nG1 Z-1 F600\n");
    for i in 0..passes {
        s.push_str(&format!("G1 X{} Y{} F3000\n", (i % 2) * 10, i));
    }
    s.push_str("G0 Z2\nM5\nM2\n");
    s
}

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("gcode_resume_{}_{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(d.join("machine.toml"), MACHINE).unwrap();
    d
}

fn items(file: &Path, resume: Option<usize>) -> (Vec<ProgramItem>, [i64; motion::MAX_AXES]) {
    let machine = job::parse_machine_toml(MACHINE).unwrap();
    let mut it = stream::items(file, &machine).unwrap();
    if let Some(line) = resume {
        it = it.resume_from(ResumeAt::new(&machine, line).unwrap());
    }
    let v: Vec<ProgramItem> = it.by_ref().map(Result::unwrap).collect();
    (v, it.final_steps())
}

fn moves(v: &[ProgramItem]) -> Vec<[i32; motion::MAX_AXES]> {
    v.iter()
        .filter_map(|i| match i {
            ProgramItem::Move { mv, .. } => Some(mv.steps),
            _ => None,
        })
        .collect()
}

#[test]
fn the_resumed_program_is_the_approach_then_the_program_from_the_line() {
    let d = dir("items");
    let file = d.join("job.ngc");
    std::fs::write(&file, program(20)).unwrap();
    let (whole, end) = items(&file, None);
    // From line 16 (the 11th pass, to X 0 Y 10): it starts where line 15 ended, X 10 Y 9 Z -1.
    let (resumed, end_resumed) = items(&file, Some(16));
    assert_eq!(end, end_resumed);
    let m = moves(&resumed);
    let z_safe = 5 * 400;
    assert_eq!(m[0][..3], [0, 0, z_safe], "Z up first");
    assert_eq!(m[1][..3], [10 * 80, 9 * 80, 0], "across at the safe height");
    // Down in a rapid to 5 mm above the resume point (Z 4), the last 5 mm at the plunge feed.
    assert_eq!(m[2][..3], [0, 0, 4 * 400 - z_safe], "rapid down to the clearance");
    assert_eq!(m[3][..3], [0, 0, -400 - 4 * 400], "plunge to the resume point");
    // Spindle on and its spin-up between the traverse and the plunge (the program had M3).
    let events: Vec<&ProgramItem> =
        resumed.iter().filter(|i| !matches!(i, ProgramItem::Move { .. })).collect();
    assert_eq!(events[0], &ProgramItem::Outputs(CW));
    assert_eq!(events[1], &ProgramItem::Dwell(SPIN_UP_S));
    // Then exactly the whole program's moves from that line on.
    let whole_moves = moves(&whole);
    let from = whole_moves.len() - (m.len() - 4);
    assert_eq!(m[4..], whole_moves[from..]);
    assert_eq!(whole_moves[from][..2], [-10 * 80, 80], "the 11th pass");
    // The sum of the resumed moves lands where the whole program does.
    let mut at = [0i64; 3];
    for s in &m {
        for k in 0..3 {
            at[k] += s[k] as i64;
        }
    }
    assert_eq!(at[..], end[..3]);
}

#[test]
fn resumed_at_ten_points_each_run_ends_where_the_job_ends_along_the_same_path() {
    let d = dir("ten");
    let file = d.join("job.ngc");
    std::fs::write(&file, program(40)).unwrap();
    let (whole, end) = items(&file, None);
    let whole_moves = moves(&whole);
    // Ten resume lines spread over the passes (lines 6..=45), from a fixed LCG.
    let mut x = 12345u32;
    for _ in 0..10 {
        x = x.wrapping_mul(1_103_515_245).wrapping_add(12_345);
        let line = 6 + (x >> 16) as usize % 40;
        let (resumed, end_resumed) = items(&file, Some(line));
        assert_eq!(end_resumed, end, "line {line}");
        let m = moves(&resumed);
        // The approach (up, across, down, plunge: at most four moves), then the whole program's
        // moves of lines `line` and after (46 - line passes and the final Z up).
        let n = 46 - line + 1;
        assert!(m.len() >= n && m.len() - n <= 4, "line {line}: {} moves", m.len());
        assert_eq!(m[m.len() - n..], whole_moves[whole_moves.len() - n..], "line {line}");
    }
}

fn motionctl() -> Command {
    Command::new(env!("CARGO_BIN_EXE_motionctl"))
}

fn run(file: &Path, machine: &Path, extra: &[&str]) -> std::process::Output {
    motionctl()
        .args(["run", file.to_str().unwrap(), "--machine", machine.to_str().unwrap()])
        .args(["--sim", "--yes"])
        .args(extra)
        .output()
        .unwrap()
}

/// The final machine position, mm, from `run`'s "positions" line (X, Y, Z).
fn final_mm(out: &str) -> Vec<f64> {
    let line = out.lines().find(|l| l.starts_with("positions")).unwrap_or_else(|| panic!("{out}"));
    line.split(" mm (").filter_map(|p| p.rsplit(' ').next()?.parse().ok()).collect()
}

#[test]
fn a_job_interrupted_on_the_board_goes_on_with_resume_and_ends_where_the_job_ends() {
    let d = dir("run");
    let (file, machine) = (d.join("job.ngc"), d.join("machine.toml"));
    std::fs::write(&file, program(40)).unwrap();
    let journal = motionctl::journal::path_for(&file);
    // Without a journal there is nothing to resume.
    let out = run(&file, &machine, &["--resume"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("no journal to resume from"), "{err}");
    // Start the job; stop it (Ctrl-C) once the journal shows it past line 20.
    let mut child = motionctl()
        .args(["run", file.to_str().unwrap(), "--machine", machine.to_str().unwrap()])
        .args(["--sim", "--yes"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    let line_now = || {
        let text = std::fs::read_to_string(&journal).ok()?;
        let v: toml::Value = toml::from_str(&text).ok()?;
        v.get("line")?.as_integer()
    };
    while line_now().is_none_or(|l| l < 20) {
        assert!(t0.elapsed() < Duration::from_secs(60), "the journal never reached line 20");
        assert!(child.try_wait().unwrap().is_none(), "the job ended before it was stopped");
        std::thread::sleep(Duration::from_millis(20));
    }
    let pid = child.id().to_string();
    assert!(Command::new("kill").args(["-INT", &pid]).status().unwrap().success());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("interrupted") && err.contains("--resume"), "{err}");
    let stopped_at = line_now().unwrap();
    assert!((20..46).contains(&stopped_at), "{stopped_at}");
    // Go on: the run ends where the whole job ends, and its journal goes.
    let out = run(&file, &machine, &["--resume"]);
    let (text, err) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "{text}\n{err}");
    assert!(text.contains(&format!("resume     from line {stopped_at}:")), "{text}");
    assert_eq!(final_mm(&text), vec![10.0 * ((39 % 2) as f64), 39.0, 2.0], "{text}");
    assert!(!journal.exists(), "a finished job leaves no journal");
    // A journal for another version of the file is refused.
    std::fs::write(
        &journal,
        "version = 1\njob = \"x\"\njob_crc = 1\nline = 7\nsegments_done = 1\nsegments = 9\n",
    )
    .unwrap();
    let out = run(&file, &machine, &["--resume"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("changed since the journal"), "{err}");
    // A line with no move at or after it.
    let out = run(&file, &machine, &["--resume-line", "9999"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("nothing to resume"), "{err}");
    std::fs::remove_dir_all(&d).unwrap();
}
