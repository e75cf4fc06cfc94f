//! What a full tick watches and counts: level causes and fault inputs, the probe, homing, a jog,
//! the job's bookkeeping (segments, a source job) and the step counters with soft limits.

use super::*;

impl Machine {
    /// Level causes and the faults they raise.
    #[inline]
    pub(super) fn watch_inputs(&mut self, dda: &Dda, inp: &Inputs) {
        let mut active = self.active & CONFIG_FAULTS;
        if inp.estop {
            active |= FaultCode::EStop.bit();
        }
        self.switches = (inp.limit_min, inp.limit_max);
        let limits = inp.limit_min | inp.limit_max;
        if limits != 0 {
            active |= FaultCode::LimitSwitch.bit();
        }
        if !inp.link_ok {
            active |= FaultCode::LinkLost.bit();
        }
        let sensors = inp.sensor_faults & SENSOR_FAULTS;
        active |= sensors;
        self.active = active;
        if active == 0 && !inp.tick_overrun {
            return;
        }
        self.fault_inputs(dda, inp, sensors);
    }

    #[cold]
    #[inline(never)]
    pub(super) fn fault_inputs(&mut self, dda: &Dda, inp: &Inputs, sensors: u32) {
        if inp.estop {
            self.raise(FaultCode::EStop);
        }
        if inp.tick_overrun {
            self.tick_overruns = self.tick_overruns.wrapping_add(1);
            self.raise(FaultCode::TickOverrun);
        }
        // Switches matter while anything may move; the homing switch is the sequencer's.
        let moving = matches!(
            self.state,
            MachineState::Homing | MachineState::Running | MachineState::Holding
        ) || !dda.is_idle();
        let (mut min, mut max) = (inp.limit_min, inp.limit_max);
        if self.state == MachineState::Homing {
            if let Some((axis, toward_max)) = self.homing.switch() {
                let bit = 1u8.checked_shl(axis as u32).unwrap_or(0);
                if toward_max {
                    max &= !bit;
                } else {
                    min &= !bit;
                }
            }
        }
        if moving && (min | max) != 0 {
            self.raise(FaultCode::LimitSwitch);
        }
        if !inp.link_ok && matches!(self.state, MachineState::Running | MachineState::Holding) {
            self.raise(FaultCode::LinkLost);
        }
        if sensors != 0 {
            for &f in FaultCode::ALL {
                if sensors & f.bit() != 0 {
                    self.raise(f);
                }
            }
        }
    }

    /// A probe move runs: on the trip, latch every axis's machine position and hold (the DDA
    /// decelerates on the path); once it is at rest, stop (the background aborts the rest of the
    /// move) so the job ends where the axes came to rest.
    #[cold]
    #[inline(never)]
    pub(super) fn watch_probe(&mut self, dda: &Dda, probe: bool) {
        if self.probe.stopping() {
            if matches!(dda.state(), MotionState::Held | MotionState::Idle) {
                self.probe.stopped();
                self.freeze();
            }
        } else if self.probe.trips(probe) {
            self.probe.trip(self.positions());
            self.hold_pending = true;
        }
    }

    /// Counts the tick's rising edges, and checks the soft limits where the position changed.
    #[cold]
    pub(super) fn count(&mut self, step: StepOutput) {
        let (rise, dir) = (step.rise(), step.dir());
        let armed = self.homed && self.state != MachineState::Homing;
        let mut outside = false;
        // Only the axes that stepped: the others cannot have crossed a limit.
        let mut bits = rise as u32;
        while bits != 0 {
            let i = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let (Some(p), Some(&min), Some(&max)) = (
                self.raw.get_mut(i),
                self.raw_limits.min_steps.get(i),
                self.raw_limits.max_steps.get(i),
            ) else {
                break;
            };
            *p += if dir & (1 << i) != 0 { -1 } else { 1 };
            outside |= *p < min || *p > max;
        }
        if armed && outside {
            self.raise(FaultCode::SoftLimit);
        }
    }

