//! The run's path check on the simulated board (which completes whole segments): every status
//! report lies on the planned path, also after a probe move (G38.2) stopped early and the rest
//! of the program was planned from where the axes came to rest.

use motionctl::gcode::stream;
use motionctl::job::{self, Job};
use motionctl::runner::{RunOptions, RunReport, SimProbe, PATH_LIMIT_STEPS};
use motionctl::sim_board::{SimBoard, SIM_CAPACITY};
use std::path::{Path, PathBuf};

fn manifest(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// Plans and runs the G-code file `path` on a fresh simulated board at 8x machine speed.
fn run(path: &Path, sim_probe: Option<SimProbe>) -> RunReport {
    let text = std::fs::read_to_string(manifest("examples/corpus-machine.toml")).unwrap();
    let m = job::parse_machine_toml(&text).unwrap();
    let c = stream::check_and_plan(stream::items(path, &m).unwrap(), |_| {}).unwrap();
    let segments = c.totals.segments as u32;
    let job = Job { machine: m.clone(), items: vec![], feed_commands: vec![] };
    let name = path.display().to_string();
    let outputs = stream::outputs(stream::items(path, &m).unwrap(), &c, &name, segments);
    let mut expected = [0i64; motion::MAX_AXES];
    expected.copy_from_slice(&c.report.positions[..motion::MAX_AXES]);
    let mut board = SimBoard::new(SIM_CAPACITY, 8.0);
    let opts = RunOptions {
        host: motion::protocol::HostConfig { rto_ms: 20, window: 8 },
        home: true,
        sim_probe,
        ..Default::default()
    };
    motionctl::runner::run_outputs(&mut board, &job, &c.program, outputs, &expected, opts)
        .map_err(|e| e.to_string())
        .unwrap()
}

#[test]
fn a_corpus_file_runs_on_its_planned_path() {
    let r = run(&manifest("../host/gcode/tests/corpus/cncjs-helical-thread-milling.gcode"), None);
    assert!(r.ok(), "{:?}", r.problems);
    let p = &r.path;
    assert!(p.ok() && p.samples > 20, "{p:?}");
    // The simulated board completes whole segments: its positions are segment ends, exactly.
    assert_eq!(p.max_dev_steps, 0.0, "{p:?}");
    assert!(r.machine_line().contains(&format!("path_samples={} ", p.samples)));
    assert!(r.machine_line().ends_with("path_max_dev_steps=0.000 path_ok=1"));
}

#[test]
fn after_a_probe_move_the_rest_is_checked_from_where_the_axes_stopped() {
    let r = run(
        &manifest("../host/gcode/tests/programs/probe_surface.ngc"),
        Some(SimProbe { axis: 2, at_mm: -3.2, below: true }),
    );
    assert!(r.ok(), "{:?}", r.problems);
    assert_eq!(r.probes.iter().filter(|p| p.outcome.tripped).count(), 1);
    let p = &r.path;
    // Planned as if the probe never tripped, the rest would be millimetres (hundreds of steps)
    // off the path the board takes.
    assert!(p.ok() && p.samples > 20 && p.max_dev_steps <= PATH_LIMIT_STEPS, "{p:?}");
}
