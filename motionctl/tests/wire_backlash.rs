//! Backlash compensation of the continuous circle -> complex job (ZT 39, FR 800): take-up
//! segments at every axis reversal, checked against a dead-band model of the mechanism driven by
//! the host model of the firmware tick by tick.

use motion::model;
use motion::segment::Segment;
use motion::wire::{circle_complex_job as table, machine};
use motionctl::wire::backlash::{
    commanded_ends, effective_ends, insert_takeups, validate, DeadBand, SegmentKind, FIELD_NAMES,
    MAX_BACKLASH_STEPS,
};
use motionctl::wire::continuous::{
    circle_complex_path, deviation_mm, joints_from_steps, plan, ContinuousJob, ContinuousParams,
    Patch,
};
use motionctl::wire::job_file::{parse_spec, render, WireJobFileError};
use std::path::PathBuf;
use std::sync::OnceLock;

/// Lash of the measured case: 20 steps on every axis (6 um on X/Y, 0.08 deg on beta).
const LASH: [u32; 4] = [20; 4];

fn plan_with(backlash_steps: [u32; 4]) -> ContinuousJob {
    let prm = ContinuousParams { backlash_steps, ..Default::default() };
    plan(&circle_complex_path().unwrap(), &machine::config(), &prm).unwrap()
}

fn bare() -> &'static ContinuousJob {
    static JOB: OnceLock<ContinuousJob> = OnceLock::new();
    JOB.get_or_init(|| plan_with([0; 4]))
}

fn compensated() -> &'static ContinuousJob {
    static JOB: OnceLock<ContinuousJob> = OnceLock::new();
    JOB.get_or_init(|| plan_with(LASH))
}

/// What a run of the host model through a dead band showed.
struct BandRun {
    ticks: u64,
    trace_hash: u64,
    commanded: [i64; 4],
    tool: [i64; 4],
    /// Segment ends reached, and those where the tool was not at the planned effective position.
    ends: usize,
    misses: usize,
    worst_miss_steps: i64,
    /// Largest distance of the wire from the ruled surface at the tool position, mm.
    worst_dev_mm: f64,
}

/// Runs `job` through the host model; every tick the commanded position drives a [`DeadBand`]
/// with `lash`. At each segment end (the commanded position reaches the segment's commanded
/// end) the tool must be at `want_tool[k]`. With `check_dev` the tool's deviation from the
/// ruled surface of the active segment's patches is measured at every tick that stepped.
fn run_band(
    job: &ContinuousJob,
    lash: [u32; 4],
    want_tool: &[[i64; 4]],
    check_dev: bool,
) -> BandRun {
    let path = circle_complex_path().unwrap();
    let cmd_ends = commanded_ends(&job.segments);
    let mut band = DeadBand::new(lash);
    let (mut k, mut misses, mut worst_miss, mut worst_dev) = (0usize, 0usize, 0i64, 0.0f64);
    let mut it = job.segments.iter().copied();
    let report = model::run(
        &machine::config(),
        || it.next(),
        &[],
        2_000_000_000,
        |dda, out| {
            if out.rise() == 0 {
                return;
            }
            let p = dda.positions();
            let cmd = [p[0], p[1], p[2], p[3]];
            band.move_to(cmd);
            let tool = band.tool();
            // Every segment moves some axis monotonically to its end, so the commanded position
            // equals a segment's end only when that segment has finished.
            while k < cmd_ends.len() && cmd == cmd_ends[k] {
                let miss = (0..4).map(|a| (tool[a] - want_tool[k][a]).abs()).max().unwrap_or(0);
                if miss != 0 {
                    misses += 1;
                    worst_miss = worst_miss.max(miss);
                }
                k += 1;
            }
            if check_dev {
                let j = joints_from_steps(tool);
                let seg = k.min(job.segments.len() - 1);
                let (first, last) = job.segment_pieces[seg];
                let mut dev = f64::INFINITY;
                for step in job.pieces[first].step..=job.pieces[last].step {
                    dev = dev.min(deviation_mm(j, &Patch::of(&path, step)).0);
                }
                if seg > 0 {
                    // Right at a boundary the tool may still be at the previous segment's end.
                    let prev = job.pieces[job.segment_pieces[seg - 1].1].step;
                    dev = dev.min(deviation_mm(j, &Patch::of(&path, prev)).0);
                }
                worst_dev = worst_dev.max(dev);
            }
        },
    )
    .unwrap();
    BandRun {
        ticks: report.ticks,
        trace_hash: report.trace_hash,
        commanded: [
            report.positions[0],
            report.positions[1],
            report.positions[2],
            report.positions[3],
        ],
        tool: band.tool(),
        ends: k,
        misses,
        worst_miss_steps: worst_miss,
        worst_dev_mm: worst_dev,
    }
}

