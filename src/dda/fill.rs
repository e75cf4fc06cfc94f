//! Many ticks in one call, for a board that takes its ticks a buffer at a time (a streamed step
//! output's fill): each tick's output exactly as [`Dda::tick`] gives it, but a fast run's ticks
//! in one loop, with the run's phase, rate and edge history in registers. Tick by tick, each
//! of those ticks costs a call, the run's dispatch and the register saves around the lane
//! kernel; here that is paid once per run.

use super::fast::run_step;
use super::*;

/// Where [`Dda::ticks_into`] puts each tick's output: a streamed output's word
/// ([`PortWords`](super::edge_stream::PortWords)), the machine's step counters around it, or
/// any `FnMut(&mut W, StepOutput)`. A trait and not a closure so that its `put` can be inlined
/// into the run loops for certain.
pub trait TickSink<W> {
    /// One tick's output, for its slot.
    fn put(&mut self, slot: &mut W, step: StepOutput);
}

impl<W, F: FnMut(&mut W, StepOutput)> TickSink<W> for F {
    #[inline(always)]
    fn put(&mut self, slot: &mut W, step: StepOutput) {
        self(slot, step)
    }
}

impl Dda {
    /// `out.len()` ticks in order, each [`Dda::tick`]'s output put in its slot by `sink`.
    #[inline(always)]
    pub fn ticks_into<W>(&mut self, out: &mut [W], sink: &mut impl TickSink<W>) {
        let mut done = 0;
        while done < out.len() {
            let rest = &mut out[done..];
            done += if self.cruise_ticks == 0 {
                sink.put(&mut rest[0], self.tick());
                1
            } else {
                match self.run_fn {
                    RunFn::CruiseNarrow => self.cruise_run::<false, _>(rest, sink),
                    RunFn::CruiseWide => self.cruise_run::<true, _>(rest, sink),
                    RunFn::AccelerateNarrow => self.accelerate_run::<false, _>(rest, sink),
                    RunFn::AccelerateWide => self.accelerate_run::<true, _>(rest, sink),
                    RunFn::TrackNarrow => self.track_run::<false, _>(rest, sink),
                    RunFn::TrackWide => self.track_run::<true, _>(rest, sink),
                }
            };
        }
    }

    /// A cruise's ticks ([`Dda::cruise_tick`]) for as many of `out`'s slots as the run has
    /// left; the count done.
    #[inline(never)]
    fn cruise_run<const WIDE: bool, W>(
        &mut self,
        out: &mut [W],
        sink: &mut impl TickSink<W>,
    ) -> usize {
        self.plain_run::<WIDE, false, W>(out, sink)
    }

    /// An accelerating run's ticks ([`Dda::accelerate_tick`]), as [`Dda::cruise_run`].
    #[inline(never)]
    fn accelerate_run<const WIDE: bool, W>(
        &mut self,
        out: &mut [W],
        sink: &mut impl TickSink<W>,
    ) -> usize {
        self.plain_run::<WIDE, true, W>(out, sink)
    }

    /// A cruise's (`RISE`: a climb's) ticks: the rate, phase and history in registers through
    /// the loop. A step due too soon ends the run on its tick, the last one done.
    #[inline(always)]
    fn plain_run<const WIDE: bool, const RISE: bool, W>(
        &mut self,
        out: &mut [W],
        sink: &mut impl TickSink<W>,
    ) -> usize {
        let n = out.len().min(self.cruise_ticks as usize);
        let (dir, minus_t, dr) = (self.cruise_dir, self.minus_t, self.dr);
        let (mut rate, mut phase, mut hist) = (self.rate, self.phase, self.hist);
        for (i, w) in out[..n].iter_mut().enumerate() {
            if RISE {
                rate += dr;
            }
            match run_step::<WIDE>(&mut self.lanes, minus_t, dir, rate, &mut phase, &mut hist) {
                Ok(step) => sink.put(w, step),
                Err((fall, rise)) => {
                    (self.rate, self.phase, self.hist) = (rate, phase, hist);
                    self.cruise_ticks -= i as u32 + 1;
                    let step = self.cruise_too_soon(fall, rise);
                    sink.put(w, step);
                    return i + 1;
                }
            }
        }
        (self.rate, self.phase, self.hist) = (rate, phase, hist);
        self.cruise_ticks -= n as u32;
        n
    }

    /// A tracking run's ticks ([`Dda::track_tick`]), as [`Dda::cruise_run`]. Its state stays
    /// in the DDA: each tick's choice reads most of it.
    #[inline(never)]
    fn track_run<const WIDE: bool, W>(
        &mut self,
        out: &mut [W],
        sink: &mut impl TickSink<W>,
    ) -> usize {
        let n = out.len().min(self.cruise_ticks as usize);
        for (i, w) in out[..n].iter_mut().enumerate() {
            self.cruise_ticks -= 1;
            let Some(step) = self.track_step::<WIDE>() else {
                let step = self.track_ends();
                sink.put(w, step);
                return i + 1;
            };
            sink.put(w, step);
            // A step due too soon left the run.
            if self.cruise_len == 0 {
                return i + 1;
            }
        }
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dda::FastRun;

    /// A step due too soon inside a run: the rate cap keeps a job's steps from it, so it is
    /// forced here, by marking every axis as having risen on the last tick. Ticks into a buffer
    /// still equal ticks one at a time through it, in every kind of run.
    #[test]
    fn a_step_due_too_soon_ends_a_buffered_run_as_it_ends_a_tick() {
        let cfg = crate::config::tests::cfg();
        let seg = Segment {
            steps: [3_000, -2_000, 0, 0, 0, 0],
            duration_ticks: 8_000,
            entry_rate: Rate::from_num(0),
            exit_rate: Rate::from_num(0),
            accel_per_tick: Rate::from_num(0.001),
            id: 1,
        };
        for kind in [FastRun::Cruise, FastRun::Accelerate, FastRun::Track] {
            let (mut one, mut many) = (Dda::new(&cfg).unwrap(), Dda::new(&cfg).unwrap());
            let mut prep = Preparer::new(&cfg).unwrap();
            let prepared = prep.prepare(&seg).unwrap();
            one.push(&prepared).unwrap();
            many.push(&prepared).unwrap();
            let mut forced = 0;
            let mut buf = [StepOutput::new(0, 0, 0, 0); 6];
            while forced < 3 && one.now() < 20_000 {
                if one.fast_run() == Some(kind) {
                    let deferred = one.deferred_steps;
                    one.hist |= 0xff;
                    many.hist |= 0xff;
                    many.ticks_into(&mut buf, &mut |w: &mut StepOutput, s| *w = s);
                    for got in buf {
                        assert_eq!(got, one.tick(), "{kind:?} run, tick {}", one.now());
                    }
                    forced += (one.deferred_steps > deferred) as u32;
                } else {
                    assert_eq!(many.tick(), one.tick());
                }
                assert_eq!((many.now(), many.positions()), (one.now(), one.positions()));
            }
            assert_eq!(forced, 3, "steps held back in {kind:?} runs");
        }
    }
}
