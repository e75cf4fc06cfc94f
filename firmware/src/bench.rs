//! DDA micro-benchmarks (the `bench` firmware): cost of one `Dda::tick()` (and of the tick plus
//! the step port's `apply`: pins and recorder) in counts of the board's cycle counter. On the QEMU board that is
//! TIM5 at 1 GHz under `-icount shift=0`, i.e. executed instructions.
//!
//! Each scenario runs long segments at a fixed rate 1.0 and classifies every measured tick by what
//! it did: `idle` (no segment), `moving` (in a segment, no step), `1axis` / `4axes` / `6axes`
//! (that many rising edges). Ticks that start or finish a segment (`segment_change`) and the
//! first tick of a fresh DDA (`first_tick`) are kept apart, so each class is the steady-state
//! cost. Prints `bench key=value` lines: the max per class, and `_mean` variants.

use crate::board::CycleCounter;
use crate::step::RecordedPort;
use board_contract::CycleCounter as _;
use core::hint::black_box;
use core::sync::atomic::{compiler_fence, Ordering::SeqCst};
use motion::dda::Preparer;
use motion::segment::Rate;
use motion::{demo_job, Dda, MachineConfig, Segment, StepOutput, MAX_AXES};

const SEGMENT_TICKS: u32 = 4_000;
const SEGMENTS: u32 = 3;

#[derive(Clone, Copy)]
struct Stat {
    n: u32,
    sum: u64,
    max: u32,
}

impl Stat {
    const EMPTY: Stat = Stat { n: 0, sum: 0, max: 0 };

