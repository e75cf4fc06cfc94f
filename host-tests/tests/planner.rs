//! The planner: valid, continuous segments within every axis limit, checked on the step stream.

use host_tests::run_segments;
use motion::config::{AxisLimits, MachineConfig, StepTiming, MAX_AXES};
use motion::demo_job;
use motion::planner::{Move, PlanError, Planner};
use motion::segment::{Segment, MAX_SEGMENT_TICKS};
use proptest::prelude::*;

fn plan(cfg: &MachineConfig, moves: &[Move]) -> Vec<Segment> {
    let mut p = Planner::new(cfg);
    let mut out = Vec::new();
    for m in moves {
        while p.push(m) == Err(PlanError::Full) {
            out.push(p.pop().expect("a full window pops"));
        }
        while let Some(s) = p.pop() {
            out.push(s);
        }
    }
    p.finish();
    while let Some(s) = p.pop() {
        out.push(s);
    }
    out
}

/// Path speed in steps/s of a segment at rate `r`.
fn speed(cfg: &MachineConfig, s: &Segment, r: f64) -> [f64; MAX_AXES] {
    let mut v = [0.0; MAX_AXES];
    for i in 0..MAX_AXES {
        v[i] = r * s.steps[i] as f64 / s.duration_ticks as f64 * cfg.tick_hz as f64;
    }
    v
}

