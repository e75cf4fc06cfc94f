//! Milling jobs: parsing, the simulation against the Case A scenario, CSV and plot output,
//! refusals naming the field and its range.

use motion::milling::scenario::{MillingScenario, Variant};
use motion::scenario::run_to_end;
use motionctl::milling::{job, simulate};

const CASE_A: &str = include_str!("../examples/case_a_milling.toml");

#[test]
fn the_case_a_job_is_the_case_a_scenario() {
    let j = job::parse(CASE_A).unwrap();
    let (report, trace) = simulate::run(&j).unwrap();
    let mut s = MillingScenario::new(Variant::CaseA).unwrap();
    let want = run_to_end(&mut s, u64::MAX);
    // Same parameters, same code: every figure and the trace hash agree.
    assert_eq!((report.figures.clone(), report.hash, report.fault), (want.figures, want.hash, 0));
    assert_eq!(trace.len() as i64, report.figure("control_updates").unwrap());
    // The trace shows the loop: force back near Fnom at the end, feed cut to about a quarter.
    let last = trace.last().unwrap();
    assert!((last.force_n - 4100.0).abs() < 410.0, "{last:?}");
    assert!((last.override_ - 0.263).abs() < 0.05, "{last:?}");
}

#[test]
fn csv_and_plots_are_written() {
    let dir = std::env::temp_dir().join(format!("milling-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (csv, svg, png) = (dir.join("t.csv"), dir.join("t.svg"), dir.join("t.png"));
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_motionctl"))
        .args(["milling", "simulate", "examples/case_a_milling.toml", "--csv"])
        .arg(&csv)
        .arg("--plot")
        .arg(&svg)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("t_s,force_n,override,feed_mm_min\n"));
    assert!(text.lines().count() > 2000);
    let svg = std::fs::read_to_string(&svg).unwrap();
    if svg.contains("<text") {
        for label in
            ["Elbestawi Case A", "force, N", "feed, mm/min", "Fnom 4100 N +-10 %", "time, s"]
        {
            assert!(svg.contains(label), "{label} missing from the plot");
        }
    }
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_motionctl"))
        .args(["milling", "simulate", "examples/case_a_milling.toml", "--plot"])
        .arg(&png)
        .output()
        .unwrap();
    assert!(out.status.success());
    assert_eq!(&std::fs::read(&png).unwrap()[..8], b"\x89PNG\r\n\x1a\n");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_jobs_name_the_field_and_the_range() {
    let bad = |from: &str, to: &str| {
        assert!(CASE_A.contains(from), "{from}");
        job::parse(&CASE_A.replace(from, to)).unwrap_err().to_string()
    };
    for (from, to, want) in [
        ("version = 2", "version = 1", "version 1 fixed the spindle"),
        (
            "fnom_n = 4100",
            "fnom_n = -1",
            "force.fnom_n = -1: must be a finite number within (0, 20000] N",
        ),
        ("fnom_n = 4100", "fnom_n = nan", "force.fnom_n = NaN"),
        (
            "trip_n = 18000",
            "trip_n = inf",
            "force.trip_n = inf: must be a finite number within (4100, 20000] N",
        ),
        ("trip_n = 18000", "trip_n = 4000", "force.trip_n = 4000"),
        ("contact_n = 45", "contact_n = 5000", "force.contact_n = 5000"),
        ("strategy = \"direct\"", "strategy = \"c\"", "force.strategy"),
        ("teeth = 4", "teeth = 0", "cutter.teeth = 0: must be a whole number within [1, 64]"),
        ("rpm = 500", "rpm = 0", "spindle.rpm = 0: must be a finite number within (0, 60000] rpm"),
        ("rpm = 500", "rpm = -500", "spindle.rpm = -500"),
        (
            "rpm = 500\nmin_rpm = 120",
            "rpm = 50",
            "a tooth period of 300.000 ms; the force chain needs 0.5 .. 102.3 ms",
        ),
        ("feed_per_tooth_mm = 0.381", "feed_per_tooth_mm = 1", "programmed feed of 2000.0 mm/min"),
        ("kc_n_per_mm2 = 4100", "kc_n_per_mm2 = 0", "cut.kc_n_per_mm2 = 0"),
        (
            "step_at_mm = 10",
            "step_at_mm = 900",
            "s of machine time at the steady feeds; a job runs at most 120 s",
        ),
        ("b_after_mm = 10", "b_after_mm = -inf", "cut.b_after_mm = -inf"),
        ("step_at_mm = 10", "step_at_mm = 10\nb_mm = 3", "unknown field `b_mm`"),
    ] {
        let e = bad(from, to);
        assert!(e.contains(want), "{to}: {e}");
    }
}
