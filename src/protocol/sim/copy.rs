//! [`CopySim`]: [`SimTarget`] with copy jobs, for session tests and the host's
//! simulated board: simulated encoders slewing to the host's `Sim(Encoders)` target, the
//! firmware's `CopyMode` and `TeachRecorder`, ticked by [`CopySim::run_copy`] the way the link
//! firmware's tick and status task run them.

#[cfg(feature = "sim-inputs")]
use super::messages::SimRequest;
use super::target::SimTarget;
use crate::config::MAX_AXES;
use crate::machine::{cell, Cell, CommandKind, MachineState};
use crate::polar::copy::CopyMode;
use crate::polar::copy_link::{
    take_batch, SimEncoderSlew, TeachRecorder, TEACH_BATCH, TEACH_BLOCKS,
};
use crate::polar::playback::SizeScale;
use crate::polar::StepEvent;
use crate::protocol::errors::ErrorCode;
use crate::protocol::messages::*;
use crate::protocol::session::LinkTarget;
use crate::protocol::BlockBytes;
use crate::segment::{Rate, Segment};
use crate::wire::link_messages::WireJobParams;

/// A [`SimTarget`] that also runs copy jobs.
#[derive(Clone, Debug)]
pub struct CopySim {
    pub inner: SimTarget,
    /// The current (or last) copy job.
    pub copy: Option<CopyMode>,
    pub copy_running: bool,
    pub teach: TeachRecorder<TEACH_BLOCKS>,
    /// Simulated encoders and the host's target.
    pub encoders: SimEncoderSlew,
    pub encoder_target: [i32; 2],
    /// Machine positions (theta, r) when the copy started.
    base: [i64; 2],
}

impl CopySim {
    pub fn new(inner: SimTarget) -> Self {
        CopySim {
            inner,
            copy: None,
            copy_running: false,
            teach: TeachRecorder::new(),
            encoders: SimEncoderSlew::new(),
            encoder_target: [0; 2],
            base: [0; 2],
        }
    }

    fn stop_copy(&mut self) {
        self.copy_running = false;
    }

    /// `ticks` machine ticks: the encoders slew, the copy steps (held: none taken), positions
    /// follow; then the link task's teach pass.
    pub fn run_copy(&mut self, ticks: u64) {
        for _ in 0..ticks {
            let counts = self.encoders.tick(self.encoder_target);
            self.inner.tick += 1;
            let running = self.copy_running && self.inner.faults == 0;
            if let Some(c) = self.copy.as_mut().filter(|_| running) {
                if self.inner.held {
                    c.tick_held();
                } else {
                    c.tick(counts);
                }
                let p = c.position();
                self.inner.positions[0] = self.base[0] + p[0];
                self.inner.positions[1] = self.base[1] + p[1];
            }
            self.teach_pass();
        }
    }

    /// The status task's teach work: move taught events into blocks while there is room;
    /// end the recording once the copy stopped and its queue is empty.
    pub fn teach_pass(&mut self) {
        let Some(c) = self.copy.as_mut() else { return };
        if self.teach.has_room() {
            let mut buf = [StepEvent::default(); TEACH_BATCH];
            let n = take_batch(c, &mut buf);
            self.teach.push_events(buf.get(..n).unwrap_or(&[]));
        }
        if !self.copy_running && c.taught_waiting() == 0 {
            self.teach.end();
        }
    }

    fn counts(&self) -> (u32, u32) {
        self.copy
            .as_ref()
            .map_or((0, 0), |c| (c.taught_total, c.teach_overflow.saturating_add(self.teach.lost)))
    }

    fn chunk(&self, block: u16, bytes: &[u8], ended: bool) -> TeachChunk {
        let (taught_events, lost_events) = self.counts();
        TeachChunk {
            block,
            bytes: BlockBytes::from_slice(bytes).unwrap_or_default(),
            ended,
            taught_events,
            lost_events,
        }
    }
}

