//! Fixed-point multi-axis DDA step generator.
//!
//! Each segment is a straight line of `d_i` steps per axis lasting `T` *virtual ticks* at its
//! planned feed. Time is the Bresenham major axis: every virtual tick adds `d_i` to axis `i`'s
//! error term and steps when it turns non-negative, so a segment emits exactly `d_i` steps per axis
//! and each step lies within half a step of the ideal line. Speed is a virtual clock: each real
//! tick advances the segment's phase by `rate` (Q2.30 virtual ticks per tick), and the ramp, the
//! feed override and the feed hold all act on `rate` alone. Step counts therefore never depend on
//! speed, and hold/resume continues from the exact state where it stopped.
//!
//! The tick path is integer-only: adds, compares and one 32x32->64 multiply when the rate changes.
//! Everything that divides (rate caps, floors, carries) is done in [`Preparer::prepare`], at the
//! priority of the task that feeds the DDA.

use crate::config::{ConfigError, MachineConfig, TickTiming, MAX_AXES, TIMING_RING_TICKS};
use crate::fixed_math::isqrt_u64;
use crate::segment::{order_hash, Rate, Segment, SegmentError, ORDER_HASH_START};
use heapless::{Deque, Vec};

mod control;
pub mod edge_stream;
mod fast;
pub mod feed_arbiter;
mod fill;
pub mod lane_kernel_check;
pub mod lanes;
mod prepare;
mod step_output;
pub use fast::FastRun;
use fast::RunFn;
use feed_arbiter::{FeedArbiter, OverrideSource};
pub use fill::TickSink;
use lanes::{Lane, Lanes};
pub use prepare::{Prepared, Preparer};
pub use step_output::StepOutput;

const ONE: u32 = 1 << Rate::FRAC_NBITS;
const RATE_FRAC_BITS: u32 = Rate::FRAC_NBITS;
/// Fastest virtual clock: override 2.0 at nominal feed.
const MAX_RATE: u32 = 2 * ONE;
const RING_MASK: u64 = TIMING_RING_TICKS as u64 - 1;
/// Prepared segments the DDA holds beyond the active one.
pub const READY_DEPTH: usize = 4;
/// Ticks of rising edges a fast run keeps in `Dda::hist` (a byte each in a u32).
const HIST_TICKS: u32 = 4;
/// Tick-stamped commands waiting to take effect.
pub const MAX_SCHEDULED: usize = 8;

/// The DDA's ready queue has no room (see [`Dda::ready_free`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct QueueFull;

/// Feed commands; they act on the tick after they are applied.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    /// The operator's feed override factor, 0..=2.0 (larger values are clamped to 2.0).
    SetOverride(Rate),
    /// The running capability's feed factor (force loop, wire retrace), 0..=2.0; the DDA runs
    /// at the product of both factors ([`feed_arbiter`]).
    CapabilityOverride(Rate),
    /// Decelerate at the segment's acceleration and stop on the path.
    Hold,
    /// Leave a hold and accelerate back to the commanded feed.
    Resume,
}

