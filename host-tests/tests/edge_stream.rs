//! The streamed step output (`motion::dda::edge_stream`): the DDA at a 500 kHz slot clock, one
//! port word per tick, and the words replayed on a model of the port's set/reset register, as a
//! board's DMA plays them to its pins. What the pins do must be what the DDA stepped: exact
//! counts, every step within half a step of the ideal line, the driver's pulse, setup and hold
//! times met, and four axes at 250 kHz each.

use host_tests::{off_the_line, run_segments_observed};
use motion::config::{AxisLimits, MachineConfig, StepTiming, TickTiming, MAX_AXES};
use motion::dda::edge_stream::{self, apply, PortWords};
use motion::segment::{Rate, Segment};
use motion::Command;
use proptest::prelude::*;

/// The slot clock: the DDA ticks once per slot.
const SLOT_HZ: u32 = 500_000;
/// The F405 motion board's layout: STEP on PC0..PC5, DIR on PC6..PC11.
const PORT: PortWords = match PortWords::new(0, 6, 6) {
    Ok(p) => p,
    Err(_) => panic!("the F405 layout"),
};

/// A driver wanting 1 us pulses and 200 ns of DIR setup and hold: one 2 us slot each.
fn cfg() -> (MachineConfig, TickTiming) {
    let cfg = MachineConfig {
        tick_hz: SLOT_HZ,
        timing: StepTiming { pulse_ns: 1_000, dir_setup_ns: 200, dir_hold_ns: 200 },
        axis_count: MAX_AXES as u8,
        axes: [AxisLimits {
            max_rate_hz: SLOT_HZ / 2,
            accel_steps_per_s2: 20_000_000,
            junction_jerk_hz: 5_000,
        }; MAX_AXES],
    };
    let timing = edge_stream::timing(&cfg).expect("a streamed config");
    (cfg, timing)
}

/// What the replayed port did: every slot with a rising STEP edge (slot, rising axes, DIR
/// levels), and every breach of the driver's timing, from the pin levels alone.
#[derive(Default)]
struct Replay {
    rises: Vec<(u64, u8, u8)>,
    net: [i64; MAX_AXES],
    violations: Vec<String>,
    last_levels: u16,
}

fn replay(words: &[(u64, u32)], t: &TickTiming) -> Replay {
    let mut r = Replay::default();
    let (mut high_since, mut last_rise, mut dir_changed) =
        ([None::<u64>; MAX_AXES], [None::<u64>; MAX_AXES], [None::<u64>; MAX_AXES]);
    let mut levels = 0u16;
    for &(slot, w) in words {
        let now = apply(levels, w);
        let (step_before, step_now) = (levels & PORT.step_pins(), now & PORT.step_pins());
        let (dir_before, dir_now) = ((levels & PORT.dir_pins()) >> 6, (now & PORT.dir_pins()) >> 6);
        let rising = (step_now & !step_before) as u8;
        let falling = (step_before & !step_now) as u8;
        for i in 0..MAX_AXES {
            let bit = 1u8 << i;
            let mut fail = |m: String| {
                if r.violations.len() < 20 {
                    r.violations.push(format!("axis {i} slot {slot}: {m}"));
                }
            };
            if (dir_before ^ dir_now) as u8 & bit != 0 {
                if let Some(e) = last_rise[i] {
                    if slot - e < t.hold_ticks as u64 {
                        fail(format!("DIR changed {} slots after a rise", slot - e));
                    }
                }
                dir_changed[i] = Some(slot);
            }
            if falling & bit != 0 {
                let since = high_since[i].take().expect("a fall follows a rise");
                if slot - since < t.pulse_ticks as u64 {
                    fail(format!("STEP high {} slots", slot - since));
                }
            }
            if rising & bit != 0 {
                // One word changes its pins at one instant: a rise never shares the slot of its
                // DIR change, whatever the setup time asked for.
                if let Some(d) = dir_changed[i] {
                    if slot - d < t.setup_ticks.max(1) as u64 {
                        fail(format!("rise {} slots after a DIR change", slot - d));
                    }
                }
                if let Some(e) = last_rise[i] {
                    if slot - e < t.min_spacing_ticks as u64 {
                        fail(format!("rises {} slots apart", slot - e));
                    }
                }
                high_since[i] = Some(slot);
                last_rise[i] = Some(slot);
                r.net[i] += if dir_now as u8 & bit != 0 { -1 } else { 1 };
            }
        }
        if rising != 0 {
            r.rises.push((slot, rising, dir_now as u8));
        }
        levels = now;
    }
    r.last_levels = levels;
    r
}

