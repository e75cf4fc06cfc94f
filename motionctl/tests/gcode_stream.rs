//! G-code planned as a stream (`gcode::stream`, what `plan` and `run` use for G-code) gives
//! exactly what the whole-program path gives: the same segments and events, the same host-model
//! run, the same refusals; and what it keeps of errors and warnings is bounded.

use motionctl::cli::{self, JobArgs};
use motionctl::convert::{self, ProgramItem};
use motionctl::gcode::{self, stream};
use motionctl::job::{self, Job, Machine, Source};
use motionctl::plan::{Output, Stream};
use std::path::{Path, PathBuf};

fn corpus(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../host/gcode/tests/corpus").join(name)
}

fn machine_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/corpus-machine.toml")
}

fn machine() -> Machine {
    job::parse_machine_toml(&std::fs::read_to_string(machine_path()).unwrap()).unwrap()
}

fn temp_file(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("motionctl-gcode-stream-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Outputs with the line of each segment, streamed from the file.
fn streamed(path: &Path, m: &Machine) -> Vec<(Output, Option<Source>)> {
    let items = stream::items(path, m).unwrap();
    let cfg = convert::machine_config(m).unwrap();
    let mut s: Stream<_, stream::Stop> = Stream::over(&cfg, items);
    let mut out = Vec::new();
    while let Some(o) = s.next() {
        let o = o.unwrap_or_else(|e| panic!("{}: {e:?}", path.display()));
        let src = matches!(o, Output::Segment(_)).then(|| s.source()).flatten();
        out.push((o, src));
    }
    assert!(s.items().verdict().is_ok());
    out
}

const FILES: [&str; 6] = [
    "linuxcnc-3d-chips-surfacing.ngc",
    "linuxcnc-arcspiral.ngc",
    "cncjs-jscut-jsdc.gcode",
    "linuxcnc-tort-g17-g18-g19.ngc",
    "linuxcnc-systems-g54-g92.ngc",
    "ugs-cambam-electric-turtle.nc",
];

#[test]
fn streamed_segments_equal_the_whole_programs_exactly() {
    let m = machine();
    for name in FILES {
        let path = corpus(name);
        let loaded = gcode::load(&path, &m).unwrap();
        let job = Job { machine: m.clone(), items: loaded.items, feed_commands: vec![] };
        let program = convert::convert(&job).unwrap();
        let whole: Vec<Output> = Stream::new(&program).map(Result::unwrap).collect();
        let streamed = streamed(&path, &m);
        let outputs: Vec<Output> = streamed.iter().map(|(o, _)| *o).collect();
        assert!(whole.len() > 10, "{name}: {} outputs", whole.len());
        assert_eq!(outputs.len(), whole.len(), "{name}");
        for (i, (a, b)) in outputs.iter().zip(&whole).enumerate() {
            assert_eq!(a, b, "{name}: output {i}");
        }
        // Each segment's line: the lines of the moves, in order, each move one segment or more.
        let move_lines: Vec<Source> = program
            .items
            .iter()
            .filter_map(|i| match i {
                ProgramItem::Move { source, .. } => Some(*source),
                _ => None,
            })
            .collect();
        let seg_lines: Vec<Source> = streamed.iter().filter_map(|(_, s)| *s).collect();
        let segments = outputs.iter().filter(|o| matches!(o, Output::Segment(_))).count();
        assert_eq!(seg_lines.len(), segments, "{name}: every segment has a line");
        let mut dedup = seg_lines.clone();
        dedup.dedup();
        let mut moves = move_lines.clone();
        moves.dedup();
        assert_eq!(dedup, moves, "{name}: segment lines follow the moves");
    }
}

#[test]
fn the_checking_pass_plans_and_models_as_plan_job_does() {
    let m = machine();
    for name in FILES {
        let path = corpus(name);
        let args = JobArgs { job: path.clone(), format: None, machine: Some(machine_path()) };
        let (_, program, whole) = cli::plan_job(&args).unwrap();
        let c = stream::check_and_plan(stream::items(&path, &m).unwrap(), |_| {}).unwrap();
        assert_eq!(c.totals, whole.totals(), "{name}");
        assert_eq!(c.report, whole.report, "{name}");
        assert_eq!(c.program.final_steps, program.final_steps, "{name}");
        assert_eq!(c.program.config, program.config, "{name}");
        // Without the model: the same plan.
        let p = stream::check_and_plan_only(stream::items(&path, &m).unwrap()).unwrap();
        assert_eq!((p.totals, p.program), (c.totals, c.program.clone()), "{name}");
        let text = |t, r| motionctl::plan::summary_text(&path, &m, 0, t, r);
        assert_eq!(
            text(&c.totals, &c.report),
            cli::summary_text(&path, &args_job(&m), &program, &whole)
        );
    }
}

fn args_job(m: &Machine) -> Job {
    Job { machine: m.clone(), items: vec![], feed_commands: vec![] }
}

fn refusal(path: &Path, m: &Machine) -> String {
    let without_model = match stream::check_and_plan_only(stream::items(path, m).unwrap()) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("{}: accepted without the model", path.display()),
    };
    match stream::check_and_plan(stream::items(path, m).unwrap(), |_| {}) {
        Err(e) => {
            assert_eq!(e.to_string(), without_model);
            e.to_string()
        }
        Ok(_) => panic!("{}: accepted", path.display()),
    }
}

#[test]
fn refusals_are_the_whole_programs() {
    let m = machine();
    let path = corpus("linuxcnc-mmount-oword-canned.ngc");
    let whole = gcode::load(&path, &m).unwrap_err().to_string();
    assert_eq!(refusal(&path, &m), whole);
    // A soft limit: the move the machine cannot take, as convert() names it.
    let src = "G21 G90\nG1 X10 F600\nG1 X600\nG1 X0\nM2\n";
    let p = temp_file("limit.ngc", src);
    let job =
        Job { machine: m.clone(), items: gcode::parse(src, &m).unwrap(), feed_commands: vec![] };
    let whole = convert::convert(&job).unwrap_err().to_string();
    assert!(whole.contains("line 3") && whole.contains("soft limit"), "{whole}");
    assert_eq!(refusal(&p, &m), whole);
    // A G-code error after it wins, as it does when the whole file is loaded first.
    let p = temp_file("limit-then-error.ngc", "G21 G90\nG1 X10 F600\nG1 X600\nG1 X0 Q\nM2\n");
    let e = refusal(&p, &m);
    assert!(
        e.starts_with("1 error in the G-code: ") && e.contains("limit-then-error.ngc:4:"),
        "{e}"
    );
    assert_eq!(e, gcode::load(&p, &m).unwrap_err().to_string());
}

#[test]
fn errors_and_warnings_kept_are_bounded_and_counted() {
    let m = machine();
    let n = stream::KEEP + 500;
    let mut src = String::from("G21 G90 F600\n");
    for i in 0..n {
        // An unknown word: an error on every line; an M62 output: a warning on every line.
        src.push_str(&format!("G1 X{} Q1\nM62 P0\n", i % 10));
    }
    src.push_str("M2\n");
    let p = temp_file("many-errors.ngc", &src);
    let mut items = stream::items(&p, &m).unwrap();
    assert!(matches!(items.next(), Some(Err(stream::Stop::Refused))));
    items.drain();
    let Err(stream::Refusal::Gcode(e)) = items.verdict() else { panic!("not refused") };
    assert_eq!((e.errors.len(), e.omitted), (stream::KEEP, 500));
    let text = e.to_string();
    assert!(text.starts_with(&format!("{n} errors in the G-code: ")), "{}", &text[..80]);
    assert!(text.ends_with("; and 500 more"));

    let mut src = String::from("G21 G90 F600\n");
    for i in 0..n {
        src.push_str(&format!("G1 X{}\nM62 P0\n", i % 10));
    }
    src.push_str("M2\n");
    let p = temp_file("many-warnings.ngc", &src);
    let c = stream::check_and_plan(stream::items(&p, &m).unwrap(), |_| {}).unwrap();
    assert_eq!(c.warnings.len(), stream::KEEP);
    assert_eq!(c.warnings_omitted, 500);
    assert!(
        c.warnings[0].contains("many-warnings.ngc:3: warning: M62..M68 output"),
        "{}",
        c.warnings[0]
    );
}

fn sim_opts() -> motionctl::runner::RunOptions {
    motionctl::runner::RunOptions {
        host: motion::protocol::HostConfig { rto_ms: 20, window: 8 },
        home: true,
        ..Default::default()
    }
}

/// A short job of zig-zags, an arc and a spindle on/off, `n` lines of motion.
fn short_job(n: usize) -> String {
    let mut src = String::from("G21 G90 F6000\nM3 S1000\n");
    for i in 0..n {
        src.push_str(&format!("G1 X{} Y{:.1}\n", 2 * (i % 2), i as f64 * 0.2));
    }
    // A full circle from where the zig-zag ends.
    let (x, y) = (2 * ((n - 1) % 2), (n - 1) as f64 * 0.2);
    src.push_str(&format!("G2 X{x} Y{y:.1} I-5 J0\nM5\nM2\n"));
    src
}

#[test]
fn the_second_pass_streams_to_the_board_as_checked() {
    use motionctl::sim_board::{SimBoard, SIM_CAPACITY};
    let m = machine();
    let p = temp_file("run.ngc", &short_job(60));
    let c = stream::check_and_plan(stream::items(&p, &m).unwrap(), |_| {}).unwrap();
    let segments = c.totals.segments as u32;
    assert!(segments > 60, "{segments}");
    let job = Job { machine: m.clone(), items: vec![], feed_commands: vec![] };
    let outputs = stream::outputs(stream::items(&p, &m).unwrap(), &c, "run.ngc", segments);
    let mut expected = [0i64; motion::MAX_AXES];
    expected.copy_from_slice(&c.report.positions[..motion::MAX_AXES]);
    let mut board = SimBoard::new(SIM_CAPACITY, 8.0);
    let r = motionctl::runner::run_outputs(
        &mut board,
        &job,
        &c.program,
        outputs,
        &expected,
        sim_opts(),
    )
    .unwrap();
    assert!(r.ok(), "{:?}", r.problems);
    assert_eq!((r.segments, r.acked, r.done), (segments, segments, segments));
    assert_eq!(r.positions, expected[..3].to_vec());
}

#[test]
fn a_file_changed_between_the_passes_stops_the_run() {
    use motionctl::sim_board::{SimBoard, SIM_CAPACITY};
    let m = machine();
    let job = Job { machine: m.clone(), items: vec![], feed_commands: vec![] };
    for (name, changed, why) in [
        ("changed-error.ngc", short_job(60).replace("Y4.0\n", "Y4.0 Q\n"), "1 error in the G-code"),
        ("changed-longer.ngc", short_job(61), "more than"),
        ("changed-shorter.ngc", short_job(59), "segments instead of"),
    ] {
        let p = temp_file(name, &short_job(60));
        let c = stream::check_and_plan(stream::items(&p, &m).unwrap(), |_| {}).unwrap();
        let segments = c.totals.segments as u32;
        std::fs::write(&p, changed).unwrap();
        let outputs = stream::outputs(stream::items(&p, &m).unwrap(), &c, name, segments);
        let mut board = SimBoard::new(SIM_CAPACITY, 8.0);
        let e = motionctl::runner::run_outputs(
            &mut board,
            &job,
            &c.program,
            outputs,
            &c.program.final_steps,
            sim_opts(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains(&format!("{name} changed since it was checked")), "{e}");
        assert!(e.contains(why) && e.contains("Abort sent to the board"), "{e}");
    }
}
