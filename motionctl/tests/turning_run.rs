//! `motionctl turning run`'s host model and table handling: the model is the
//! firmware's own `Machine` + `ZJob` + encoder logic, so these runs are what the board must
//! report at the end of a QEMU run (`cargo xtask turning-e2e`).

use motion::turning::douglass_table::DOUGLASS_POWER;
use motionctl::turning::run::{self as zrun, LinkTableBytes, ZOutput, ZRunOptions};

fn run_model(o: &ZRunOptions, step: Option<(u64, u32)>) -> zrun::ZModel {
    let cfg = zrun::machine_config(o.tick_hz);
    let spec = zrun::job_spec(o).unwrap();
    let table = LinkTableBytes::douglass().unwrap();
    zrun::model(&cfg, &table, &spec, o.rpm_milli, step, 10 * o.tick_hz as u64).unwrap()
}

#[test]
fn model_feeds_x_to_its_end_and_returns_z_to_rest() {
    let o = ZRunOptions::default();
    let m = run_model(&o, None);
    eprintln!("{m:?}");
    assert!(m.finished && m.faults == 0, "{m:?}");
    // X 0 -> 0.5 in at 1000 steps/in; Z blended back to 0 steps.
    let want_x = (o.x_end_in * zrun::X_STEPS_PER_IN as f64).round() as i64;
    assert_eq!((m.x_steps, m.z_steps), (want_x, 0));
    // The feed takes 0.5 s at 1 in/s: the job ends within the engage and the last steps of it.
    let spec = zrun::job_spec(&o).unwrap();
    let span_q24 = (spec.x_end_in_q24 - spec.x_start_in_q24) as u64;
    let feed_ticks = span_q24.div_ceil(spec.x_feed_in_q24_per_tick as u64) - 1;
    assert!(m.ticks >= feed_ticks && m.ticks < feed_ticks + o.tick_hz as u64 / 10, "{}", m.ticks);
    // Following error of the 10 uin stepper, one rise every other tick: above half a step (the
    // quantisation) and below the 56.9 uin the full 7.5 in feed saturates at.
    assert!(m.max_following_nin > 5_000 && m.max_following_nin < 57_000, "{}", m.max_following_nin);
}

#[test]
fn model_handles_the_20_percent_speed_step_and_the_dac_output() {
    let o = ZRunOptions::default();
    let plain = run_model(&o, None);
    // +20 % at 0.25 s after the start: the command follows the sensed speed, no fault, the
    // same end.
    let stepped = run_model(&o, Some((o.tick_hz as u64 / 4, o.rpm_milli * 6 / 5)));
    eprintln!("plain {plain:?}\nstepped {stepped:?}");
    assert!(stepped.finished && stepped.faults == 0);
    assert_eq!((stepped.x_steps, stepped.z_steps), (plain.x_steps, plain.z_steps));
    // The DAC output: following error is the code quantisation (half a code = 2.44 uin).
    let dac = ZRunOptions { output: ZOutput::Dac, ..ZRunOptions::default() };
    let m = run_model(&dac, None);
    eprintln!("dac {m:?}");
    assert!(m.finished && m.faults == 0);
    let half_code_nin = (1e9 / zrun::DAC_CODES_PER_IN as f64 / 2.0).ceil() as i64;
    assert!(m.max_following_nin <= half_code_nin + 1, "{} > {half_code_nin}", m.max_following_nin);
    assert_eq!(m.z_steps, 0);
}

#[test]
fn table_text_parses_into_the_same_link_bytes() {
    // The checked-in table printed as `X C00 C01 C02 C03` (inches) and parsed back: the same
    // fixed-point rows (the Q32 values survive a 12-digit print).
    let t = &DOUGLASS_POWER;
    let mut text = String::from("X C00 C01 C02 C03\n");
    for r in 0..t.len() {
        let x = (t.x0_in_q24() as f64 + r as f64 * t.dx_in_q24() as f64) / (1u64 << 24) as f64;
        let c = t.row(r).unwrap().map(|v| v as f64 / (1u64 << 32) as f64);
        text += &format!("{x:.9} {:.14} {:.14} {:.14} {:.14}\n", c[0], c[1], c[2], c[3]);
    }
    let parsed = LinkTableBytes::parse("text", &text).unwrap();
    let built_in = LinkTableBytes::douglass().unwrap();
    assert_eq!(parsed.header, built_in.header);
    assert_eq!(parsed.bytes, built_in.bytes);
    assert!(LinkTableBytes::parse("t", "1 2 3 4 5\n").is_err());
    assert!(LinkTableBytes::parse("t", "0 0 0 0 0\n0.1 0 0 0 0\n0.3 0 0 0 0\n").is_err());
}