/// Runs `segments` (and `commands`) at the slot clock, keeping each tick's word; the DDA's own
/// edges beside them.
fn stream(
    segments: &[Segment],
    commands: &[(u64, Command)],
) -> (Vec<(u64, u32)>, host_tests::Run, TickTiming) {
    let (cfg, timing) = cfg();
    let mut words = Vec::new();
    let run = run_segments_observed(&cfg, timing, segments, commands, 20_000_000, |slot, out| {
        words.push((slot, PORT.word(*out)))
    });
    (words, run, timing)
}

fn total(segs: &[Segment]) -> [i64; MAX_AXES] {
    let mut t = [0i64; MAX_AXES];
    for s in segs {
        for (t, &d) in t.iter_mut().zip(&s.steps) {
            *t += d as i64;
        }
    }
    t
}

/// A legal segment at the slot clock: each axis at most 15/16 of a step every other slot.
fn segment_strategy() -> impl Strategy<Value = Segment> {
    (20u32..6_000, prop::array::uniform6(-1000i32..=1000), 0.0f64..=1.0, 0.0f64..=1.0, 1u32..400)
        .prop_map(|(t, frac, entry, exit, accel)| {
            let max = (t / 2) as i32 * 15 / 16;
            let mut steps = frac.map(|f| f * max / 1000);
            if steps.iter().all(|&s| s == 0) {
                steps[0] = max.max(1);
            }
            Segment {
                steps,
                duration_ticks: t,
                entry_rate: Rate::from_num(entry),
                exit_rate: Rate::from_num(exit),
                accel_per_tick: Rate::from_bits(accel * 1000),
                id: 0,
            }
        })
}

