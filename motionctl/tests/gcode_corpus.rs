//! Real G-code from CAM programs and senders (host/gcode/tests/corpus, sources in its
//! SOURCES.md) plans on a machine with the travel they need: the host model of the firmware runs
//! every segment and ends, step for step, at the program's own end point (the last move of
//! motion-gcode's canonical calls in machine millimetres; motion-gcode itself is checked call
//! for call against LinuxCNC's rs274 by `cargo xtask rs274-oracle`). Files that need what the
//! board lacks are refused before anything moves, naming the line and the reason.

use motion_gcode::frame::Frame;
use motion_gcode::{Event, Interpreter, Options};
use motionctl::cli::{plan_job, JobArgs};
use std::path::{Path, PathBuf};

fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../host/gcode/tests/corpus")
}

fn machine() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/corpus-machine.toml")
}

/// The program's end point in machine mm (X, Y, Z), from the interpreter's calls.
fn programmed_end(path: &Path) -> [f64; 3] {
    let mut frame = Frame::default();
    let mut end = [0.0; 3];
    for e in Interpreter::open(path, Options::default()).unwrap() {
        if let Event::Call(c) = e {
            if let Some(m) = frame.apply(&c.canon) {
                let p = m.end();
                end = [p[0], p[1], p[2]];
            }
        }
    }
    end
}

fn plan(path: &Path) -> anyhow::Result<motionctl::plan::Summary> {
    let args = JobArgs { job: path.to_path_buf(), format: None, machine: Some(machine()) };
    plan_job(&args).map(|(_, _, s)| s)
}

#[test]
fn corpus_files_plan_and_end_where_the_program_ends() {
    const STEPS_PER_MM: [f64; 3] = [80.0, 80.0, 400.0];
    // The ballnose file runs its spindle counterclockwise (M4): planned like the rest.
    let refused = ["linuxcnc-mmount-oword-canned.ngc"];
    let mut planned = 0;
    let mut files: Vec<PathBuf> = std::fs::read_dir(corpus())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e != "md"))
        .collect();
    files.sort();
    for f in &files {
        let name = f.file_name().unwrap().to_string_lossy().to_string();
        if refused.contains(&name.as_str()) {
            continue;
        }
        let s = plan(f).unwrap_or_else(|e| panic!("{name}: {e:#}"));
        let end = programmed_end(f);
        for a in 0..3 {
            let want = (end[a] * STEPS_PER_MM[a]).round() as i64;
            assert_eq!(s.report.positions[a], want, "{name}: axis {a} ends at {} mm", end[a]);
        }
        planned += 1;
    }
    assert_eq!(planned, files.len() - refused.len());
    assert!(planned >= 15, "{planned} corpus files planned");
}

#[test]
fn what_the_board_cannot_do_is_refused_with_the_line() {
    let e = format!("{:#}", plan(&corpus().join("linuxcnc-mmount-oword-canned.ngc")).unwrap_err());
    assert!(e.contains("linuxcnc-mmount-oword-canned.ngc:314:1: error: G33"), "{e}");
}
