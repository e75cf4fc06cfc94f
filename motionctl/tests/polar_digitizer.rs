//! The digitizer end to end: limacon -> events -> stream -> firmware playback, against the ideal
//! tool-centre path; errors for a pole inside and a path outside the work area; the generated
//! built-in stream.

use motion::polar::playback::{Playback, SizeScale};
use motion::polar::stream::{decode_all, BlockEncoder};
use motion::polar::StepEvent;
use motion::segment::Rate;
use motionctl::polar::contour::{witch, Circle, Limacon, Polar};
use motionctl::polar::digitize::{digitize, gauss4, DigitizeError, FeedAt, Setup, ToolPath};
use motionctl::polar::work_area::WorkArea;
use motionctl::polar::Resolution;

const TICK_HZ: u32 = 100_000;

/// The limacon 3 + 2 cos with the thesis's tool, pole moved out to 6.5 in so the whole path is
/// inside the work area (at RI = 5 in the indentation comes within 2.6 in of the machine pole).
pub fn limacon_setup(vt: f64) -> Setup {
    Setup {
        pole_r_in: 6.5,
        pole_angle_rad: 70f64.to_radians(),
        tool_radius_in: 0.125,
        vt_in_per_s: vt,
        res: Resolution::THESIS,
        tick_hz: TICK_HZ,
        cap_speed: true,
        area: WorkArea::FAHIM_1983,
        feed_at: FeedAt::Centre,
    }
}

fn encode(events: &[StepEvent]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut enc = BlockEncoder::new();
    for &e in events {
        enc.push(e, &mut |b: &[u8]| out.extend_from_slice(b)).unwrap();
    }
    enc.finish(&mut |b: &[u8]| out.extend_from_slice(b));
    out
}

/// Plays events; returns the machine's (theta, r) step position after every tick (index = tick).
fn play(events: &[StepEvent], rate: Rate, scale: SizeScale) -> (Vec<[i64; 2]>, Vec<u64>, u32) {
    let mut p = Playback::new(scale);
    p.set_rate(rate);
    let mut it = events.iter();
    let mut pos = vec![[0, 0]];
    let mut rises = Vec::new();
    while !p.done() {
        while p.free() > 0 {
            match it.next() {
                Some(&e) => p.push(e).unwrap(),
                None => {
                    p.finish();
                    break;
                }
            }
        }
        let o = p.tick();
        if o.rise() != 0 {
            rises.push(pos.len() as u64);
        }
        pos.push(p.position());
    }
    (pos, rises, p.fired())
}

#[test]
fn limacon_played_back_stays_within_one_resolution_at_constant_speed() {
    let lim = Polar::closed(Limacon { b: 3.0, a: 2.0 });
    let setup = limacon_setup(0.5);
    let t0 = std::time::Instant::now();
    let d = digitize(&lim, &setup).unwrap();
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    let radial = d.events.iter().filter(|e| e.axis == 1).count();
    println!(
        "limacon digitized: {} events ({} radial, {} angular), length {:.4} in, {ms:.1} ms, min rho {:.4} in, warnings {:?}",
        d.events.len(),
        radial,
        d.events.len() - radial,
        d.length_in,
        d.min_rho_in,
        d.warnings
    );
    assert!(d.warnings.is_empty());
    let bytes = encode(&d.events);
    println!(
        "stream: {} bytes ({:.2} bytes/event; thesis word: 2 bytes/event)",
        bytes.len(),
        bytes.len() as f64 / d.events.len() as f64
    );
    let mut decoded = Vec::new();
    decode_all(&bytes, |e| decoded.push(e)).unwrap();
    assert_eq!(decoded, d.events);
    let (pos, rises, fired) = play(&decoded, Rate::ONE, SizeScale::ONE);
    assert_eq!(fired as usize, d.events.len());
    assert_eq!(*pos.last().unwrap(), [0, 0], "closed contour ends where it starts");
    // Ideal path vs machine: sample the tool centre densely by arc length.
    let path = ToolPath::new(&lim, &setup);
    let speed = |u: f64| {
        let (_, dx, _) = path.eval(u);
        dx[0].hypot(dx[1])
    };
    let n = 200_000;
    let (mut s, mut worst_r, mut worst_th, mut worst_dev) = (0.0, 0.0f64, 0.0f64, 0.0f64);
    let res = setup.res;
    let mut th_prev = d.theta0_rad;
    let mut th_unwrapped = d.theta0_rad;
    for i in 0..=n {
        let u = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
        if i > 0 {
            s += gauss4(u - 2.0 * std::f64::consts::PI / n as f64, u, speed);
        }
        let (x, ..) = path.eval(u);
        let (r, th) = (x[0].hypot(x[1]), x[1].atan2(x[0]));
        th_unwrapped += (th - th_prev + std::f64::consts::PI)
            .rem_euclid(2.0 * std::f64::consts::PI)
            - std::f64::consts::PI;
        th_prev = th;
        let tick = ((s / d.vt_in_per_s * TICK_HZ as f64).round() as usize).min(pos.len() - 1);
        let m = pos[tick];
        let rm = (d.start_r_steps + m[1]) as f64 * res.dr_in;
        let thm = d.theta0_rad + m[0] as f64 * res.dtheta_rad;
        worst_r = worst_r.max((r - rm).abs() / res.dr_in);
        worst_th = worst_th.max((th_unwrapped - thm).abs() / res.dtheta_rad);
        let (xm, ym) = (rm * thm.cos(), rm * thm.sin());
        let dev = (x[0] - xm).hypot(x[1] - ym) / res.deviation_in(r);
        worst_dev = worst_dev.max(dev);
    }
    println!("worst radial error {worst_r:.3} dR, angular {worst_th:.3} dTheta, deviation {worst_dev:.3} of eq 4.1");
    assert!(worst_r < 1.0 && worst_th < 1.0 && worst_dev < 1.0);
    // Speed between events: arc length over the played time (playback fires each event on the
    // tick of its cumulative dt, unit-tested in motion::polar::playback), intervals of 200+ ticks.
    let _ = rises;
    let mut worst_speed = 0.0f64;
    let mut t = 0u64;
    let mut last = (0u64, 0.0f64);
    for (e, &s_in) in d.events.iter().zip(&d.s_in) {
        t += e.dt_ticks as u64;
        if t - last.0 >= 200 {
            let v = (s_in - last.1) / ((t - last.0) as f64 / TICK_HZ as f64);
            worst_speed = worst_speed.max((v / d.vt_in_per_s - 1.0).abs());
            last = (t, s_in);
        }
    }
    println!("worst speed error between events {:.3} %", worst_speed * 100.0);
    assert!(worst_speed < 0.01);
}