fn command_strategy() -> impl Strategy<Value = (u64, Command)> {
    (
        0u64..40_000,
        prop_oneof![
            (0.0f64..=2.0).prop_map(|r| Command::SetOverride(Rate::from_num(r))),
            Just(Command::Hold),
            Just(Command::Resume),
        ],
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Random jobs with overrides and holds: the replayed pins rise on exactly the slots and
    /// axes the DDA stepped, in its directions; every step comes out; every STEP ends low; the
    /// driver's timing holds on the pins themselves.
    #[test]
    fn the_pins_do_what_the_dda_stepped(
        segs in prop::collection::vec(segment_strategy(), 1..10),
        mut cmds in prop::collection::vec(command_strategy(), 0..8),
    ) {
        cmds.push((40_001, Command::Resume));
        cmds.push((40_001, Command::SetOverride(Rate::ONE)));
        let (words, run, timing) = stream(&segs, &cmds);
        prop_assert!(run.dda.is_idle(), "did not finish in {} slots", run.ticks);
        prop_assert!(run.pins.violations.is_empty(), "DDA timing: {:?}", run.pins.violations);
        let r = replay(&words, &timing);
        prop_assert!(r.violations.is_empty(), "pin timing: {:?}", r.violations);
        prop_assert_eq!(&r.rises, &run.edges);
        prop_assert_eq!(r.net, total(&segs));
        prop_assert_eq!(r.last_levels & PORT.step_pins(), 0);
    }

    /// Every step the pins make on a straight line lies within half a step (per axis) of it:
    /// some point of the segment is within 0.5 step of the position on every axis at once.
    #[test]
    fn the_pins_stay_within_half_a_step_of_the_line(seg in segment_strategy(), ovr in 0.1f64..=2.0) {
        let (words, run, timing) = stream(&[seg], &[(0, Command::SetOverride(Rate::from_num(ovr)))]);
        prop_assert!(run.dda.is_idle());
        let r = replay(&words, &timing);
        prop_assert_eq!(off_the_line(&seg, &r.rises), None);
        prop_assert_eq!(r.net, total(&[seg]));
    }
}

/// A job whose last step rises on the DDA's last busy tick: the run goes on until that pulse
/// has fallen, so the port is left with every STEP low (a case proptest found in CI).
#[test]
fn the_last_pulse_falls_after_the_dda_goes_idle() {
    let seg = |steps: [i32; MAX_AXES], t, entry: f64, exit: f64| Segment {
        steps,
        duration_ticks: t,
        entry_rate: Rate::from_num(entry),
        exit_rate: Rate::from_num(exit),
        accel_per_tick: Rate::from_num(0.000_000_931),
        id: 0,
    };
    let segs = [
        Segment {
            accel_per_tick: Rate::from_num(0.000_073_574_5),
            ..seg([1009, 0, 0, 0, 0, 0], 2155, 0.0, 0.647_508_272)
        },
        seg([9, 0, 0, 0, 0, 0], 20, 0.841_189_857, 0.361_122_602),
        seg([0, 0, 0, 0, 0, 8], 22, 0.740_899_44, 0.0),
    ];
    let cmds = [(1, Command::Hold), (40_001, Command::Resume)];
    let (words, run, timing) = stream(&segs, &cmds);
    assert!(run.dda.is_idle());
    let r = replay(&words, &timing);
    assert!(r.violations.is_empty(), "pin timing: {:?}", r.violations);
    assert_eq!(r.rises, run.edges);
    assert_eq!(r.net, total(&segs));
    assert_eq!(r.last_levels & PORT.step_pins(), 0, "a STEP pin left high");
}

/// Four axes at full feed: at a 500 kHz slot clock each steps every other slot, 250 kHz per axis
/// and 1 MHz together, for the whole cruise, with 2 us pulses.
#[test]
fn four_axes_step_at_250_khz_each_through_the_port() {
    let t = 40_000u32;
    let mut steps = [0i32; MAX_AXES];
    steps[..4].copy_from_slice(&[20_000, -20_000, 20_000, -20_000]);
    // Up to full feed, a cruise at rate 1.0 for exactly `t` slots, down again.
    let up = Segment {
        steps,
        duration_ticks: t,
        entry_rate: Rate::ZERO,
        exit_rate: Rate::ONE,
        accel_per_tick: Rate::from_bits(1 << 16),
        id: 0,
    };
    let cruise = Segment { entry_rate: Rate::ONE, id: 1, ..up };
    let down = Segment { exit_rate: Rate::ZERO, id: 2, ..cruise };
    let (words, run, timing) = stream(&[up, cruise, down], &[]);
    assert!(run.dda.is_idle());
    let r = replay(&words, &timing);
    assert!(r.violations.is_empty(), "pin timing: {:?}", r.violations);
    assert_eq!(r.net, total(&[up, cruise, down]));
    let (from, to) = (run.segment_ends[0], run.segment_ends[1]);
    assert_eq!(to - from, t as u64, "the cruise takes exactly its slots at rate 1.0");
    for axis in 0..4 {
        let slots: Vec<u64> = r
            .rises
            .iter()
            .filter(|&&(s, rise, _)| s > from && s <= to && rise & (1 << axis) != 0)
            .map(|&(s, _, _)| s)
            .collect();
        assert_eq!(slots.len(), 20_000, "axis {axis}: one step per two slots");
        assert!(slots.windows(2).all(|w| w[1] - w[0] == 2), "axis {axis}: every other slot");
        let hz = slots.len() as f64 * SLOT_HZ as f64 / (to - from) as f64;
        assert_eq!(hz, 250_000.0, "axis {axis}");
    }
    // Each STEP pulse is one 2 us slot: the 1 us the driver asked for, rounded up.
    assert_eq!(timing.pulse_ticks as u64 * 1_000_000_000 / SLOT_HZ as u64, 2_000);
}
