//! Both ways to play a digitized contour, judged by one metric: the largest distance of the
//! machine's tool centre from the ideal tool path. The event path (timed single-axis steps through
//! the firmware's playback) against the alternative (short polar linear segments through the
//! host model of the DDA, which interpolates linearly in (theta, r)).

use motionctl::polar::contour::{Limacon, Polar};
use motionctl::polar::digitize::{digitize, FeedAt, Setup};
use motionctl::polar::segments::{
    dense_path, max_deviation_in, play_events, polar_segments, run_segments,
};
use motionctl::polar::work_area::WorkArea;
use motionctl::polar::Resolution;

const TICK_HZ: u32 = 100_000;

fn limacon_setup() -> Setup {
    Setup {
        pole_r_in: 6.5,
        pole_angle_rad: 70f64.to_radians(),
        tool_radius_in: 0.125,
        vt_in_per_s: 0.5,
        res: Resolution::THESIS,
        tick_hz: TICK_HZ,
        cap_speed: true,
        area: WorkArea::FAHIM_1983,
        feed_at: FeedAt::Centre,
    }
}

#[test]
fn event_path_and_segment_path_contour_error() {
    let lim = Polar::closed(Limacon { b: 3.0, a: 2.0 });
    let setup = limacon_setup();
    let res = setup.res;
    let dense = dense_path(&lim, &setup, 400_000);
    let d = digitize(&lim, &setup).unwrap();
    let ev_pos = play_events(&d.events);
    let ev_dev = max_deviation_in(&dense, d.start_r_steps, d.theta0_rad, &res, &ev_pos);
    let r_max = dense.xy.iter().map(|p| p[0].hypot(p[1])).fold(0.0, f64::max);
    println!(
        "event path: {} events, {} ticks, max deviation {:.5} in (eq 4.1 at r_max {:.3} in: {:.5} in)",
        d.events.len(),
        ev_pos.len() - 1,
        ev_dev,
        r_max,
        res.deviation_in(r_max)
    );
    assert!(ev_dev < res.deviation_in(r_max), "{ev_dev}");
    let mut devs = Vec::new();
    for seg_len in [0.02, 0.1, 0.5] {
        let sp = polar_segments(&lim, &setup, seg_len).unwrap();
        let pos = run_segments(&sp, TICK_HZ).unwrap();
        let dev = max_deviation_in(&dense, sp.start_r_steps, sp.theta0_rad, &res, &pos);
        println!(
            "segment path, {seg_len} in segments: {} segments, {} ticks, max deviation {:.5} in",
            sp.segments.len(),
            pos.len() - 1,
            dev
        );
        assert_eq!(*pos.last().unwrap(), [0, 0], "closed contour ends where it starts");
        // Bound: the chord's sagitta L^2 / (8 rho_min) plus one diagonal grid cell (both axes'
        // rounding and Bresenham lag).
        let bound =
            seg_len * seg_len / (8.0 * d.min_rho_in) + res.dr_in.hypot(r_max * res.dtheta_rad);
        assert!(dev <= bound, "{seg_len}: {dev} > {bound}");
        // Timed events put each step at its crossing: never worse than the DDA's segments.
        assert!(ev_dev <= dev, "{seg_len}: events {ev_dev} vs segments {dev}");
        devs.push(dev);
    }
    // Long segments cut corners: the chord error shows.
    assert!(devs[2] > 2.0 * devs[0], "{devs:?}");
}
