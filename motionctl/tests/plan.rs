//! Planning and the offline model run: the examples end where they should; events follow the
//! motion before them; the binary's `plan` works and errors are one line.

use motion::machine::ProbeKind;
use motion::protocol::{ProgramOutputs, SpindleDir};
use motionctl::cli::{self, JobArgs};
use motionctl::convert::{self, Program};
use motionctl::job::{self, Feed, Item, Job, MoveCmd, Source, Target};
use motionctl::plan::{self, Output, Stream};
use std::path::{Path, PathBuf};
use std::process::Command;

/// M3 alone, and everything off.
const CW: ProgramOutputs = ProgramOutputs { spindle: SpindleDir::Cw, mist: false, flood: false };
const OFF: ProgramOutputs = ProgramOutputs::OFF;

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples").join(name)
}

fn args(name: &str) -> JobArgs {
    JobArgs { job: example(name), format: None, machine: None }
}

#[test]
fn square_example_runs_on_the_model_to_its_final_position() {
    let (_, program, s) = cli::plan_job(&args("square.toml")).unwrap();
    assert!(s.finished);
    assert_eq!(program.final_steps[..3], [400, 400, 0]);
    assert_eq!(s.report.positions[..3], [400, 400, 0]);
    assert_eq!(s.report.segments as usize, s.plan.segments.len());
    assert_eq!(s.report.underruns, 0);
    assert_eq!((s.moves, s.plan.spindle_events, s.plan.pauses), (9, 2, 1));
    // 800 + 800 to the start, the 4 sides and the diagonal, back to 5/5 and to 0 on Z.
    assert_eq!(s.report.steps[..3], [800 + 4 * 3_200 + 400, 800 + 4 * 3_200 + 400, 1_600]);
    // No axis beyond its max rate (X, Y 20 kHz; Z 10 kHz).
    assert!(s.report.peak_rate_hz[0] <= 20_000 && s.report.peak_rate_hz[2] <= 10_000);
    assert!(s.seconds() > 5.0 && s.seconds() < 30.0, "{}", s.seconds());
}

#[test]
fn part_gcode_runs_on_the_model_to_its_final_position() {
    let (_, program, s) = cli::plan_job(&args("part.gcode")).unwrap();
    assert!(s.finished);
    assert_eq!(program.final_steps[..3], [800, 800, 0]);
    assert_eq!(s.report.positions[..3], [800, 800, 0]);
    assert_eq!(s.report.segments as usize, s.plan.segments.len());
    // An explicit --machine and --format give the same.
    let mut a = args("part.gcode");
    a.machine = Some(example("square.toml"));
    a.format = Some(cli::JobFormat::Gcode);
    assert_eq!(cli::plan_job(&a).unwrap().2.report, s.report);
}

fn mv(index: usize, x_mm: f64, feed: Feed) -> Item {
    Item::Move(MoveCmd {
        target: Target::Relative(vec![x_mm, 0.0, 0.0]),
        feed,
        source: Source::Toml { index },
    })
}

fn probe(index: usize, x_mm: f64) -> Item {
    let Item::Move(m) = mv(index, x_mm, Feed::MmPerMin(600.0)) else { unreachable!() };
    Item::Probe { kind: ProbeKind::Toward, mv: m }
}

fn program(items: Vec<Item>) -> Program {
    let machine = job::parse_machine_toml(include_str!("../examples/machine.toml")).unwrap();
    convert::convert(&Job { machine, items, feed_commands: vec![] }).unwrap()
}

