//! Digitizer throughput entry point for `cargo xtask bench`.

use super::contour::{Limacon, Polar};
use super::digitize::{digitize, FeedAt, Setup};
use super::work_area::WorkArea;
use super::Resolution;

/// The benchmark contour: the limacon 3 + 2 cos (in) with the thesis's tool (0.125 in), pole
/// 6.5 in at 70 deg (the whole path inside the work area), Vt 0.5 in/s, 16000 steps/rev, 100 kHz.
pub fn limacon_bench_setup() -> Setup {
    Setup {
        pole_r_in: 6.5,
        pole_angle_rad: 70f64.to_radians(),
        tool_radius_in: 0.125,
        vt_in_per_s: 0.5,
        res: Resolution::THESIS,
        tick_hz: 100_000,
        cap_speed: true,
        area: WorkArea::FAHIM_1983,
        feed_at: FeedAt::Centre,
    }
}

/// Median wall time in milliseconds of digitizing the benchmark limacon (5 runs after one
/// warm-up), and the event count (so a caller can see the work was done).
pub fn bench_limacon() -> (f64, usize) {
    let lim = Polar::closed(Limacon { b: 3.0, a: 2.0 });
    let setup = limacon_bench_setup();
    let events = digitize(&lim, &setup).map(|d| d.events.len()).unwrap_or(0);
    let mut ms: Vec<f64> = (0..5)
        .map(|_| {
            let t0 = std::time::Instant::now();
            let d = digitize(&lim, &setup);
            let dt = t0.elapsed().as_secs_f64() * 1e3;
            std::hint::black_box(d.map(|d| d.events.len()).unwrap_or(0));
            dt
        })
        .collect();
    ms.sort_by(f64::total_cmp);
    (ms[ms.len() / 2], events)
}

/// Median milliseconds of [`bench_limacon`].
pub fn bench_limacon_ms() -> f64 {
    bench_limacon().0
}
