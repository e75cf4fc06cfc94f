//! Shared helpers for the host integration tests in `tests/`.

use motion::config::{TickTiming, MAX_AXES};
use motion::dda::{Dda, Preparer, StepOutput};
use motion::segment::Segment;
use motion::trace::StepRecorder;
use motion::{Command, MachineConfig};

/// Replays pin outputs tick by tick and checks what a stepper driver needs: STEP high for the
/// pulse time, low long enough between pulses, DIR stable for the hold time after an edge and set
/// up before the next one. Records every violation.
#[derive(Default)]
pub struct PinChecker {
    timing: Option<TickTiming>,
    high_since: [Option<u64>; MAX_AXES],
    last_fall: [Option<u64>; MAX_AXES],
    last_rise: [Option<u64>; MAX_AXES],
    last_dir_write: [Option<u64>; MAX_AXES],
    pub violations: Vec<String>,
}

impl PinChecker {
    pub fn new(timing: TickTiming) -> Self {
        PinChecker { timing: Some(timing), ..Default::default() }
    }

    pub fn check(&mut self, tick: u64, out: &StepOutput) {
        let Some(t) = self.timing else { return };
        for i in 0..MAX_AXES {
            let bit = 1u8 << i;
            if out.fall() & bit != 0 {
                match self.high_since[i].take() {
                    Some(r) if tick - r >= t.pulse_ticks as u64 => {}
                    Some(r) => self.fail(format!("axis {i}: pulse {} ticks at {tick}", tick - r)),
                    None => self.fail(format!("axis {i}: fall without rise at {tick}")),
                }
                self.last_fall[i] = Some(tick);
            }
            if out.dir_write() & bit != 0 {
                if let Some(r) = self.last_rise[i] {
                    if tick - r < t.hold_ticks as u64 {
                        self.fail(format!("axis {i}: DIR written {} ticks after edge", tick - r));
                    }
                }
                self.last_dir_write[i] = Some(tick);
            }
            if out.rise() & bit != 0 {
                if self.high_since[i].is_some() {
                    self.fail(format!("axis {i}: rise while high at {tick}"));
                }
                if let Some(r) = self.last_rise[i] {
                    if tick - r < t.min_spacing_ticks as u64 {
                        self.fail(format!("axis {i}: edges {} ticks apart at {tick}", tick - r));
                    }
                }
                if let Some(w) = self.last_dir_write[i] {
                    if tick - w < t.setup_ticks as u64 {
                        self.fail(format!("axis {i}: edge {} ticks after DIR", tick - w));
                    }
                }
                self.high_since[i] = Some(tick);
                self.last_rise[i] = Some(tick);
            }
        }
    }

    /// Some STEP pin is high: a pulse whose fall has not come yet.
    pub fn any_high(&self) -> bool {
        self.high_since.iter().any(Option::is_some)
    }

    fn fail(&mut self, msg: String) {
        if self.violations.len() < 20 {
            self.violations.push(msg);
        }
    }
}

/// Everything a run produced, for assertions.
pub struct Run {
    pub dda: Dda,
    pub rec: StepRecorder,
    pub pins: PinChecker,
    /// (tick, rise mask, dir levels) of every tick with an edge.
    pub edges: Vec<(u64, u8, u8)>,
    /// Ticks at which a segment completed, in order.
    pub segment_ends: Vec<u64>,
    /// Ticks where `dda.positions()` disagreed with the pins' net steps.
    pub position_mismatches: u64,
    pub ticks: u64,
}

/// Feeds `segments` through a Preparer into a DDA (ready queue kept full), applies `commands` at
/// their ticks, and ticks until idle or `max_ticks`, checking positions against the pins on
/// every tick.
pub fn run_segments(
    cfg: &MachineConfig,
    segments: &[Segment],
    commands: &[(u64, Command)],
    max_ticks: u64,
) -> Run {
    let timing = cfg.validate().expect("config");
    run_segments_observed(cfg, timing, segments, commands, max_ticks, |_, _| {})
}

/// [`run_segments`] with the tick timing given (a streamed step output's, validated with
/// `motion::dda::edge_stream::timing`), handing `observe` every tick's number and output.
pub fn run_segments_observed(
    cfg: &MachineConfig,
    timing: TickTiming,
    segments: &[Segment],
    commands: &[(u64, Command)],
    max_ticks: u64,
    mut observe: impl FnMut(u64, &StepOutput),
) -> Run {
    let mut dda = Dda::with_timing(timing);
    let mut prep = Preparer::with_timing(cfg, timing);
    let mut pins = PinChecker::new(*dda.timing());
    let mut rec = StepRecorder::new();
    let mut cmds: Vec<(u64, Command)> = commands.to_vec();
    cmds.sort_by_key(|c| c.0);
    let mut cmds = cmds.into_iter().peekable();
    let mut next = 0;
    let mut edges = Vec::new();
    let mut segment_ends = Vec::new();
    let mut position_mismatches = 0;
    let mut done = dda.segments_done();
    while dda.now() < max_ticks {
        while next < segments.len() && dda.ready_free() > 0 {
            let p = prep.prepare(&segments[next]).expect("valid segment");
            dda.push(&p).expect("room");
            next += 1;
        }
        while let Some(&(at, c)) = cmds.peek() {
            if at > dda.now() {
                break;
            }
            dda.apply(c);
            cmds.next();
        }
        // An idle DDA may still owe the last pulse its fall.
        if next == segments.len() && dda.is_idle() && cmds.peek().is_none() && !pins.any_high() {
            break;
        }
        let out = dda.tick();
        let now = dda.now();
        observe(now, &out);
        rec.record(now, &out);
        pins.check(now, &out);
        if out.rise() != 0 {
            edges.push((now, out.rise(), out.dir()));
        }
        if dda.segments_done() != done {
            done = dda.segments_done();
            segment_ends.push(now);
        }
        if dda.positions()[..] != rec.net[..] {
            position_mismatches += 1;
        }
    }
    let ticks = dda.now();
    Run { dda, rec, pins, edges, segment_ends, position_mismatches, ticks }
}

/// The first position, walking `edges` (tick, rising axes, DIR levels; a set DIR bit is the
/// negative direction) from the origin, that is more than half a step off the straight line of
/// `seg` on some axis: no point k/T of the segment lies within 0.5 step of it on every axis at
/// once. `None`: every step stays within half a step of the line.
pub fn off_the_line(seg: &Segment, edges: &[(u64, u8, u8)]) -> Option<[i64; MAX_AXES]> {
    let t = seg.duration_ticks as f64;
    let mut pos = [0i64; MAX_AXES];
    for &(_, rise, dir) in edges {
        for (i, p) in pos.iter_mut().enumerate() {
            if rise & (1 << i) != 0 {
                *p += if dir & (1 << i) != 0 { -1 } else { 1 };
            }
        }
        // The interval of the line parameter (virtual ticks) each axis allows.
        let (mut lo, mut hi) = (0.0f64, t);
        for (i, &p) in pos.iter().enumerate() {
            let d = seg.steps[i] as f64;
            if d == 0.0 {
                if p != 0 {
                    return Some(pos);
                }
                continue;
            }
            let (a, b) = ((p as f64 - 0.5) * t / d, (p as f64 + 0.5) * t / d);
            lo = lo.max(a.min(b));
            hi = hi.min(a.max(b));
        }
        if lo > hi + 1e-9 {
            return Some(pos);
        }
    }
    None
}