/// With no lash the planner produces today's job: the same segments as the firmware's
/// checked-in table (byte-identical rendering) and the same trace hash on the host model.
#[test]
fn zero_backlash_is_todays_job() {
    let cfg = machine::config();
    let j = bare();
    assert_eq!(*j, plan(&circle_complex_path().unwrap(), &cfg, &Default::default()).unwrap());
    assert!(j.kinds.iter().all(|k| *k == SegmentKind::Path));
    assert_eq!(j.takeup_ticks, 0);
    let file = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../src/wire/circle_complex_job.rs");
    let text = render(j, &cfg, 800.0, "motionctl/tests/wire_job_file.rs");
    assert!(std::fs::read_to_string(file).unwrap() == text, "rendering differs from the table");
    let table_segs: Vec<Segment> =
        table::SEGMENTS.iter().enumerate().map(|(k, s)| s.segment(k as u32)).collect();
    assert_eq!(j.segments, table_segs);
    let mut a = table_segs.iter().copied();
    let m = model::run(&cfg, || a.next(), &[], 20_000_000, |_, _| {}).unwrap();
    let r = run_band(j, [0; 4], &effective_ends(&j.segments, &j.kinds), false);
    assert_eq!((r.ticks, r.trace_hash), (m.ticks, m.trace_hash));
    assert_eq!((r.ends, r.misses), (j.segments.len(), 0));
}

/// The compensated job keeps every cutting segment (steps, nominal duration) of today's job and
/// only adds take-ups; each take-up moves only axes that reverse in the next cutting segment,
/// by exactly their lash, within the axis limits.
#[test]
fn takeups_sit_only_at_reversals() {
    let (c, b, cfg) = (compensated(), bare(), machine::config());
    let cut: Vec<&Segment> = c
        .segments
        .iter()
        .zip(&c.kinds)
        .filter(|(_, k)| **k == SegmentKind::Path)
        .map(|p| p.0)
        .collect();
    assert_eq!(cut.len(), b.segments.len());
    for (x, y) in cut.iter().zip(&b.segments) {
        assert_eq!((x.steps, x.duration_ticks), (y.steps, y.duration_ticks));
    }
    let mut last_dir = [0i32; 4];
    let mut reversals = 0;
    for (k, (s, kind)) in c.segments.iter().zip(&c.kinds).enumerate() {
        s.check(&cfg).unwrap();
        assert_eq!(s.id, k as u32);
        match kind {
            SegmentKind::TakeUp => {
                let next = c.segments[k + 1];
                for a in 0..4 {
                    let rev = last_dir[a] != 0 && next.steps[a].signum() == -last_dir[a];
                    let want = if rev { next.steps[a].signum() * LASH[a] as i32 } else { 0 };
                    assert_eq!(s.steps[a], want, "take-up {k} axis {a}");
                    reversals += rev as usize;
                }
            }
            SegmentKind::Path => {
                for (last, &d) in last_dir.iter_mut().zip(&s.steps) {
                    let d = d.signum();
                    if d != 0 {
                        let rev = *last != 0 && d != *last;
                        // A reversal is always preceded by its take-up.
                        assert!(!rev || c.kinds[k - 1] == SegmentKind::TakeUp, "segment {k}");
                        *last = d;
                    }
                }
            }
        }
    }
    let takeups = c.kinds.iter().filter(|k| **k == SegmentKind::TakeUp).count();
    eprintln!("{takeups} take-up segments for {reversals} axis reversals");
    assert!(takeups > 0 && reversals >= takeups);
}

