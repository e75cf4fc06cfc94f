//! A milling job other than the thesis's Case A (1500 N, 800 rpm, 3 teeth, Kc 2150.5 N/mm^2,
//! b 2 -> 6 mm) settles to its own nominal force the way Case A settles to 4100 N. The
//! expected values are solved here from the plant and the control law: the plant's force at a
//! constant feed v is F = Kc b v tau (eq 4.17, tau = 60 / (z N)); the PI's integrator is at
//! rest only where F = Fnom, unless the feed clamps (override 1.0 = the programmed feed
//! f_t z N) hold it off; the force at the step is the new depth's at the old feed.

use motion::scenario::ScenarioReport;
use motionctl::milling::{job, simulate};

const JOB: &str = include_str!("../examples/pocket_wall_1500n.toml");

/// (force N, feed mm/s) the closed loop settles to at axial depth `b` (mm).
fn closed_loop_steady(fnom: f64, kc: f64, b: f64, tau: f64, v_prog: f64) -> (f64, f64) {
    let v_at_fnom = fnom / (kc * b * tau);
    if v_at_fnom >= v_prog {
        (kc * b * v_prog * tau, v_prog)
    } else {
        (fnom, v_at_fnom)
    }
}

fn fig(r: &ScenarioReport, name: &str) -> f64 {
    r.figure(name).unwrap_or_else(|| panic!("no figure {name}: {r:?}")) as f64
}

#[test]
fn a_1500_n_job_settles_to_1500_n() {
    let (fnom, kc, teeth, rpm, ft, b0, b1) = (1500.0, 2150.5, 3.0, 800.0, 0.25, 2.0, 6.0);
    let tau = 60.0 / (teeth * rpm);
    let v_prog = ft * teeth * rpm / 60.0;
    let (f_before, v_before) = closed_loop_steady(fnom, kc, b0, tau, v_prog);
    let f_at_step = kc * b1 * v_before * tau;
    let (f_after, v_after) = closed_loop_steady(fnom, kc, b1, tau, v_prog);
    // This job clamps at the programmed feed before the step and holds Fnom after it.
    assert!(f_before < fnom && (f_after - fnom).abs() < 1e-9, "{f_before} {f_after}");

    let j = job::parse(JOB).unwrap();
    let (r, trace) = simulate::run(&j).unwrap();
    assert_eq!(r.fault, 0, "{r:?}");
    assert_eq!(fig(&r, "fnom_mn"), 1.5e6, "the report carries the job's Fnom");
    assert_eq!(fig(&r, "lost_steps"), 0.0);
    let within = |got: f64, want: f64, rel: f64| (got - want).abs() <= rel * want;
    let before = fig(&r, "force_before_step_mn") / 1e3;
    assert!(within(before, f_before, 0.01), "before the step {before} N, plant {f_before} N");
    let feed_before = fig(&r, "feed_before_step_um_s") / 1e3;
    assert!(within(feed_before, v_before, 0.01), "{feed_before} mm/s, plant {v_before}");
    let peak = fig(&r, "peak_force_mn") / 1e3;
    assert!(within(peak, f_at_step, 0.02), "peak {peak} N, plant at the step {f_at_step} N");
    // Settles like Case A: inside Fnom +-10 % within 150 ms of the step, dipping at most 20 %.
    let settle_ms = fig(&r, "settle_us") / 1e3;
    assert!(settle_ms <= 150.0, "settled after {settle_ms} ms");
    let dip = fig(&r, "overshoot_below_fnom_mn") / 1e3;
    assert!(dip < 0.2 * fnom, "dips {dip} N below Fnom");
    let feed_after = fig(&r, "feed_after_step_um_s") / 1e3;
    assert!(within(feed_after, v_after, 0.02), "after the step {feed_after} mm/s, plant {v_after}");
    // The last 100 ms average Fnom.
    let t_end = trace.last().unwrap().t_s;
    let late: Vec<f64> = trace.iter().filter(|p| p.t_s > t_end - 0.1).map(|p| p.force_n).collect();
    let mean = late.iter().sum::<f64>() / late.len() as f64;
    assert!(within(mean, fnom, 0.01), "late force {mean} N");
    assert!(late.iter().all(|f| within(*f, fnom, 0.05)), "late force leaves +-5 %");
}

/// The command line reports the job's values in its units, as text and JSON.
#[test]
fn the_summary_is_the_jobs() {
    let run = |extra: &[&str]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_motionctl"))
            .args(["milling", "simulate", "examples/pocket_wall_1500n.toml"])
            .args(extra)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8(out.stdout).unwrap()
    };
    let text = run(&[]);
    for want in
        ["Fnom 1500 N", "800 rpm", "3 teeth", "programmed feed 600.0 mm/min", "Kc 2150.5 N/mm^2"]
    {
        assert!(text.contains(want), "{want} missing:\n{text}");
    }
    assert!(!text.contains("4100") && !text.contains("_mn"), "{text}");
    let j: serde_json::Value = serde_json::from_str(&run(&["--json"])).unwrap();
    assert_eq!(j["fnom_n"], 1500.0);
    assert_eq!(j["settled"], true);
    assert!(j["settle_ms"].as_f64().unwrap() <= 150.0);
    assert!((j["predicted_feed_after_mm_min"].as_f64().unwrap() - 279.0).abs() < 0.1);
}