#[test]
fn events_come_after_the_motion_before_them_has_come_to_rest() {
    let p = program(vec![
        mv(0, 10.0, Feed::MmPerMin(3_000.0)),
        mv(1, 10.0, Feed::MmPerMin(3_000.0)),
        Item::Outputs(CW),
        mv(3, 5.0, Feed::Rapid),
        Item::Pause,
        mv(5, 5.0, Feed::Rapid),
        Item::Dwell(0.25),
        mv(7, 2.0, Feed::Rapid),
        Item::Outputs(OFF),
        probe(9, -3.0),
        mv(10, 2.0, Feed::Rapid),
    ]);
    let out: Vec<Output> = Stream::new(&p).map(Result::unwrap).collect();
    let kinds: Vec<char> = out
        .iter()
        .map(|o| match o {
            Output::Segment(_) => 's',
            Output::Outputs(o) if o.spindle != SpindleDir::Off => 'M',
            Output::Outputs(_) => 'm',
            Output::Pause => 'P',
            Output::Dwell(s) => {
                assert_eq!(*s, 0.25);
                'D'
            }
            Output::Probe(k) => {
                assert_eq!(*k, ProbeKind::Toward);
                'G'
            }
            Output::ProbeEnd => 'E',
        })
        .collect();
    let kinds: String = kinds.iter().collect();
    // The probe move alone between its two events, however many segments it takes.
    let probe_segments = kinds.matches('s').count() - 6;
    assert!(probe_segments >= 1, "{kinds}");
    assert_eq!(kinds, format!("ssMsPsDsmG{}Es", "s".repeat(probe_segments)));
    // The probe move starts and ends at rest.
    let g = kinds.find('G').unwrap();
    let (Output::Segment(first), Output::Segment(last)) = (out[g + 1], out[g + probe_segments])
    else {
        panic!("{kinds}")
    };
    assert_eq!((first.entry_rate, last.exit_rate), (motion::Rate::ZERO, motion::Rate::ZERO));
    // The segment before each event ends at rest; the first ones meet at speed.
    for w in out.windows(2) {
        if let (Output::Segment(s), Output::Outputs(_) | Output::Pause | Output::Dwell(_)) =
            (w[0], w[1])
        {
            assert_eq!(s.exit_rate, motion::Rate::ZERO);
        }
    }
    let Output::Segment(first) = out[0] else { panic!() };
    assert!(first.exit_rate > motion::Rate::ZERO);
    let segs: Vec<_> = out
        .iter()
        .filter_map(|o| match o {
            Output::Segment(s) => Some(*s),
            _ => None,
        })
        .collect();
    assert_eq!(plan::net_steps(&segs)[0], p.final_steps[0]);
    let s = plan::simulate(&p, |_| {}).unwrap();
    assert!(s.finished);
    // 10 + 10 + 5 + 5 + 2, the probe move back 3 (the model never trips), 2 more.
    assert_eq!(s.report.positions[0], 31 * 80);
}

#[test]
fn a_move_too_long_for_the_free_window_is_planned_after_a_stop() {
    // 15 short moves fill most of the window; then 280 mm at 0.2 mm/min (22 400 steps at the
    // slowest feed, 1 step/s) is split into 3 pieces of at most ~10 700 s at 100 kHz: more room
    // than the window has left, so the stream ends the motion so far at rest and pushes it again.
    let mut items: Vec<Item> = (0..15).map(|i| mv(i, 1.0, Feed::MmPerMin(600.0))).collect();
    items.push(mv(15, 280.0, Feed::MmPerMin(0.2)));
    items.push(mv(16, 1.0, Feed::MmPerMin(600.0)));
    let p = program(items);
    let plan = plan::plan(&p).unwrap();
    assert_eq!(plan::net_steps(&plan.segments)[0], p.final_steps[0]);
    assert_eq!(p.final_steps[0], (15 + 280 + 1) * 80);
    // The long move was split (at least 17 + 1 segments).
    assert!(plan.segments.len() > 17, "{}", plan.segments.len());
}

fn motionctl(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_motionctl"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn binary_plans_examples_and_reports_errors_in_one_line() {
    let (code, out, err) = motionctl(&["plan", "examples/square.toml"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("moves      9 (0 skipped"), "{out}");
    let x_row = out.lines().find(|l| l.starts_with("X ")).unwrap();
    assert_eq!(x_row.split_whitespace().nth(1), Some("400"), "{x_row}");

    let (code, out, _) = motionctl(&["plan", "examples/part.gcode"]);
    assert_eq!(code, 0);
    // M3, M5, and M30's own spindle stop (rs274 stops the spindle at the program end).
    assert!(out.contains("events     3 spindle, 1 pause"), "{out}");

    for (args, code_want, want) in [
        (&["plan", "examples/missing.toml"][..], 1, "reading examples/missing.toml"),
        (&["plan", "Cargo.toml"][..], 1, "Cargo.toml: format: missing"),
        (&["plan", "JOB_FORMAT.md"][..], 1, "unknown job format"),
        (&["plan", "examples/part.gcode", "--format", "toml"][..], 1, "examples/part.gcode: "),
        (&["override", "2.5", "--qemu"][..], 2, "must be within 0..=2"),
        (&["hold", "--qemu"][..], 1, "--qemu starts a fresh board for `run` only"),
        (&["status", "--port", "/dev/ttyNOPE7"][..], 1, "port /dev/ttyNOPE7 not found: "),
        (&["abort"][..], 1, "no link given: pass --port PATH, --tcp HOST:PORT or --qemu"),
        (
            &["run", "examples/square.toml", "--port", "/dev/ttyNOPE7", "--baud", "230400"][..],
            1,
            "port /dev/ttyNOPE7 not found: ",
        ),
        (&["run", "examples/square.toml", "--tcp", "127.0.0.1:1"][..], 1, "cannot connect to"),
        (&["frobnicate"][..], 2, "unrecognized subcommand"),
    ] {
        let (code, out, err) = motionctl(args);
        assert_eq!(code, code_want, "{args:?}: {err}");
        assert!(out.is_empty(), "{args:?}: {out}");
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert!(err.starts_with("motionctl: error: ") && err.contains(want), "{args:?}: {err}");
    }
}