#[test]
fn rate_and_size_scaling_on_the_limacon() {
    let lim = Polar::closed(Limacon { b: 3.0, a: 2.0 });
    let d = digitize(&lim, &limacon_setup(0.5)).unwrap();
    let (base, _, _) = play(&d.events, Rate::ONE, SizeScale::ONE);
    let peak_r = base.iter().map(|p| p[1]).max().unwrap();
    for (rate, factor) in [("0.25", 4.0), ("2", 0.5)] {
        let (pos, _, fired) = play(&d.events, Rate::lit(rate), SizeScale::ONE);
        assert_eq!(fired as usize, d.events.len());
        let ratio = (pos.len() - 1) as f64 / (base.len() - 1) as f64;
        assert!((ratio - factor).abs() < 1e-4, "{rate}: {ratio}");
    }
    for (m, k) in [(1u8, 4u8), (4, 1)] {
        let (pos, _, _) = play(&d.events, Rate::ONE, SizeScale::new(m, k).unwrap());
        let pr = pos.iter().map(|p| p[1]).max().unwrap();
        let want = peak_r as f64 * m as f64 / k as f64;
        assert!((pr as f64 - want).abs() <= 1.0 + want * 1e-3, "{m}:{k}: {pr} vs {want}");
        assert!(pos.last().unwrap()[1].abs() <= 1);
    }
}

#[test]
fn pole_inside_and_outside_work_area_are_errors() {
    let c = Polar::closed(Circle { a: 5.0 });
    let mut s = limacon_setup(0.5);
    s.pole_r_in = 1.0;
    assert!(matches!(digitize(&c, &s), Err(DigitizeError::PoleInside(1))));
    // The thesis's own example pole (RI = 5 in): the indentation comes within 3 in.
    let lim = Polar::closed(Limacon { b: 3.0, a: 2.0 });
    s.pole_r_in = 5.0;
    let e = digitize(&lim, &s).unwrap_err();
    assert!(matches!(e, DigitizeError::OutsideWorkArea { r_in, .. } if r_in <= 3.0), "{e}");
    println!("{e}");
}

#[test]
fn open_witch_and_tangency_are_digitized() {
    // Witch of Agnesi a = 2 in over x in [-3, 3], pole placed so it sits in the work area; the
    // curve's top is tangent to a grid circle about the pole somewhere: no Newton to fail.
    let w = witch(2.0, -3.0, 3.0);
    let s = Setup { pole_r_in: 3.0, pole_angle_rad: 1.4, ..limacon_setup(0.5) };
    let d = digitize(&w, &s).unwrap();
    assert!(d.events.len() > 1000);
    let (pos, _, fired) = play(&d.events, Rate::ONE, SizeScale::ONE);
    assert_eq!(fired as usize, d.events.len());
    let net: i64 =
        d.events.iter().filter(|e| e.axis == 1).map(|e| if e.negative { -1 } else { 1 }).sum();
    assert_eq!(pos.last().unwrap()[1], net);
}

/// Inputs that used to digitize into nothing (exit 0, an empty stream) or allocate without
/// bound are refused before any event is made, naming what is wrong.
#[test]
fn degenerate_and_unbounded_inputs_are_refused() {
    use motionctl::polar::cli::parse_contour;
    use motionctl::polar::digitize::{digitize, DigitizeError, FeedAt, Setup, MAX_EVENTS};
    use motionctl::polar::Resolution;
    let setup = |pole_r_in: f64, dr_in: f64| Setup {
        pole_r_in,
        pole_angle_rad: 0.4,
        tool_radius_in: 0.0,
        vt_in_per_s: 0.5,
        res: Resolution { dr_in, dtheta_rad: std::f64::consts::TAU / 16_000.0 },
        tick_hz: 100_000,
        cap_speed: true,
        area: WorkArea::FAHIM_1983,
        feed_at: FeedAt::Centre,
    };
    let limacon = parse_contour("limacon:3,2").unwrap();
    match digitize(limacon.as_ref(), &setup(6.5, 1e-12)) {
        Err(DigitizeError::TooManyEvents { estimated, max, .. }) => {
            assert!(estimated > 1e12 && max == MAX_EVENTS, "{estimated}")
        }
        other => panic!("dR 1e-12: {:?}", other.map(|d| d.events.len())),
    }
    assert!(matches!(
        digitize(limacon.as_ref(), &setup(f64::NAN, 0.001)),
        Err(DigitizeError::Setup(_))
    ));
    for spec in ["circle:0", "witch:1,0,0"] {
        let c = parse_contour(spec).unwrap();
        assert!(
            matches!(digitize(c.as_ref(), &setup(6.5, 0.001)), Err(DigitizeError::Degenerate(_))),
            "{spec}"
        );
    }
}