/// The mechanism with 20 steps of lash per axis, driven tick by tick by the host model:
/// compensated, the tool ends every segment exactly (in steps) at the planned effective
/// position and stays within the tolerance of the ruled surface at every tick; the commanded
/// position the model reports includes the take-up. Uncompensated, the tool misses.
/// The time the take-ups add is measured and reported.
#[test]
fn dead_band_mechanism_follows_the_compensated_job() {
    let (c, b) = (compensated(), bare());
    let tol = ContinuousParams::default().tol_mm;
    let want = effective_ends(&c.segments, &c.kinds);
    let r = run_band(c, LASH, &want, true);
    let offset: Vec<i64> = (0..4).map(|a| r.commanded[a] - r.tool[a]).collect();
    eprintln!(
        "compensated: {} segment ends, {} misses; tool at end {:?}, commanded {:?}; worst deviation {:.5} mm",
        r.ends, r.misses, r.tool, r.commanded, r.worst_dev_mm
    );
    assert_eq!((r.ends, r.misses), (c.segments.len(), 0));
    assert_eq!(r.tool, [0; 4]);
    assert_eq!(r.commanded, *commanded_ends(&c.segments).last().unwrap());
    // Each axis ends engaged one way or the other: 0 or -(first direction) x lash.
    assert!(offset.iter().zip(LASH).all(|(&o, l)| o == 0 || o.abs() == l as i64), "{offset:?}");
    assert!(r.worst_dev_mm <= tol, "worst deviation {} mm", r.worst_dev_mm);

    // The same mechanism fed today's job: the tool misses the planned positions.
    let u = run_band(b, LASH, &effective_ends(&b.segments, &b.kinds), false);
    eprintln!(
        "uncompensated: {} of {} segment ends missed, worst by {} steps; tool at end {:?}",
        u.misses, u.ends, u.worst_miss_steps, u.tool
    );
    assert!(u.misses > 0);
    assert_eq!(u.worst_miss_steps, 20);

    // Time: the take-ups and the slow-downs around them, against 60 A / FR.
    let tick = machine::TICK_HZ as f64;
    let (t_c, t_b) = (r.ticks as f64 / tick, u.ticks as f64 / tick);
    let takeups = c.kinds.iter().filter(|k| **k == SegmentKind::TakeUp).count();
    let added = t_c - t_b;
    eprintln!(
        "time: {t_c:.3} s compensated vs {t_b:.3} s (60 A / FR {:.3} s): +{added:.3} s ({:.3} %) for \
         {takeups} take-ups, {:.3} s of them nominal, {:.1} ms each on average",
        c.time_ruled_s,
        added / c.time_ruled_s * 100.0,
        c.takeup_ticks as f64 / tick,
        added / takeups as f64 * 1e3
    );
    assert!(added > 0.0);
    // Against the physical minimum: each take-up is at least a rest-to-rest triangle of its
    // slowest axis, 2 sqrt(lash / accel) (20 steps at 20 000 steps/s^2: 63.2 ms). The junction
    // slow-downs around them may add a quarter on top, no more.
    let cfg = machine::config();
    let triangles_s: f64 = c
        .segments
        .iter()
        .zip(&c.kinds)
        .filter(|(_, k)| **k == SegmentKind::TakeUp)
        .map(|(s, _)| {
            (0..4)
                .filter(|&a| s.steps[a] != 0)
                .map(|a| {
                    2.0 * (s.steps[a].unsigned_abs() as f64 / cfg.axes[a].accel_steps_per_s2 as f64)
                        .sqrt()
                })
                .fold(0.0, f64::max)
        })
        .sum();
    eprintln!(
        "take-up triangles {triangles_s:.3} s: added time is {:.3} x that",
        added / triangles_s
    );
    assert!(added >= triangles_s * 0.99 && added <= triangles_s * 1.25, "{added} s");
    // Small: the whole job stays within the 1 % of 60 A / FR.
    assert!((t_c / c.time_ruled_s - 1.0).abs() < 0.01, "{t_c} s");
}

/// The thesis's lash, 1 deg of the beta gearbox = 250 steps (seed L2916-2930, BASIC 5980-6050),
/// computed from the step scale, compensated the continuous way: exact segment ends, on the
/// surface, and the time it costs.
#[test]
fn thesis_beta_lash() {
    let beta = motionctl::wire::ik::STEPS_PER_DEG_BETA.round() as u32;
    assert_eq!(beta, 250, "1 deg of beta in steps");
    let lash = [0, 0, beta, 0];
    let c = plan_with(lash);
    let r = run_band(&c, lash, &effective_ends(&c.segments, &c.kinds), true);
    let u = run_band(bare(), lash, &effective_ends(&bare().segments, &bare().kinds), false);
    let takeups = c.kinds.iter().filter(|k| **k == SegmentKind::TakeUp).count();
    let added = (r.ticks - u.ticks) as f64 / machine::TICK_HZ as f64;
    eprintln!(
        "beta lash {beta}: {takeups} take-ups, +{added:.3} s; worst deviation {:.5} mm; \
         uncompensated misses {} of {} (worst {} steps)",
        r.worst_dev_mm, u.misses, u.ends, u.worst_miss_steps
    );
    assert_eq!((r.ends, r.misses, r.tool), (c.segments.len(), 0, [0; 4]));
    assert!(r.worst_dev_mm <= ContinuousParams::default().tol_mm);
    assert!(takeups > 0 && u.misses > 0 && u.worst_miss_steps == beta as i64);
    assert!((r.ticks as f64 / machine::TICK_HZ as f64 / c.time_ruled_s - 1.0).abs() < 0.01);
}

