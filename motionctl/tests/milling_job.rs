//! Milling jobs: parsing, the simulation against the Case A scenario, CSV and PNG output.

use motion::force::scenario::{ForceScenario, Variant};
use motion::scenario::run_to_end;
use motionctl::milling::{job, simulate};

const CASE_A: &str = include_str!("../examples/case_a_milling.toml");

#[test]
fn the_case_a_job_is_the_case_a_scenario() {
    let j = job::parse(CASE_A).unwrap();
    let (report, trace) = simulate::run(&j).unwrap();
    let mut s = ForceScenario::new(Variant::CaseA).unwrap();
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
fn csv_and_png_are_written() {
    let dir = std::env::temp_dir().join(format!("milling-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (_, trace) = simulate::run(&job::parse(CASE_A).unwrap()).unwrap();
    let csv = dir.join("t.csv");
    simulate::write_csv(&csv, &trace).unwrap();
    let text = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(text.lines().count(), trace.len() + 1);
    assert!(text.starts_with("t_s,force_n,override,feed_mm_s\n"));
    let png = dir.join("t.png");
    simulate::write_png(&png, &trace, 4100.0).unwrap();
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    assert!(bytes.len() > 10_000, "{} bytes", bytes.len());
}

#[test]
fn bad_jobs_are_clear_errors() {
    let bad = |from: &str, to: &str| job::parse(&CASE_A.replace(from, to)).unwrap_err().to_string();
    assert!(bad("version = 1", "version = 2").contains("version 2"));
    assert!(bad("fnom_n = 4100", "fnom_n = -1").contains("force.fnom_n"));
    assert!(bad("strategy = \"direct\"", "strategy = \"c\"").contains("force.strategy"));
    assert!(bad("a_mm = 20", "a_mm = 20\nb_mm = 3").contains("b_mm"));
    // Thresholds out of order are refused when the control law is built.
    let j = job::parse(&CASE_A.replace("trip_n = 18000", "trip_n = 4000")).unwrap();
    assert!(simulate::run(&j).unwrap_err().to_string().contains("contact < Fnom < trip"));
}
