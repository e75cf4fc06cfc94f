//! The spindle (M3, M4, M5) and coolant (M7, M8, M9) of a G-code job switch the board's outputs
//! in program order: `run` sends each switch once the motion before it is done, the board's
//! status shows it, and the job ends with everything off.

use motion::protocol::{ProgramOutputs, SpindleDir};
use motionctl::gcode::stream;
use motionctl::job::{self, Job, Machine};
use motionctl::sim_board::{SimBoard, SIM_CAPACITY};
use std::path::{Path, PathBuf};
use std::process::Command;

fn machine_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/corpus-machine.toml")
}

fn machine() -> Machine {
    job::parse_machine_toml(&std::fs::read_to_string(machine_path()).unwrap()).unwrap()
}

fn temp_file(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("motionctl-gcode-outputs-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// M3, M8, M7, then M9 and M4 with no motion between them, M5, each after a move.
const PROGRAM: &str = "G21 G90 F3000\nM3 S1000\nG1 X10\nM8\nG1 Y10\nM7\nG1 X0\nM9\nM4\nG1 Y0\n\
                       M5\nM2\n";

#[test]
fn spindle_and_coolant_switch_the_board_in_program_order() {
    let m = machine();
    let p = temp_file("outputs.ngc", PROGRAM);
    let c = stream::check_and_plan(stream::items(&p, &m).unwrap(), |_| {}).unwrap();
    assert!(c.warnings.is_empty(), "coolant and M4 are no longer warned: {:?}", c.warnings);
    let segments = c.totals.segments as u32;
    let job = Job { machine: m.clone(), items: vec![], feed_commands: vec![] };
    let outputs = stream::outputs(stream::items(&p, &m).unwrap(), &c, "outputs.ngc", segments);
    let mut expected = [0i64; motion::MAX_AXES];
    expected.copy_from_slice(&c.report.positions[..motion::MAX_AXES]);
    let mut board = SimBoard::new(SIM_CAPACITY, 8.0);
    let opts = motionctl::runner::RunOptions {
        host: motion::protocol::HostConfig { rto_ms: 20, window: 8 },
        home: true,
        ..Default::default()
    };
    let r = motionctl::runner::run_outputs(&mut board, &job, &c.program, outputs, &expected, opts)
        .unwrap();
    assert!(r.ok(), "{:?}", r.problems);

    let o = |spindle, mist, flood| ProgramOutputs { spindle, mist, flood };
    use SpindleDir::{Ccw, Cw, Off};
    let asked: Vec<ProgramOutputs> = r.output_switches.iter().map(|s| s.to).collect();
    assert_eq!(
        asked,
        [
            o(Cw, false, false),
            o(Cw, false, true),
            o(Cw, true, true),
            // M9 then M4 with no motion between: one switch to their end state.
            o(Ccw, false, false),
            // M5, and M2's own stop (nothing more to switch).
            o(Off, false, false),
        ]
    );
    for s in &r.output_switches {
        assert_eq!(s.shown, s.to.bits(), "the board's status after {s:?}");
    }
    // Each switch at its place among the moves: before the first, between each pair (the
    // motion before it done), after the last.
    let done: Vec<u32> = r.output_switches.iter().map(|s| s.segments_done).collect();
    assert_eq!(done[0], 0, "M3 before any move");
    assert!(done.windows(2).all(|w| w[0] < w[1]), "one move between switches: {done:?}");
    assert_eq!(*done.last().unwrap(), segments, "M5 after the last move");
    assert_eq!(r.final_outputs, 0, "everything off at the end");
    assert_eq!(board.target.outputs, motion::machine::Outputs::SAFE);
}

#[test]
fn run_says_what_it_switched_in_words() {
    let p = temp_file("words.ngc", PROGRAM);
    let m = machine_path();
    let out = Command::new(env!("CARGO_BIN_EXE_motionctl"))
        .args(["run", p.to_str().unwrap(), "--machine", m.to_str().unwrap(), "--sim", "--yes"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let said: Vec<&str> = [
        "spindle on clockwise (M3)",
        "flood on (M8)",
        "mist on (M7)",
        "spindle on counterclockwise (M4), coolant off (M9)",
        "spindle off (M5)",
    ]
    .into_iter()
    .filter(|w| !err.contains(w))
    .collect();
    assert!(said.is_empty(), "missing {said:?} in:\n{err}");
    assert!(!err.contains("nothing switched"), "{err}");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("5 spindle/coolant switches; at the end: spindle off, coolant off"),
        "{text}"
    );
}
