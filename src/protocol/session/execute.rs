//! Each request's own checks and its call on the target, once the sequence rules let it run.

#[cfg(feature = "sim-inputs")]
use super::capability::range_nak;
use super::capability::{config_nak, plain, RequestContext};
use super::commands::command_kind;
use super::target::LinkTarget;
use super::BoardLink;
use crate::machine::{cell, Cell};
use crate::protocol::errors::{ErrorCode, SegmentReason};
use crate::protocol::messages::*;
use crate::segment::Rate;

#[cfg(feature = "sim-inputs")]
use crate::protocol::sim::messages::SimRequest;

impl BoardLink {
    pub(super) fn execute(
        &mut self,
        req: &Request,
        t: &mut impl LinkTarget,
    ) -> Result<Reply, (ErrorCode, NakDetail)> {
        let machine = t.machine_state();
        let out_of_state = Err((ErrorCode::OutOfState, NakDetail::State(machine)));
        if let Some(kind) = command_kind(&req.body) {
            if cell(machine, kind) == Cell::Refused {
                return out_of_state;
            }
        }
        let queue_empty = t.credits() == t.queue_capacity();
        match &req.body {
            // Handled before sequencing; never reaches here.
            RequestBody::Hello { .. } => Err(plain(ErrorCode::Internal)),
            RequestBody::GetConfig => Ok(Reply::Config(t.config())),
            RequestBody::GetStatus => Ok(Reply::Status(self.status(t))),
            RequestBody::SetConfig(cfg) => {
                if !queue_empty {
                    return out_of_state;
                }
                cfg.validate().map_err(config_nak)?;
                t.set_config(cfg).map_err(plain)?;
                Ok(Reply::None)
            }
            RequestBody::SetHoming(h) => {
                if !queue_empty {
                    return out_of_state;
                }
                crate::machine::BoardConfig::with_homing(t.config(), h)
                    .validate()
                    .map_err(config_nak)?;
                t.set_homing(h).map_err(plain)?;
                Ok(Reply::None)
            }
            RequestBody::QueueSegments(batch) => {
                if t.events_pending() {
                    return out_of_state;
                }
                if batch.len() > t.credits() as usize {
                    return Err(plain(ErrorCode::QueueFull));
                }
                let cfg = t.config();
                cfg.validate().map_err(config_nak)?;
                let mut pos = t.planned_position();
                for (index, seg) in batch.iter().enumerate() {
                    let index = index as u8;
                    let seg_nak = |(reason, axis)| {
                        (ErrorCode::InvalidSegment, NakDetail::Segment { index, reason, axis })
                    };
                    seg.check(&cfg.machine).map_err(|e| seg_nak(SegmentReason::from_error(e)))?;
                    for (axis, p) in pos.iter_mut().enumerate() {
                        let s = &cfg.scale[axis];
                        if seg.steps[axis] == 0 {
                            continue;
                        }
                        match p.checked_add(seg.steps[axis] as i64) {
                            Some(np) if np >= s.soft_min && np <= s.soft_max => *p = np,
                            _ => return Err(seg_nak((SegmentReason::SoftLimit, Some(axis as u8)))),
                        }
                    }
                }
                for seg in batch.iter() {
                    // Checked above; a failure here is a target bug, reported as Internal.
                    t.queue_segment(seg).map_err(|_| plain(ErrorCode::Internal))?;
                }
                Ok(Reply::None)
            }
            RequestBody::Start => {
                t.config().validate().map_err(config_nak)?;
                t.start().map_err(plain)?;
                Ok(Reply::None)
            }
            RequestBody::Hold => {
                t.hold().map_err(plain)?;
                Ok(Reply::None)
            }
            RequestBody::Resume => {
                t.resume().map_err(plain)?;
                Ok(Reply::None)
            }
            RequestBody::Abort => {
                t.abort().map_err(plain)?;
                Ok(Reply::None)
            }
            RequestBody::Home => {
                t.home().map_err(plain)?;
                Ok(Reply::None)
            }
            RequestBody::JogOffLimit => {
                t.jog_off_limit().map_err(|code| match code {
                    ErrorCode::OutOfState => (code, NakDetail::State(machine)),
                    _ => plain(code),
                })?;
                Ok(Reply::None)
            }
            RequestBody::SetOverride { rate_bits } => {
                if *rate_bits > MAX_OVERRIDE_BITS {
                    return Err(plain(ErrorCode::OutOfRange));
                }
                t.set_override(Rate::from_bits(*rate_bits)).map_err(plain)?;
                Ok(Reply::None)
            }
            RequestBody::SetStatusPeriod { ms } => {
                if *ms != 0 && *ms < MIN_STATUS_PERIOD_MS {
                    return Err(plain(ErrorCode::OutOfRange));
                }
                self.status_period_ms = *ms;
                self.status_due_ms = None;
                Ok(Reply::None)
            }
            RequestBody::Capability(c) => {
                let cx = RequestContext { machine, capabilities: self.capabilities };
                c.execute(&cx, t)
            }
            #[cfg(feature = "sim-inputs")]
            RequestBody::Sim(s) => {
                sim(self.capabilities, s, t)?;
                Ok(Reply::None)
            }
            RequestBody::ArmProbe(kind) => {
                if self.capabilities & CAP_PROBE == 0 {
                    return Err(plain(ErrorCode::Unsupported));
                }
                t.arm_probe(*kind).map_err(|code| match code {
                    ErrorCode::OutOfState => (code, NakDetail::State(machine)),
                    _ => plain(code),
                })?;
                Ok(Reply::None)
            }
            RequestBody::SetProgramOutputs(o) => {
                t.set_program_outputs(*o).map_err(|code| match code {
                    ErrorCode::OutOfState => (code, NakDetail::State(machine)),
                    _ => plain(code),
                })?;
                Ok(Reply::None)
            }
            RequestBody::ClearFault => {
                t.clear_fault().map_err(|code| match code {
                    ErrorCode::OutOfState => (code, NakDetail::State(machine)),
                    _ => plain(code),
                })?;
                Ok(Reply::None)
            }
        }
    }
}

/// A test hook on a board announcing `capabilities`: without the hooks' capabilities
/// `Unsupported`, changing nothing; a milling plant out of range `OutOfRange` naming the field.
#[cfg(feature = "sim-inputs")]
fn sim(
    capabilities: u32,
    req: &SimRequest,
    t: &mut impl LinkTarget,
) -> Result<(), (ErrorCode, NakDetail)> {
    let needs = match req {
        SimRequest::Milling(_) => CAP_SIM_INPUTS | CAP_MILLING_JOB,
        SimRequest::Probe { .. } => CAP_SIM_INPUTS | CAP_PROBE,
        _ => CAP_SIM_INPUTS,
    };
    if capabilities & needs != needs {
        return Err((ErrorCode::Unsupported, NakDetail::None));
    }
    if let SimRequest::Milling(p) = req {
        crate::milling::link_job::check_sim(p).map_err(range_nak)?;
    }
    t.sim(req).map_err(|code| (code, NakDetail::None))
}
