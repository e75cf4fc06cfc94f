//! G38.2..G38.5 probe moves in `run`, on the simulated board with a probe surface: each probe
//! move runs alone, the board's trip position goes back to the interpreter (#5061..#5066,
//! #5070, as LinuxCNC's), and the rest of the program is planned from where the axes stopped.
//! A G38.2 that never touches ends the run with ProbeFail at its file:line; G38.3 goes on.

use motionctl::gcode::stream;
use motionctl::job::{self, Job, Machine};
use motionctl::runner::{RunError, RunOptions, RunReport, SimProbe};
use motionctl::sim_board::{SimBoard, SIM_CAPACITY};
use std::path::{Path, PathBuf};
use std::process::Command;

const Z: usize = 2;

fn machine_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/corpus-machine.toml")
}

fn machine() -> Machine {
    job::parse_machine_toml(&std::fs::read_to_string(machine_path()).unwrap()).unwrap()
}

fn temp_file(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("motionctl-gcode-probe-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Probes Z down (`word`), sets G54's Z zero at the result (#5063), moves Y by #5070 (1 when
/// it tripped), then cuts 0.5 mm above the new zero.
fn program(word: &str) -> String {
    format!(
        "G21 G90 G54 G94\n\
         G0 X10 Y5 Z0\n\
         {word} Z-20 F300\n\
         G10 L2 P1 Z#5063\n\
         G0 Y[5 + #5070] Z2\n\
         G1 X20 Z0.5 F600\n\
         M2\n"
    )
}

/// Checks and runs `src` on a fresh simulated board whose probe touches at or below `z_mm`.
fn run(name: &str, src: &str, z_mm: f64) -> Result<RunReport, RunError> {
    let m = machine();
    let p = temp_file(name, src);
    let c = stream::check_and_plan(stream::items(&p, &m).unwrap(), |_| {}).unwrap();
    assert_eq!(c.totals.probes, 1);
    let segments = c.totals.segments as u32;
    let job = Job { machine: m.clone(), items: vec![], feed_commands: vec![] };
    let outputs = stream::outputs(stream::items(&p, &m).unwrap(), &c, name, segments);
    let mut expected = [0i64; motion::MAX_AXES];
    expected.copy_from_slice(&c.report.positions[..motion::MAX_AXES]);
    let mut board = SimBoard::new(SIM_CAPACITY, 8.0);
    let opts = RunOptions {
        host: motion::protocol::HostConfig { rto_ms: 20, window: 8 },
        home: true,
        sim_probe: Some(SimProbe { axis: Z, at_mm: z_mm, below: true }),
        ..Default::default()
    };
    motionctl::runner::run_outputs(&mut board, &job, &c.program, outputs, &expected, opts)
}

#[test]
fn a_probed_surface_becomes_the_work_zero_and_the_program_goes_on_from_it() {
    let r = run("probe-surface.ngc", &program("G38.2"), -3.2).unwrap();
    assert!(r.ok(), "{:?}", r.problems);
    assert_eq!(r.probes.len(), 1);
    let probe = r.probes[0];
    assert_eq!(probe.line, Some(3));
    assert!(probe.outcome.tripped);
    // The surface at -3.2 mm = -1280 steps of Z: the trip within one step of it.
    let trip_z = probe.outcome.trip_steps[Z];
    assert!((trip_z + 1280).abs() <= 1, "tripped at {trip_z} steps");
    assert_eq!(&probe.outcome.trip_steps[..2], &[800, 400], "X10 Y5 at the trip");
    // Y 5 + #5070 = 6 mm; Z 0.5 mm above the probed zero; X 20 mm: in steps.
    let z_end = trip_z + 200;
    assert_eq!(r.positions, vec![1600, 480, z_end]);
    assert_eq!(r.expected_positions, r.positions);
    // The rest was planned from the trip, 16.8 mm above the probe move's planned end: the path
    // check follows it there (reports during the probe move itself are not checked).
    assert!(r.path.ok() && r.path.samples > 0, "{:?}", r.path);
}

#[test]
fn a_g38_3_that_misses_goes_on_with_5070_at_0() {
    let r = run("probe-miss-ok.ngc", &program("G38.3"), -50.0).unwrap();
    assert!(r.ok(), "{:?}", r.problems);
    assert!(!r.probes[0].outcome.tripped);
    assert_eq!(r.probes[0].outcome.rest_steps[Z], -8000, "the whole move, to Z-20");
    // No trip: #5063 is the move's end (-20 mm), #5070 is 0: Y stays at 5 mm.
    assert_eq!(r.positions, vec![1600, 400, -8000 + 200]);
}

#[test]
fn a_g38_2_that_misses_ends_the_run_with_probe_fail_at_its_line() {
    let e = run("probe-miss.ngc", &program("G38.2"), -50.0).unwrap_err().to_string();
    assert!(e.contains("probe-miss.ngc:3: G38.2 probe move: "), "{e}");
    assert!(e.contains("ProbeFail"), "{e}");
}

#[test]
fn a_probe_already_touching_is_probe_initial_at_its_line() {
    // The surface at Z 5 mm: the probe, at Z 0, touches before it moves.
    let e = run("probe-initial.ngc", &program("G38.2"), 5.0).unwrap_err().to_string();
    assert!(e.contains("probe-initial.ngc:3: G38.2 probe move: "), "{e}");
    assert!(e.contains("ProbeInitial"), "{e}");
}

#[test]
fn run_sim_probe_from_the_command_line() {
    let m = machine_path();
    let go = |name: &str, word: &str, surface: &str| {
        let p = temp_file(name, &program(word));
        Command::new(env!("CARGO_BIN_EXE_motionctl"))
            .args(["run", p.to_str().unwrap(), "--machine", m.to_str().unwrap(), "--sim"])
            .args(["--yes", "--sim-probe", surface])
            .output()
            .unwrap()
    };
    let out = go("cli-probe.ngc", "G38.2", "z=-3.2");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("cli-probe.ngc:3: G38.2 probe move tripped at X 10.0000 Y 5.0000 Z -3.2"),
        "{err}"
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("result     OK"), "{text}");

    let out = go("cli-probe-miss.ngc", "G38.2", "z<=-50");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("cli-probe-miss.ngc:3: G38.2 probe move: "), "{err}");
    assert!(err.contains("ProbeFail"), "{err}");

    let out = go("cli-probe-bad.ngc", "G38.2", "q=1");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--sim-probe: the machine has no axis q"), "{err}");
}