fn move_strategy() -> impl Strategy<Value = Move> {
    (prop::array::uniform6(-3_000i32..=3_000), 500u32..60_000).prop_map(|(mut steps, feed_hz)| {
        if steps.iter().all(|&s| s == 0) {
            steps[2] = 1;
        }
        Move { steps, feed_hz }
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn segments_are_valid_and_continuous(moves in prop::collection::vec(move_strategy(), 1..40)) {
        let cfg = demo_job::config();
        let segs = plan(&cfg, &moves);
        let mut sum = [0i64; MAX_AXES];
        for s in &segs {
            prop_assert_eq!(s.check(&cfg), Ok(()));
            for i in 0..MAX_AXES {
                sum[i] += s.steps[i] as i64;
            }
        }
        let mut want = [0i64; MAX_AXES];
        for m in &moves {
            for i in 0..MAX_AXES {
                want[i] += m.steps[i] as i64;
            }
        }
        prop_assert_eq!(sum, want);
        prop_assert_eq!(segs[0].entry_rate.to_num::<f64>(), 0.0);
        prop_assert_eq!(segs.last().unwrap().exit_rate.to_num::<f64>(), 0.0);
        for w in segs.windows(2) {
            let a = speed(&cfg, &w[0], w[0].exit_rate.to_num());
            let b = speed(&cfg, &w[1], w[1].entry_rate.to_num());
            // Same path speed on both sides, and per-axis jumps within the junction jerk.
            let la: f64 = w[0].steps.iter().map(|&s| (s as f64).powi(2)).sum::<f64>().sqrt();
            let lb: f64 = w[1].steps.iter().map(|&s| (s as f64).powi(2)).sum::<f64>().sqrt();
            let va = a.iter().map(|x| x * x).sum::<f64>().sqrt();
            let vb = b.iter().map(|x| x * x).sum::<f64>().sqrt();
            prop_assert!((va - vb).abs() <= 1e-3 * va.max(vb) + 0.05 * (la.recip() + lb.recip()) * 1e5,
                "junction speeds {} vs {}", va, vb);
            for i in 0..MAX_AXES {
                prop_assert!((a[i] - b[i]).abs() <= cfg.axes[i].junction_jerk_hz as f64 * 1.01 + 1.0,
                    "axis {} jumps {} -> {}", i, a[i], b[i]);
            }
        }
    }
}

#[test]
fn long_moves_are_split_below_the_segment_limit() {
    let mut cfg = demo_job::config();
    cfg.tick_hz = 100_000;
    // 2^31 - 1 steps at 40 kHz: 15 hours, five pieces.
    let mv = Move { steps: [i32::MAX, -7, 0, 0, 0, 0], feed_hz: 40_000 };
    let segs = plan(&cfg, &[mv]);
    assert!(segs.len() > 1);
    assert!(segs.iter().all(|s| s.duration_ticks <= MAX_SEGMENT_TICKS && s.check(&cfg).is_ok()));
    let x: i64 = segs.iter().map(|s| s.steps[0] as i64).sum();
    let y: i64 = segs.iter().map(|s| s.steps[1] as i64).sum();
    assert_eq!((x, y), (i32::MAX as i64, -7));
}

#[test]
fn invalid_moves_are_refused_with_the_reason() {
    let mut cfg = demo_job::config();
    cfg.axis_count = 3;
    let mut p = Planner::new(&cfg);
    assert_eq!(p.push(&Move { steps: [0; MAX_AXES], feed_hz: 10 }), Err(PlanError::Empty));
    assert_eq!(p.push(&Move { steps: [1, 0, 0, 0, 0, 0], feed_hz: 0 }), Err(PlanError::Feed));
    assert_eq!(
        p.push(&Move { steps: [1, 0, 0, 5, 0, 0], feed_hz: 10 }),
        Err(PlanError::UnusedAxis { axis: 3 })
    );
    assert_eq!(
        p.push(&Move { steps: [i32::MAX, 0, 0, 0, 0, 0], feed_hz: 1_000 }),
        Err(PlanError::TooLong)
    );
    assert!(p.pop().is_none());
}

/// The demo job on the pins: per-axis speed changes between 10 ms windows stay within what the
/// acceleration and junction limits allow, at every override the scenario uses.
#[test]
fn demo_job_respects_acceleration_on_the_pins() {
    let cfg = demo_job::config();
    let mut job = demo_job::DemoJob::new();
    let segs: Vec<Segment> = std::iter::from_fn(|| job.next_segment()).collect();
    let run = run_segments(&cfg, &segs, demo_job::commands(), 2_000_000);
    assert!(run.dda.is_idle());
    assert!(run.pins.violations.is_empty(), "{:?}", run.pins.violations);
    let window = 1_000u64;
    let mut counts = vec![[0i64; MAX_AXES]; (run.ticks / window + 2) as usize];
    for &(t, rise, _) in &run.edges {
        for i in 0..MAX_AXES {
            if rise & (1 << i) != 0 {
                counts[(t / window) as usize][i] += 1;
            }
        }
    }
    let w_s = window as f64 / cfg.tick_hz as f64;
    for i in 0..MAX_AXES {
        let a = cfg.axes[i].accel_steps_per_s2 as f64;
        // Window averages of a ramp differ by a*w^2 steps; junctions add the jerk; +-2 counting.
        let bound = a * w_s * w_s + cfg.axes[i].junction_jerk_hz as f64 * w_s + 2.0;
        for (k, c) in counts.windows(2).enumerate() {
            let dv = (c[1][i] - c[0][i]).abs() as f64;
            assert!(dv <= bound, "axis {i} window {k}: {dv} steps change > {bound}");
        }
        let peak = counts.iter().map(|c| c[i]).max().unwrap() as f64 / w_s;
        assert!(peak <= cfg.axes[i].max_rate_hz as f64 * 1.001, "axis {i} peak {peak}");
    }
}

#[test]
fn demo_job_model_ends_where_the_moves_add_up() {
    let r = motion::model::run_demo(|_| {});
    let mut want = [0i64; MAX_AXES];
    for m in &demo_job::MOVES {
        for i in 0..MAX_AXES {
            want[i] += m.steps[i] as i64;
        }
    }
    assert_eq!(r.positions, want);
    assert_eq!(r.underruns, 0);
    assert_eq!(r.segments as usize, demo_job::MOVES.len());
    assert!(r.ticks < motion::model::DEMO_MAX_TICKS, "the demo must finish");
    // Every move of the demo is planned (none refused).
    let mut job = demo_job::DemoJob::new();
    assert_eq!(std::iter::from_fn(|| job.next_segment()).count(), demo_job::MOVES.len());
}

#[test]
fn slow_axes_limit_the_path_feed() {
    let mut cfg = demo_job::config();
    cfg.axes[1] = AxisLimits { max_rate_hz: 1_000, ..cfg.axes[1] };
    cfg.timing = StepTiming { pulse_ns: 2_500, dir_setup_ns: 0, dir_hold_ns: 0 };
    let segs = plan(&cfg, &[Move { steps: [3_000, 1_000, 0, 0, 0, 0], feed_hz: 40_000 }]);
    // Y at 1 kHz for 1000 steps: at least one second.
    assert!(segs[0].duration_ticks >= cfg.tick_hz);
    assert!(segs[0].check(&cfg).is_ok());
}