#[test]
fn job_file_backlash_field() {
    let p = parse_spec("version = 1\n").unwrap();
    assert_eq!(p, ContinuousParams::default());
    let p = parse_spec(
        "version = 1\nfr_mm2_per_min = 500\n[backlash]\nx_steps = 20\nbeta_steps = 250\n",
    )
    .unwrap();
    assert_eq!((p.fr_mm2_per_min, p.backlash_steps), (500.0, [20, 0, 250, 0]));
    let err = |src: &str| parse_spec(src).unwrap_err().to_string();
    let e = err("version = 1\n[backlash]\ny_steps = -1\n");
    assert!(e.contains("backlash.y_steps = -1"), "{e}");
    let e = err("version = 1\n[backlash]\nalpha_steps = 1000000\n");
    assert!(e.contains("backlash.alpha_steps = 1000000"), "{e}");
    let e = err("version = 1\n[backlash]\nz_steps = 1\n");
    assert!(e.contains("z_steps"), "{e}");
    assert_eq!(parse_spec("version = 2\n"), Err(WireJobFileError::Version(2)));
    let e = err("version = 1\ntolerance_mm = 0\n");
    assert!(e.contains("tolerance_mm"), "{e}");
}

#[test]
fn cli_backlash_flag_is_checked() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_motionctl"))
        .args(["wire", "plan", "--backlash", "20,-3,0,0"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("backlash Y = -3"), "{err}");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_motionctl"))
        .args(["wire", "plan", "--backlash", "20,20,20"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("want 4"));
}

/// Any sequence of moves (2000 pseudo-random ones; proptest is not a dependency of motionctl):
/// with the take-ups inserted, a dead band with the same lash ends every segment exactly at the
/// running sum of the cutting moves; without them it does not whenever an axis with lash
/// reverses.
#[test]
fn takeups_cancel_any_dead_band() {
    let cfg = machine::config();
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = |n: u64| {
        // xorshift64*
        seed ^= seed >> 12;
        seed ^= seed << 25;
        seed ^= seed >> 27;
        (seed.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 33) % n
    };
    let mut uncompensated_misses = 0;
    for _ in 0..2000 {
        let lash: [u32; 4] = std::array::from_fn(|_| next(41) as u32);
        let n = 1 + next(40) as usize;
        let path: Vec<Segment> = (0..n)
            .map(|_| std::array::from_fn::<i32, 4, _>(|_| next(61) as i32 - 30))
            .filter(|m| m.iter().any(|&d| d != 0))
            .map(|m| Segment {
                steps: [m[0], m[1], m[2], m[3], 0, 0],
                duration_ticks: 1000,
                ..bare().segments[0]
            })
            .collect();
        let (segs, kinds, origin) = insert_takeups(&path, lash, &cfg);
        assert_eq!(origin.len(), segs.len());
        let want = effective_ends(&segs, &kinds);
        let mut band = DeadBand::new(lash);
        for (s, (c, w)) in segs.iter().zip(commanded_ends(&segs).iter().zip(&want)) {
            s.check(&cfg).unwrap();
            band.move_to(*c);
            assert_eq!(band.tool(), *w, "lash {lash:?} moves {path:?}");
        }
        let mut band = DeadBand::new(lash);
        for (c, w) in commanded_ends(&path).iter().zip(commanded_ends(&path).iter()) {
            band.move_to(*c);
            uncompensated_misses += (band.tool() != *w) as usize;
        }
    }
    assert!(uncompensated_misses > 0);
}

#[test]
fn validate_bounds() {
    assert!(validate([0, 0, 0, MAX_BACKLASH_STEPS], FIELD_NAMES).is_ok());
    assert!(validate([0, 0, 0, MAX_BACKLASH_STEPS + 1], FIELD_NAMES).is_err());
}