    pub(super) fn watch_homing(&mut self, dda: &Dda, inp: &Inputs) {
        let pressed = match self.homing.switch() {
            Some((axis, toward_max)) => {
                let bits = if toward_max { inp.limit_max } else { inp.limit_min };
                bits & 1u8.checked_shl(axis as u32).unwrap_or(0) != 0
            }
            None => false,
        };
        match self.homing.watch(&self.cfg, pressed, dda.is_idle()) {
            HomeEvent::None => {}
            HomeEvent::Stop => self.freeze(),
            HomeEvent::Latched { axis } => {
                let a = (axis as usize).min(MAX_AXES - 1);
                // Saturating: a validated home position and a raw count from real travel are far
                // from i64's range, and a wrapped offset would be a wrong position.
                self.offset[a] = self.cfg.home[a].home_pos_steps.saturating_sub(self.raw[a]);
                self.raw_limits = self.limits.minus(&self.offset);
                self.freeze();
            }
            HomeEvent::NotFound { .. } | HomeEvent::Stuck { .. } => {
                self.raise(FaultCode::HomingFailed);
                return;
            }
        }
        if self.homing.is_done() && !self.homing.needs_move() {
            self.homed = true;
            self.homing.cancel();
            self.enter(MachineState::Ready);
            // The background resets the job bookkeeping to the homed position.
            self.freeze();
        }
    }

    /// A segment's machine checks and the soft limits at the end of everything admitted before
    /// it; on success the planned end moves there (a refusal changes nothing).
    pub(super) fn admit(&mut self, seg: &Segment) -> Result<(), Refusal> {
        seg.check(&self.cfg.link.machine).map_err(Refusal::Segment)?;
        self.planned_end = self
            .limits
            .check_move(&self.planned_end, &seg.steps)
            .map_err(|axis| Refusal::SoftLimit { axis })?;
        Ok(())
    }

    /// The jog off a limit switch: stop once every tripped switch opened, at once if another
    /// closes, and forget the jog when its move ended (the operator may jog again).
    pub(super) fn watch_jog(&mut self, dda: &Dda, inp: &Inputs) {
        let Some(jog) = self.jog else { return };
        match jog.watch(inp.limit_min, inp.limit_max, dda.is_idle()) {
            JogEvent::None => {}
            JogEvent::OtherSwitch | JogEvent::Released | JogEvent::Ended => {
                self.jog = None;
                // Also after a move that ended by itself: the background resets the job
                // bookkeeping to where the axes are.
                self.freeze();
            }
        }
    }

    /// Segments admitted since the last stop and not finished yet (queued in the link, in the
    /// DDA's ready queue, or running).
    pub fn in_flight(&self, dda: &Dda) -> u32 {
        self.admitted.wrapping_sub(dda.segments_done().wrapping_sub(self.done_base))
    }

    pub(super) fn watch_job(&mut self, dda: &Dda) {
        let in_flight = self.in_flight(dda);
        if in_flight == 0 && dda.is_idle() {
            if let Some(fault) = self.probe.job_end() {
                // An error-kind probe move ended without a trip (grbl's ALARM:5).
                self.raise(fault);
                return;
            }
            self.enter(MachineState::Ready);
            return;
        }
        // The DDA runs the last admitted segment, which expects a successor (exit speed > 0),
        // nothing is queued behind it, and the segment is about to end: the host is late. Hold
        // now, so the stop is a ramp on the path instead of the DDA's abrupt stop at the
        // segment end (until then the host may still deliver the successor in time). Like a
        // grbl planner that runs out of blocks, this is a pause, not a fault: the next admitted
        // segment resumes the job. Only an abrupt stop at a segment end is a fault.
        if dda.underruns() != self.underruns_base {
            self.raise(FaultCode::QueueUnderrun);
            return;
        }
        if self.starved {
            // The successor reached the DDA: carry on from where the hold got to (the DDA
            // ramps back up on the path).
            if dda.ready_free() != READY_DEPTH {
                self.starved = false;
                self.resume_pending = true;
            }
            return;
        }
        let starving = in_flight == 1
            && self.last_exit_nonzero
            && dda.ready_free() == READY_DEPTH
            && dda.stop_due(STARVE_MARGIN_VTICKS);
        if starving && !self.paused {
            self.starved = true;
            self.starve_holds = self.starve_holds.wrapping_add(1);
            self.hold_pending = true;
        }
    }

    /// A source job: done when the source has stepped everything; a source that ran dry before
    /// the host's last block is an underrun (hold, like a late segment).
    #[inline]
    pub(super) fn watch_source(&mut self, dda: &Dda, source: &impl StepSource) {
        if source.idle(dda) {
            self.source = None;
            self.source_queued = false;
            // A source's own segments ran through the DDA without entering the plain job's
            // count: the count starts again from here (nothing plain can be queued during it).
            self.admitted = 0;
            self.done_base = dda.segments_done();
            self.enter(MachineState::Ready);
        } else if source.starved() {
            self.raise(FaultCode::QueueUnderrun);
        }
    }
}
