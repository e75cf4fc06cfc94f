//! A deterministic sample job for link tests: a zig-zag of short X/Y moves with Z dips and
//! varied feeds, on a 100 steps/mm machine (Z 400 steps/mm) with targets in 0.01 mm, so every
//! target is a whole step and the final position in steps is known without conversion. The
//! motionctl link tests and `cargo xtask test`'s end-to-end QEMU run both stream it.

use std::fmt::Write as _;

/// The machine's DDA tick.
pub const TICK_HZ: u32 = 20_000;
/// (name, steps/mm, max mm/s, accel mm/s^2, junction jerk mm/s, soft limit +-mm).
pub const AXES: [(&str, f64, f64, f64, f64, f64); 3] = [
    ("X", 100.0, 60.0, 5000.0, 25.0, 100.0),
    ("Y", 100.0, 60.0, 5000.0, 25.0, 100.0),
    ("Z", 400.0, 20.0, 2000.0, 5.0, 20.0),
];
pub const FEEDS_MM_MIN: [f64; 5] = [600.0, 900.0, 1200.0, 1500.0, 750.0];

/// Move targets in 0.01 mm, and feeds.
pub fn targets(n: usize) -> Vec<([i64; 3], f64)> {
    let (mut x, mut y, mut z) = (0i64, 0i64, 0i64);
    let mut seed = 12345u64;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let r = (seed >> 33) as i64;
        x += if i % 2 == 0 { 20 + r % 30 } else { -(20 + (r >> 8) % 30) };
        y += if (i / 50) % 2 == 0 { 5 + (r >> 16) % 10 } else { -(5 + (r >> 16) % 10) };
        if i % 7 == 3 {
            z = if z == 0 { -(10 + (r >> 24) % 20) } else { 0 };
        }
        x = x.clamp(-9000, 9000);
        y = y.clamp(-9000, 9000);
        out.push(([x, y, z], FEEDS_MM_MIN[i % FEEDS_MM_MIN.len()]));
    }
    out
}

/// The job file (motionctl TOML format) for `moves`.
pub fn job_toml(moves: &[([i64; 3], f64)]) -> String {
    let mut t = format!(
        "# motionctl::sample_job: {} short moves.\n\
         format = \"motion-job\"\nversion = 1\n\n[machine]\ntick_hz = {TICK_HZ}\n\
         [machine.timing]\npulse_ns = 2_500\ndir_setup_ns = 5_000\ndir_hold_ns = 5_000\n",
        moves.len()
    );
    for (name, spm, rate, accel, jerk, lim) in AXES {
        let _ = write!(
            t,
            "[[machine.axes]]\nname = \"{name}\"\nsteps_per_mm = {spm:.1}\nmax_rate_mm_s = \
             {rate:.1}\naccel_mm_s2 = {accel:.1}\njunction_jerk_mm_s = {jerk:.1}\nmin_mm = \
             -{lim:.1}\nmax_mm = {lim:.1}\n"
        );
    }
    for (p, feed) in moves {
        let _ = write!(
            t,
            "[[moves]]\nto = {{ X = {:.2}, Y = {:.2}, Z = {:.2} }}\nfeed_mm_min = {feed:.1}\n",
            p[0] as f64 / 100.0,
            p[1] as f64 / 100.0,
            p[2] as f64 / 100.0,
        );
    }
    t
}

/// Target in 0.01 mm -> steps (exact: 1 step = 0.01 mm on X/Y, 0.0025 mm on Z).
pub fn to_steps(p: [i64; 3]) -> [i64; 3] {
    [p[0], p[1], p[2] * 4]
}