impl LinkTarget for CopySim {
    fn state(&self) -> LinkState {
        match self.inner.state() {
            LinkState::Idle if self.copy_running => LinkState::Moving,
            s => s,
        }
    }
    fn machine_state(&self) -> MachineState {
        self.inner.machine_state()
    }
    fn credits(&self) -> u16 {
        self.inner.credits()
    }
    fn queue_capacity(&self) -> u16 {
        self.inner.queue_capacity()
    }
    fn config(&self) -> LinkConfig {
        self.inner.config()
    }
    fn planned_position(&self) -> [i64; MAX_AXES] {
        self.inner.planned_position()
    }
    fn status(&self) -> Status {
        let (taught_events, lost_events) = self.counts();
        Status {
            state: self.state(),
            copy_running: self.copy_running,
            encoder_counts: self.encoders.counts,
            taught_events,
            lost_events,
            ..self.inner.status()
        }
    }
    fn set_config(&mut self, cfg: &LinkConfig) -> Result<(), ErrorCode> {
        self.inner.set_config(cfg)?;
        self.stop_copy();
        Ok(())
    }
    fn queue_segment(&mut self, seg: &Segment) -> Result<(), ErrorCode> {
        self.inner.queue_segment(seg)
    }
    fn start(&mut self) -> Result<(), ErrorCode> {
        if self.copy_running {
            return Err(ErrorCode::OutOfState);
        }
        self.inner.start()
    }
    fn hold(&mut self) -> Result<(), ErrorCode> {
        self.inner.hold()
    }
    fn resume(&mut self) -> Result<(), ErrorCode> {
        self.inner.resume()
    }
    fn abort(&mut self) -> Result<(), ErrorCode> {
        self.inner.abort()?;
        self.stop_copy();
        Ok(())
    }
    fn set_override(&mut self, rate: Rate) -> Result<(), ErrorCode> {
        self.inner.set_override(rate)
    }
    fn clear_fault(&mut self) -> Result<(), ErrorCode> {
        self.inner.clear_fault()?;
        self.stop_copy();
        Ok(())
    }
    fn home(&mut self) -> Result<(), ErrorCode> {
        self.inner.home()
    }
    fn set_homing(&mut self, homing: &HomingConfig) -> Result<(), ErrorCode> {
        self.inner.set_homing(homing)
    }
    fn jog_off_limit(&mut self) -> Result<(), ErrorCode> {
        self.inner.jog_off_limit()
    }
    fn event_credits(&self) -> u16 {
        self.inner.event_credits()
    }
    fn events_pending(&self) -> bool {
        self.copy_running || self.inner.events_pending()
    }
    /// The encoders are this target's; the wire-stall switch the inner one's; no spindle or
    /// milling plant.
    #[cfg(feature = "sim-inputs")]
    fn sim(&mut self, req: &SimRequest) -> Result<(), ErrorCode> {
        match *req {
            SimRequest::Encoders { arm_counts, carriage_counts } => {
                self.encoder_target = [arm_counts, carriage_counts];
                Ok(())
            }
            SimRequest::Inject { .. } => self.inner.sim(req),
            SimRequest::Spindle { .. }
            | SimRequest::Milling(_)
            | SimRequest::Probe { .. }
            | SimRequest::CorruptConfig => Err(ErrorCode::Unsupported),
        }
    }
}

impl crate::polar::link_messages::PolarTarget for CopySim {
    fn next_event_block(&self) -> Option<u16> {
        self.inner.next_event_block()
    }
    fn queue_events(&mut self, block: &[u8], last: bool) -> Result<(), ErrorCode> {
        if self.copy_running {
            return Err(ErrorCode::OutOfState);
        }
        self.inner.queue_events(block, last)
    }
    fn start_playback(&mut self, scale: SizeScale) -> Result<(), ErrorCode> {
        if self.copy_running {
            return Err(ErrorCode::OutOfState);
        }
        self.inner.start_playback(scale)
    }
    fn start_copy(&mut self, scale: SizeScale, teach: bool) -> Result<(), ErrorCode> {
        let busy = self.copy_running
            || self.inner.events_pending()
            || self.inner.credits() != self.inner.queue_capacity()
            || self.inner.wire_armed.is_some();
        if self.inner.machine != MachineState::Ready || busy {
            return Err(ErrorCode::OutOfState);
        }
        if let Cell::To(s) = cell(self.inner.machine, CommandKind::Start) {
            self.inner.machine = s;
        }
        self.inner.running = true;
        self.inner.mutations += 1;
        self.copy = Some(CopyMode::new(self.encoders.counts, scale, teach));
        self.copy_running = true;
        self.teach.reset(teach);
        self.base = [self.inner.positions[0], self.inner.positions[1]];
        Ok(())
    }
    fn read_teach(&mut self, block: u16) -> Result<TeachChunk, ErrorCode> {
        let r = self.teach.read(block);
        let (bytes, ended) = (BlockBytes::from_slice(r.bytes).unwrap_or_default(), r.ended);
        Ok(TeachChunk { bytes, ..self.chunk(block, &[], ended) })
    }
    fn teach_resend(&self) -> Option<TeachChunk> {
        let block = self.teach.front_seq();
        let r = self.teach.peek(block);
        Some(self.chunk(block, r.bytes, r.ended))
    }
}

impl crate::turning::link_messages::TurningTarget for CopySim {}

impl crate::milling::link_messages::MillingTarget for CopySim {}

impl crate::wire::link_messages::WireTarget for CopySim {
    fn arm_wire(&mut self, params: &WireJobParams) -> Result<(), ErrorCode> {
        if self.copy_running {
            return Err(ErrorCode::OutOfState);
        }
        self.inner.arm_wire(params)
    }
}