    fn add(&mut self, v: u32) {
        self.n += 1;
        self.sum += v as u64;
        self.max = self.max.max(v);
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Class {
    Idle,
    Moving,
    OneAxis,
    FourAxes,
    SixAxes,
    SegmentChange,
    FirstTick,
    Other,
}

const CLASSES: [(Class, &str); 7] = [
    (Class::Idle, "idle"),
    (Class::Moving, "moving"),
    (Class::OneAxis, "1axis"),
    (Class::FourAxes, "4axes"),
    (Class::SixAxes, "6axes"),
    (Class::SegmentChange, "segment_change"),
    (Class::FirstTick, "first_tick"),
];

struct Stats([Stat; CLASSES.len()]);

impl Stats {
    fn add(&mut self, class: Class, v: u32) {
        if let Some(i) = CLASSES.iter().position(|&(c, _)| c == class) {
            self.0[i].add(v);
        }
    }

    fn print(&self, prefix: &str) {
        for (s, (_, name)) in self.0.iter().zip(CLASSES) {
            if s.n == 0 {
                continue;
            }
            let mean10 = (s.sum * 10 + s.n as u64 / 2) / s.n as u64;
            defmt::println!("bench {=str}_{=str}={=u32}", prefix, name, s.max);
            defmt::println!(
                "bench {=str}_{=str}_mean={=u64}.{=u64}",
                prefix,
                name,
                mean10 / 10,
                mean10 % 10
            );
        }
    }
}

/// The DDA's tick behind a call boundary: the figure is the DDA's own code with the normal
/// calling convention (call, return and all), not whatever the harness loop inlines around it.
#[inline(never)]
fn tick_once(d: &mut Dda) -> StepOutput {
    d.tick()
}

/// Counter reads bracketing `f`, fenced so the measured work stays between them.
#[inline(always)]
fn measure<R>(c: &CycleCounter, f: impl FnOnce() -> R) -> (R, u32) {
    compiler_fence(SeqCst);
    let t0 = c.now();
    compiler_fence(SeqCst);
    let r = f();
    compiler_fence(SeqCst);
    let t1 = c.now();
    compiler_fence(SeqCst);
    (r, t1.wrapping_sub(t0))
}

/// The demo machine with every axis allowed the fastest rate its pulse timing permits.
fn bench_config() -> MachineConfig {
    let mut cfg = demo_job::config();
    let spacing = defmt::unwrap!(cfg.validate().ok()).min_spacing_ticks;
    for a in cfg.axes.iter_mut() {
        a.max_rate_hz = cfg.tick_hz / spacing;
    }
    cfg
}

/// `axes` axes stepping together one step every `spacing` ticks (the fastest the timing allows:
/// `TickTiming::min_spacing_ticks`), at rate 1.0 throughout.
fn segment(spacing: u32, axes: usize, id: u32) -> Segment {
    let mut steps = [0; MAX_AXES];
    for s in steps.iter_mut().take(axes) {
        *s = (SEGMENT_TICKS / spacing) as i32;
    }
    Segment {
        steps,
        duration_ticks: SEGMENT_TICKS,
        entry_rate: Rate::ONE,
        exit_rate: Rate::ONE,
        accel_per_tick: Rate::ONE,
        id,
    }
}

fn classify(first: bool, idle_before: bool, changed: bool, out: &StepOutput) -> Class {
    if first {
        return Class::FirstTick;
    }
    if changed {
        return Class::SegmentChange;
    }
    match (idle_before, out.rise().count_ones()) {
        (true, 0) => Class::Idle,
        (false, 0) => Class::Moving,
        (_, 1) => Class::OneAxis,
        (_, 4) => Class::FourAxes,
        (_, 6) => Class::SixAxes,
        _ => Class::Other,
    }
}

/// Runs `segments` segments of `axes` moving axes (0: no segment, idle ticks) and folds every
/// tick into `dda_only` or, with `port`, into the tick-plus-apply statistics.
fn scenario(
    c: &CycleCounter,
    overhead: u32,
    axes: usize,
    mut port: Option<&mut RecordedPort>,
    stats: &mut Stats,
) {
    let cfg = bench_config();
    let mut dda = defmt::unwrap!(Dda::new(&cfg).ok());
    let mut prep = defmt::unwrap!(Preparer::new(&cfg).ok());
    let spacing = dda.timing().min_spacing_ticks;
    let mut next_id = 0;
    let total = if axes == 0 { 2_000 } else { SEGMENTS };
    // Keeps the DDA's ready queue full; true once every segment is in.
    let mut feed = |dda: &mut Dda| {
        while axes > 0 && next_id < total && dda.ready_free() > 0 {
            let p = defmt::unwrap!(prep.prepare(&segment(spacing, axes, next_id)).ok());
            defmt::unwrap!(dda.push(&p).ok());
            next_id += 1;
        }
        next_id == total
    };
    let mut all_fed = feed(&mut dda);
    let ticks = if axes == 0 { total } else { SEGMENTS * SEGMENT_TICKS + 100 };
    for _ in 0..ticks {
        let idle_before = dda.is_idle();
        if axes > 0 && idle_before && all_fed {
            // Motion scenarios end with their motion; idle ticks come from the idle scenario.
            break;
        }
        let before = (dda.segments_done(), dda.ready_free());
        let d = black_box(&mut dda);
        let (out, n) = match port.as_deref_mut() {
            None => measure(c, || black_box(tick_once(d))),
            Some(p) => measure(c, || {
                let out = d.tick();
                p.apply(d.now(), &out);
                black_box(out)
            }),
        };
        let changed = (dda.segments_done(), dda.ready_free()) != before;
        stats.add(classify(dda.now() == 1, idle_before, changed, &out), n.saturating_sub(overhead));
        all_fed = feed(&mut dda);
    }
}

pub fn run(c: &CycleCounter, port: &mut RecordedPort) {
    // Cost of an empty measurement: the counter reads themselves.
    let mut overhead = u32::MAX;
    for _ in 0..100 {
        overhead = overhead.min(measure(c, || black_box(0u32)).1);
    }
    defmt::println!("bench measure_overhead_instr={=u32}", overhead);

    let mut dda_only = Stats([Stat::EMPTY; CLASSES.len()]);
    let mut with_apply = Stats([Stat::EMPTY; CLASSES.len()]);
    for axes in [0, 1, 4, 6] {
        scenario(c, overhead, axes, None, &mut dda_only);
        scenario(c, overhead, axes, Some(port), &mut with_apply);
    }
    dda_only.print("dda_tick_instr");
    with_apply.print("tick_apply_instr");
    kernels(c);
    defmt::println!("bench done");
}

/// Cost of one call of each capability's interrupt-rate kernel, measured like the tick: the
/// state advances between calls so every branch the run takes is counted. Prints
/// `bench kernel_<name>_instr=<max>` and `_mean`.
pub fn kernels(c: &CycleCounter) {
    let mut overhead = u32::MAX;
    for _ in 0..100 {
        overhead = overhead.min(measure(c, || black_box(0u32)).1);
    }
    zslide_kernels(c, overhead);
    force_kernels(c, overhead);
    polar_kernels(c, overhead);
    stream_kernels(c, overhead);
}

/// Max and mean (tenths) of `n` measured calls of `f`, printed under `name`.
fn kernel(c: &CycleCounter, overhead: u32, name: &str, n: u32, mut f: impl FnMut(u32)) {
    kernel_prepared(c, overhead, name, n, &mut (), |_, _| {}, |_, i, ()| f(i));
}

/// [`kernel`] over a `state` both steps share, with `prepare` run before each call outside the
/// measurement; its result is the call's input.
fn kernel_prepared<S, T>(
    c: &CycleCounter,
    overhead: u32,
    name: &str,
    n: u32,
    state: &mut S,
    mut prepare: impl FnMut(&mut S, u32) -> T,
    mut f: impl FnMut(&mut S, u32, T),
) {
    let mut s = Stat::EMPTY;
    for i in 0..n {
        let input = prepare(state, i);
        let ((), k) = measure(c, || f(state, i, input));
        s.add(k.saturating_sub(overhead));
    }
    print_stat(name, &s);
}

fn print_stat(name: &str, s: &Stat) {
    let mean10 = (s.sum * 10 + s.n as u64 / 2) / s.n.max(1) as u64;
    defmt::println!("bench kernel_{=str}_instr={=u32}", name, s.max);
    defmt::println!("bench kernel_{=str}_instr_mean={=u64}.{=u64}", name, mean10 / 10, mean10 % 10);
}

fn zslide_kernels(c: &CycleCounter, overhead: u32) {
    use motion::spindle::encoder::QuadratureEncoder;
    use motion::spindle::resolver::Resolver;
    use motion::spindle::SpindleSource;
    use motion::turning::command::ZCommand;
    use motion::turning::douglass_table::DOUGLASS_POWER;
    use motion::turning::scenario::{
        command_config, encoder_config, resolver_config, speed_at_rpm,
    };
    use motion::turning::table::{CoefficientTable, Interp, TableForm};

    let speed = speed_at_rpm(360);
    let mut cmd = defmt::unwrap!(ZCommand::new(&DOUGLASS_POWER, command_config(), 0).ok());
    defmt::unwrap!(cmd.start(0, speed, 0).ok());
    // X from 0 to 8 in over the calls, the angle at 360 rpm.
    let mut angle = 0u32;
    kernel(c, overhead, "zslide_update_power_cubic", 4_000, |i| {
        angle = angle.wrapping_add(speed as u32);
        let x_in_q24 = (i as i32) << 15;
        black_box(cmd.update(black_box(x_in_q24), angle, speed, None));
    });
    // The harmonic form at its largest order: the table's size, not its values, sets the cost.
    const ORDER: u8 = 8;
    const WIDTH: usize = 2 * ORDER as usize + 1;
    static HARMONIC: CoefficientTable<81, WIDTH> = match CoefficientTable::try_new(
        TableForm::Harmonic { order: ORDER },
        0,
        1 << 24 >> 3,
        81,
        [[1_000; WIDTH]; 81],
    ) {
        Ok(t) => t,
        Err(_) => panic!("a valid table"),
    };
    let mut h = defmt::unwrap!(ZCommand::new(&HARMONIC, command_config(), 0).ok());
    defmt::unwrap!(h.start(0, speed, 0).ok());
    let mut angle = 0u32;
    kernel(c, overhead, "zslide_update_harmonic8_cubic", 4_000, |i| {
        angle = angle.wrapping_add(speed as u32);
        let x_in_q24 = (i as i32) << 15;
        black_box(h.update(black_box(x_in_q24), angle, speed, None));
    });
    kernel(c, overhead, "zslide_eval_power_cubic", 4_000, |i| {
        let x_in_q24 = (i as i32) << 15;
        black_box(DOUGLASS_POWER.eval(black_box(x_in_q24), i.wrapping_mul(1 << 20), Interp::Cubic));
    });
    let mut enc = defmt::unwrap!(QuadratureEncoder::new(encoder_config(), 0).ok());
    kernel(c, overhead, "spindle_encoder_update", 4_000, |i| {
        let index = (i % 1000 == 999).then_some(0u16);
        enc.update(black_box((i * 3) as u16), index);
    });
    let res = defmt::unwrap!(Resolver::new(resolver_config()).ok());
    // Samples from the scenario's simulated spindle at 360 rpm, taken outside the measurement.
    let mut state = (res, motion::spindle::sim::SimSpindle::new(0), 1u32);
    kernel_prepared(
        c,
        overhead,
        "spindle_resolver_update",
        4_000,
        &mut state,
        |(_, sim, seed), _| {
            sim.advance(speed as u32);
            sim.resolver(1800, 2, seed)
        },
        |(res, _, _), _, (sin, cos)| res.update(black_box(sin), black_box(cos)),
    );
    defmt::unwrap!(state.0.fault().is_none().then_some(()));
}

fn force_kernels(c: &CycleCounter, overhead: u32) {
    use motion::milling::chain::ForceChain;
    use motion::milling::control::{ControlInput, ForceController};
    use motion::milling::scenario::{chain_config, control_params, SPINDLE_MREV_S};

    let mut chain = defmt::unwrap!(ForceChain::new(chain_config()).ok());
    // Counts with some noise so the stuck detector never trips; every 5th call decimates.
    kernel(c, overhead, "force_chain_sample", 5_000, |i| {
        let n = (i * 7 % 13) as u16;
        let counts = [2_500 + n, 2_400 + n, 2_300 + n];
        black_box(chain.sample(black_box(&counts), SPINDLE_MREV_S, false));
    });
    let mut ctl = defmt::unwrap!(ForceController::new(control_params(18_000_000)).ok());
    kernel(c, overhead, "force_control_update", 2_000, |i| {
        black_box(ctl.update(&ControlInput {
            force_mn: black_box(3_000_000 + (i % 400) * 5_000),
            tooth_updates: 60,
            position_steps: i as i64 * 6,
            spindle_mrev_s: SPINDLE_MREV_S,
            chain_fault: None,
        }));
    });
}

fn polar_kernels(c: &CycleCounter, overhead: u32) {
    use motion::polar::playback::{Playback, SizeScale};
    use motion::polar::{StepEvent, AXIS_R, AXIS_THETA};

    // The queue is kept full outside the measurement: events 3 ticks apart, both axes.
    let mut state = (Playback::new(SizeScale::ONE), 0u32);
    kernel_prepared(
        c,
        overhead,
        "polar_playback_tick",
        4_000,
        &mut state,
        |(p, n), _| {
            while p.free() > 0 {
                let axis = if n.is_multiple_of(3) { AXIS_R } else { AXIS_THETA };
                let _ = p.push(StepEvent { dt_ticks: 3, axis, negative: *n % 50 < 25 });
                *n += 1;
            }
        },
        |(p, _), _, ()| {
            black_box(p.tick());
        },
    );
}

/// Slots per half buffer of the streamed step output: its interrupt's period in slots.
const STREAM_HALF_SLOTS: usize = 64;

/// The streamed step output's fill (`motion::dda::edge_stream`), the work its DMA interrupt
/// would do per half buffer: the DDA at the 500 kHz slot clock with four axes at 250 kHz each,
/// one port word per slot into [`STREAM_HALF_SLOTS`] words. The DDA and the words only: not the
/// machine's step counters and supervision, nor the interrupt's entry and exit.
fn stream_kernels(c: &CycleCounter, overhead: u32) {
    use motion::config::StepTiming;
    use motion::dda::edge_stream::{self, PortWords};
    let mut cfg = bench_config();
    cfg.tick_hz = edge_stream::MAX_STREAM_TICK_HZ;
    cfg.timing = StepTiming { pulse_ns: 1_000, dir_setup_ns: 200, dir_hold_ns: 200 };
    for a in cfg.axes.iter_mut() {
        a.max_rate_hz = cfg.tick_hz / 2;
    }
    let timing = defmt::unwrap!(edge_stream::timing(&cfg).ok());
    let port = defmt::unwrap!(PortWords::new(0, 6, 6).ok());
    let mut state = (
        Dda::with_timing(timing),
        Preparer::with_timing(&cfg, timing),
        0u32,
        [0u32; STREAM_HALF_SLOTS],
    );
    kernel_prepared(
        c,
        overhead,
        "stream_fill_64_slots_4axes",
        400,
        &mut state,
        |(dda, prep, id, _), _| {
            while dda.ready_free() > 0 {
                defmt::unwrap!(dda
                    .push(&defmt::unwrap!(prep
                        .prepare(&segment(timing.min_spacing_ticks, 4, *id))
                        .ok()))
                    .ok());
                *id += 1;
            }
        },
        |(dda, _, _, words), _, ()| {
            let d = black_box(dda);
            port.fill(black_box(words), || d.tick());
        },
    );
}