#[cfg(feature = "defmt")]
impl defmt::Format for Command {
    fn format(&self, f: defmt::Formatter) {
        match self {
            Command::SetOverride(r) => defmt::write!(f, "SetOverride({=u32}/2^30)", r.to_bits()),
            Command::CapabilityOverride(r) => {
                defmt::write!(f, "CapabilityOverride({=u32}/2^30)", r.to_bits())
            }
            Command::Hold => defmt::write!(f, "Hold"),
            Command::Resume => defmt::write!(f, "Resume"),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MotionState {
    /// Nothing to do.
    Idle,
    Moving,
    /// Hold requested; still decelerating.
    Stopping,
    /// Stopped on the path by a hold; `Resume` continues.
    Held,
}

/// Per-axis state while a DIR change or deferred steps hold the axis back.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Gate {
    dir_pending: bool,
    dir_at: u64,
    open_at: u64,
}

/// `repr(C)` with the lanes first: the lane kernel addresses the lanes from the DDA's own address.
#[repr(C)]
pub struct Dda {
    lanes: Lanes,
    timing: TickTiming,
    /// Ticks run; during a cruise, those before it began (see [`Dda::now`]).
    now: u64,

    // Active segment (`remaining == 0`: none).
    remaining: u32,
    t: u32,
    /// `2^32 - t`: the lanes' correction when they step.
    minus_t: u32,
    h: u32,
    wide: bool,
    seg_dir: u8,
    seg_steps: [i32; MAX_AXES],
    seg_exit: u32,
    seg_id: u32,
    cap: u32,
    floor: u32,
    dr: u32,
    two_dr: u64,
    /// Decelerate when `rate_sq >= budget` (both in rate^2 / ONE units).
    budget: u64,
    inv_two_dr: u32,

    // Fast paths (`fast.rs`). A run (cruise or ramp): ticks left (0: off), ticks it was
    // entered for, the phase and rate then, its kind and (tracking) the virtual ticks
    // run; `remaining` and the deceleration budget are brought up to date from these on
    // leaving. Idle: ticks left (0: off).
    cruise_ticks: u32,
    cruise_len: u32,
    cruise_phase: u32,
    run_rate0: u32,
    /// The rate a tracking run rises to (`min(ovr, cap)` on entry).
    run_target: u32,
    run_vticks: u32,
    /// The run's kind and lane count in one byte: one dispatch per tick.
    run_fn: RunFn,
    /// Rising edges of the last [`HIST_TICKS`] ticks while cruising, newest in the low byte.
    hist: u32,
    /// DIR levels in [`StepOutput`]'s place; DIR cannot change during a cruise.
    cruise_dir: u32,
    idle_ticks: u32,
    cruise_enabled: bool,

    // `rate` and `phase` side by side: the cruise tick loads both at once.
    rate: u32,
    phase: u32,
    rate_sq: u64,
    /// The operator and capability factors behind `ovr` (their clamped product).
    arbiter: FeedArbiter,
    ovr: u32,
    holding: bool,

    dir: u8,
    /// Rising edges of the last `TIMING_RING_TICKS` ticks, indexed by tick.
    ring: [u8; TIMING_RING_TICKS as usize],
    /// Axes held back by a gate.
    gated: u8,
    gate: [Gate; MAX_AXES],
    /// Steps counted by the DDA but not yet put on the pins, signed like the axis moves.
    pending: [i32; MAX_AXES],
    origin: [i64; MAX_AXES],

    ready: Deque<Prepared, READY_DEPTH>,
    scheduled: Vec<(u64, Command), MAX_SCHEDULED>,
    next_due: u64,

    segments_done: u32,
    last_done_id: Option<u32>,
    done_hash: u32,
    underruns: u32,
    deferred_steps: u32,
}

impl Dda {
    pub fn new(cfg: &MachineConfig) -> Result<Self, ConfigError> {
        Ok(Self::with_timing(cfg.validate()?))
    }

    /// A DDA with `timing` validated elsewhere (a streamed step output's, [`edge_stream::timing`]).
    pub fn with_timing(timing: TickTiming) -> Self {
        Dda {
            timing,
            now: 0,
            remaining: 0,
            t: 0,
            minus_t: 0,
            h: 0,
            lanes: [Lane::default(); MAX_AXES],
            wide: false,
            seg_dir: 0,
            seg_steps: [0; MAX_AXES],
            seg_exit: 0,
            seg_id: 0,
            cap: 0,
            floor: 0,
            dr: 0,
            two_dr: 0,
            budget: 0,
            inv_two_dr: 0,
            cruise_ticks: 0,
            cruise_len: 0,
            cruise_phase: 0,
            run_rate0: 0,
            run_target: 0,
            run_vticks: 0,
            run_fn: RunFn::CruiseNarrow,
            hist: 0,
            cruise_dir: 0,
            idle_ticks: 0,
            cruise_enabled: true,
            rate: 0,
            rate_sq: 0,
            phase: 0,
            arbiter: FeedArbiter::new(),
            ovr: ONE,
            holding: false,
            dir: 0,
            ring: [0; TIMING_RING_TICKS as usize],
            gated: 0,
            gate: [Gate::default(); MAX_AXES],
            pending: [0; MAX_AXES],
            origin: [0; MAX_AXES],
            ready: Deque::new(),
            scheduled: Vec::new(),
            next_due: u64::MAX,
            segments_done: 0,
            last_done_id: None,
            done_hash: ORDER_HASH_START,
            underruns: 0,
            deferred_steps: 0,
        }
    }

    /// One DDA tick: call at exactly `tick_hz`, apply the result to the pins.
    #[inline]
    pub fn tick(&mut self) -> StepOutput {
        if self.cruise_ticks != 0 {
            self.cruise_ticks -= 1;
            // Direct calls (no function pointer): the divide check follows every one.
            return match self.run_fn {
                RunFn::CruiseNarrow => self.cruise_tick::<false>(),
                RunFn::CruiseWide => self.cruise_tick::<true>(),
                RunFn::AccelerateNarrow => self.accelerate_tick::<false>(),
                RunFn::AccelerateWide => self.accelerate_tick::<true>(),
                RunFn::TrackNarrow => self.track_tick::<false>(),
                RunFn::TrackWide => self.track_tick::<true>(),
            };
        }
        if self.idle_ticks != 0 {
            self.now += 1;
            self.idle_ticks -= 1;
            return StepOutput::new(0, 0, self.dir, 0);
        }
        self.full_tick()
    }

    /// The end of every tick that left the fast paths: steps due too soon are held back, gates
    /// write DIR and release held steps, and the tick's rising edges are recorded.
    #[inline]
    fn settle_edges(&mut self, slot: usize, fall: u8, mut rise: u8, too_soon: u8) -> StepOutput {
        if too_soon != 0 {
            rise &= !too_soon;
            self.defer(too_soon);
        }
        let mut dir_write = 0;
        if self.gated != 0 {
            (rise, dir_write) = self.gate_pass(rise);
        }
        self.ring[slot] = rise;
        StepOutput::new(fall, dir_write, self.dir, rise)
    }

    /// The complete tick: commands, segment changes, ramps, gates. Kept out of line so the
    /// fast paths in [`Dda::tick`] need few registers.
    #[inline(never)]
    fn full_tick(&mut self) -> StepOutput {
        self.leave_fast();
        self.now += 1;
        let now = self.now;
        let slot = (now & RING_MASK) as usize;
        let fall =
            self.ring[(now.wrapping_sub(self.timing.pulse_ticks as u64) & RING_MASK) as usize];
        self.ring[slot] = 0;
        if now >= self.next_due {
            self.run_due_commands();
        }
        if self.remaining == 0 && self.gated == 0 && self.ready.is_empty() {
            self.rate = 0;
            self.rate_sq = 0;
            self.phase = 0;
            self.try_idle();
            return StepOutput::new(fall, 0, self.dir, 0);
        }
        let mut rise = 0;
        if self.remaining != 0 || self.load_next() {
            let r = self.update_rate();
            let p = self.phase + r;
            if p >= ONE {
                rise = self.vtick(slot);
                let p = p - ONE;
                if p >= ONE {
                    self.phase = p - ONE;
                    if self.remaining != 0 || self.load_next() {
                        let again = self.vtick(slot);
                        let twice = rise & again;
                        rise |= again;
                        if twice != 0 {
                            self.defer(twice);
                        }
                    }
                } else {
                    self.phase = p;
                }
            } else {
                self.phase = p;
            }
        }
        let out = self.settle_edges(slot, fall, rise, rise & self.recent_rises());
        self.try_fast_run();
        out
    }

    /// One virtual tick of the active segment's lanes; bit `i`: axis `i` steps (bits 6..: 0).
    #[inline(always)]
    fn bresenham(&mut self) -> u32 {
        lanes::step(&mut self.lanes, self.wide, self.minus_t)
    }

    #[inline(always)]
    fn update_rate(&mut self) -> u32 {
        let r = self.rate;
        let mut target = if self.ovr < self.cap { self.ovr } else { self.cap };
        if self.rate_sq >= self.budget {
            let slower = r.saturating_sub(self.dr).max(self.floor);
            target = target.min(slower);
        }
        if self.holding {
            target = 0;
        }
        let mut nr = if r < target {
            (r + self.dr).min(target)
        } else {
            r.saturating_sub(self.dr).max(target)
        };
        if nr < self.floor && target >= self.floor {
            nr = self.floor;
        }
        if nr != r {
            self.rate = nr;
            self.rate_sq = (nr as u64 * nr as u64) >> RATE_FRAC_BITS;
        }
        nr
    }

    /// One virtual tick of the active segment: the Bresenham step over all moving axes. Steps of
    /// gated axes wait in `pending`; the rest are recorded in this tick's ring slot at once, so a
    /// segment loaded later in the same tick sees them when it times its DIR changes.
    #[inline(always)]
    fn vtick(&mut self, slot: usize) -> u8 {
        self.remaining -= 1;
        self.budget = self.budget.saturating_sub(self.two_dr);
        let mut rise = self.bresenham() as u8;
        if rise & self.gated != 0 {
            rise = self.absorb(rise);
        }
        self.ring[slot] |= rise;
        if self.remaining == 0 {
            self.finish_segment();
        }
        rise
    }

    /// Steps of gated axes join their queue, signed by the segment that produced them.
    #[cold]
    #[inline(never)]
    fn absorb(&mut self, rise: u8) -> u8 {
        let held = rise & self.gated;
        for i in 0..MAX_AXES {
            if held & (1 << i) != 0 {
                self.pending[i] += if self.seg_dir & (1 << i) != 0 { -1 } else { 1 };
            }
        }
        rise & !held
    }

    /// Axes whose last rising edge is too recent for another one this tick.
    #[inline(always)]
    fn recent_rises(&self) -> u8 {
        let mut m = 0;
        for back in 1..self.timing.min_spacing_ticks as u64 {
            m |= self.ring[(self.now.wrapping_sub(back) & RING_MASK) as usize];
        }
        m
    }

    /// Holds steps of ungated axes back for a later tick instead of losing them. Their DIR pins
    /// already show the direction they were produced in.
    #[cold]
    #[inline(never)]
    fn defer(&mut self, axes: u8) {
        for i in 0..MAX_AXES {
            let bit = 1u8 << i;
            if axes & bit == 0 {
                continue;
            }
            self.pending[i] += if self.dir & bit != 0 { -1 } else { 1 };
            self.deferred_steps += 1;
            if self.gated & bit == 0 {
                self.gated |= bit;
                self.gate[i] = Gate { dir_pending: false, dir_at: self.now, open_at: self.now };
            }
        }
    }

    /// Gated axes: write DIR once hold time allows, then release waiting steps one per tick as
    /// setup time and pulse spacing allow; the gate opens when nothing waits.
    #[cold]
    #[inline(never)]
    fn gate_pass(&mut self, mut rise: u8) -> (u8, u8) {
        let mut dir_write = 0;
        let now = self.now;
        let busy = rise | self.recent_rises();
        for i in 0..MAX_AXES {
            let bit = 1u8 << i;
            if self.gated & bit == 0 {
                continue;
            }
            let g = &mut self.gate[i];
            if g.dir_pending && now >= g.dir_at {
                g.dir_pending = false;
                self.dir = (self.dir & !bit) | (self.seg_dir & bit);
                dir_write |= bit;
            }
            let open = !g.dir_pending && now >= g.open_at;
            if open && self.pending[i] != 0 && busy & bit == 0 {
                rise |= bit;
                self.pending[i] -= self.pending[i].signum();
            }
            if open && self.pending[i] == 0 {
                self.gated &= !bit;
            }
        }
        (rise, dir_write)
    }

    /// Starts the next ready segment; false when there is none (or it must wait for a gate).
    #[cold]
    #[inline(never)]
    fn load_next(&mut self) -> bool {
        let Some(next) = self.ready.front() else {
            self.rate = 0;
            self.rate_sq = 0;
            self.phase = 0;
            return false;
        };
        let reversing = (next.dir ^ self.dir) & next.active;
        // An axis still releasing steps in its old direction must finish before DIR flips.
        if reversing & self.gated & self.axes_with_pending() != 0 {
            return false;
        }
        let now = self.now;
        for i in 0..MAX_AXES {
            let bit = 1u8 << i;
            if reversing & bit == 0 {
                continue;
            }
            // DIR may change `hold_ticks` after this axis' last rising edge.
            let mut dir_at = now;
            for back in 0..self.timing.hold_ticks as u64 {
                if self.ring[(now.wrapping_sub(back) & RING_MASK) as usize] & bit != 0 {
                    dir_at = now.saturating_sub(back) + self.timing.hold_ticks as u64;
                    break;
                }
            }
            // A rising edge this tick leaves after the DIR write: DIR must wait a tick.
            if dir_at == now && self.ring[(now & RING_MASK) as usize] & bit != 0 {
                dir_at = now + 1;
            }
            self.gated |= bit;
            self.gate[i] = Gate {
                dir_pending: true,
                dir_at,
                open_at: dir_at + self.timing.setup_ticks as u64,
            };
        }
        // Read in place and dropped after: popping it first would copy the whole slot. Looked up
        // again after the DIR loop: holding `next` across it costs the segment change more.
        let Some(p) = self.ready.front() else {
            return false;
        };
        self.t = p.t;
        self.minus_t = p.t.wrapping_neg();
        self.h = p.h;
        self.remaining = p.t;
        self.wide = p.wide;
        for (lane, &d) in self.lanes.iter_mut().zip(&p.d) {
            // err = k*d + h - t*(s + 1) with k = s = 0; d <= t < 2^31.
            *lane = Lane { err: p.h.wrapping_sub(p.t), d };
        }
        self.seg_dir = p.dir;
        self.seg_steps = p.steps;
        self.seg_exit = p.exit_rate;
        self.seg_id = p.id;
        self.cap = p.cap;
        self.floor = p.floor;
        self.dr = p.dr;
        self.two_dr = 2 * p.dr as u64;
        self.inv_two_dr = p.inv_two_dr;
        self.budget = p.exit_sq + self.two_dr * p.t as u64;
        let carried = ((self.rate as u64 * p.carry as u64) >> RATE_FRAC_BITS).min(MAX_RATE as u64);
        self.rate = carried as u32;
        self.rate_sq = (carried * carried) >> RATE_FRAC_BITS;
        self.ready.pop_front();
        true
    }

    fn axes_with_pending(&self) -> u8 {
        let mut m = 0;
        for i in 0..MAX_AXES {
            if self.pending[i] != 0 {
                m |= 1 << i;
            }
        }
        m
    }

    #[cold]
    #[inline(never)]
    fn finish_segment(&mut self) {
        for i in 0..MAX_AXES {
            self.origin[i] += self.seg_steps[i] as i64;
        }
        self.segments_done += 1;
        self.last_done_id = Some(self.seg_id);
        self.done_hash = order_hash(self.done_hash, self.seg_id);
        if self.ready.is_empty() && self.seg_exit != 0 {
            self.underruns += 1;
        }
    }

    #[cold]
    #[inline(never)]
    fn run_due_commands(&mut self) {
        let now = self.now;
        let mut next = u64::MAX;
        let mut k = 0;
        while k < self.scheduled.len() {
            let (at, cmd) = self.scheduled[k];
            if at <= now {
                self.apply(cmd);
                self.scheduled.remove(k);
            } else {
                next = next.min(at);
                k += 1;
            }
        }
        self.next_due = next;
    }
}
