//! Talking to the board outside a job's stream: asking, the job's config, bringing the board to
//! `Ready` (config, faults, homing). Every job runner starts here.

use super::report::{err, link_err, RunError};
use super::watch::JobWatch;
use crate::convert::Program;
use crate::job::Job;
use crate::link::{describe_rejection, Session};
use motion::machine::MachineState;
use motion::protocol::{
    AxisScale, FaultCode, HomingConfig, LinkConfig, Reply, RequestBody, Status,
};
use motion::MAX_AXES;
use std::time::Duration;

/// The job's machine as the board's `LinkConfig`: the step-space config plus per-axis scale and
/// soft limits (rounded to steps the same way move targets are).
pub fn link_config(job: &Job, program: &Program) -> LinkConfig {
    let mut scale = [AxisScale::UNUSED; MAX_AXES];
    for (s, a) in scale.iter_mut().zip(&job.machine.axes) {
        *s = AxisScale {
            steps_per_unit_milli: (a.steps_per_mm * 1000.0).round() as u32,
            soft_min: (a.min_mm * a.steps_per_mm).round() as i64,
            soft_max: (a.max_mm * a.steps_per_mm).round() as i64,
        };
    }
    LinkConfig { machine: program.config, scale, inputs: job.machine.input_filter() }
}

/// (name, steps per mm) of the job's axes.
pub fn axes_of(job: &Job) -> Vec<(String, f64)> {
    job.machine.axes.iter().map(|a| (a.name.clone(), a.steps_per_mm)).collect()
}

/// The names of the fault codes set in `bits`, comma-separated.
pub fn fault_names(bits: u32) -> String {
    let names: Vec<&str> =
        FaultCode::ALL.iter().filter(|f| bits & f.bit() != 0).map(|f| f.name()).collect();
    names.join(", ")
}

/// `a` at or after `b` in seq order.
pub fn seq_at_or_after(a: u32, b: u32) -> bool {
    (a.wrapping_sub(b) as i32) >= 0
}

pub(super) fn status_of(reply: Reply) -> Option<Status> {
    match reply {
        Reply::Status(s) => Some(s),
        _ => None,
    }
}

/// One request answered: the board's reply, or an error naming `what` with the refusal (a
/// link failure as it is). The job runners' one way to ask.
pub fn ask(s: &mut Session, body: RequestBody, what: &str) -> anyhow::Result<Reply> {
    match s.request(body).map_err(|e| anyhow::anyhow!("{e}"))? {
        Ok(r) => Ok(r),
        Err(r) => anyhow::bail!("{what} refused: {}", describe_rejection(&r)),
    }
}

/// The board's status now ([`ask`] with `GetStatus`).
pub fn ask_status(s: &mut Session) -> anyhow::Result<Status> {
    match ask(s, RequestBody::GetStatus, "GetStatus")? {
        Reply::Status(st) => Ok(st),
        _ => anyhow::bail!("the board answered GetStatus without a status"),
    }
}

/// Whether and how [`ready_board`] homes a board that is not homed.
#[derive(Clone, Copy)]
pub enum Home<'a> {
    /// Refuse the job: the operator homes the board (`motionctl home`) or passes `--home`.
    Refuse,
    /// Home with the switches the board was given before.
    AsConfigured,
    /// Give the board the job's machine's switches first (a board given the same ones keeps
    /// its homing; other ones make it home again), then home if `allowed`. A machine without
    /// switches takes the axes where they stand as machine zero: only once `zero_here` says
    /// the operator put them there.
    Switches { homing: &'a HomingConfig, allowed: bool, zero_here: &'a dyn Fn(&str) -> bool },
}

impl Home<'_> {
    /// `Refuse` or `AsConfigured`.
    pub fn allowed(home: bool) -> Home<'static> {
        if home {
            Home::AsConfigured
        } else {
            Home::Refuse
        }
    }
}

/// Brings a connected board to `Ready` with `cfg`, as every job runner starts: refuses a board
/// with a latched fault other than `ConfigMissing` / `ConfigCorrupt` or one that is busy, sends
/// `cfg` when the board's differs (or a fault is latched), clears either of those two (the
/// faults sending the config removes; a corrupt record is reported), gives it the machine's
/// switches and homes when the board is not homed, as `home` says. `what` names the machine in
/// messages. Returns the board's status from before the config was sent.
pub fn ready_board(
    s: &mut Session,
    cfg: LinkConfig,
    home: Home<'_>,
    what: &str,
    say: &dyn Fn(&str),
) -> Result<Status, String> {
    let query = |s: &mut Session, body: RequestBody, name: &str| -> Result<Reply, String> {
        match s.request(body).map_err(|e| e.to_string())? {
            Ok(r) => Ok(r),
            Err(r) => Err(format!("{name} refused: {}", describe_rejection(&r))),
        }
    };
    let status = |s: &mut Session| -> Result<Status, String> {
        match query(s, RequestBody::GetStatus, "GetStatus")? {
            Reply::Status(st) => Ok(st),
            _ => Err("the board answered GetStatus without a status".into()),
        }
    };
    let st = status(s)?;
    // The two faults that sending a config removes; anything else needs the operator.
    let config_missing = FaultCode::ConfigMissing.bit();
    let config_corrupt = FaultCode::ConfigCorrupt.bit();
    let replaceable = config_missing | config_corrupt;
    if st.faults & !replaceable != 0 {
        return Err(format!(
            "the board has faults latched ({}): find the cause, then `motionctl clear-fault`",
            fault_names(st.faults)
        ));
    }
    if !matches!(st.machine, MachineState::Idle | MachineState::Ready | MachineState::Fault)
        || st.queue_depth != 0
    {
        return Err(format!(
            "the board is busy (state {:?}, {} segments queued): run `motionctl abort` first",
            st.machine, st.queue_depth
        ));
    }
    if query(s, RequestBody::GetConfig, "GetConfig")? == Reply::Config(cfg) && st.faults == 0 {
        say(&format!("the board already has the {what}'s config"));
    } else {
        query(s, RequestBody::SetConfig(cfg), &format!("SetConfig ({what})"))?;
        say(&format!("sent the {what}'s config"));
    }
    if st.faults == config_missing {
        query(s, RequestBody::ClearFault, "ClearFault")?;
        say("cleared ConfigMissing (the board had no stored config)");
    } else if st.faults == config_corrupt {
        query(s, RequestBody::ClearFault, "ClearFault")?;
        say(&format!(
            "cleared ConfigCorrupt: the board's stored config failed its check and was replaced by \
             the {what}'s (check the board's flash if this happens again)"
        ));
    }
    if let Home::Switches { homing, .. } = home {
        query(s, RequestBody::SetHoming(*homing), &format!("SetHoming ({what})"))?;
    }
    let now = status(s)?;
    if now.machine != MachineState::Ready {
        match home {
            Home::Refuse | Home::Switches { allowed: false, .. } => {
                return Err(format!(
                    "the board is not homed (state {:?}): home it (`motionctl home`) or pass \
                     --home",
                    now.machine
                ))
            }
            Home::Switches { homing, zero_here, .. } if homing.count == 0 => {
                let ask = format!(
                    "the {what} has no homing switches (no axis has a `home` entry): homing \
                     takes the axes where they stand now as machine zero"
                );
                if !zero_here(&ask) {
                    return Err(format!(
                        "{ask}. Jog them to machine zero (where the job's coordinates start), \
                         then run again with --yes, or answer yes at the prompt"
                    ));
                }
            }
            Home::Switches { .. } | Home::AsConfigured => {}
        }
        self::home(s, cfg.machine.tick_hz, say).map_err(|e| e.to_string())?;
    }
    Ok(st)
}

/// Longest homing may take in board time (the board's own search-distance limit normally
/// ends a failed search first), and in wall time without the position moving.
pub const HOMING_BOARD_SECONDS: u64 = 120;
pub const HOMING_STUCK: Duration = Duration::from_secs(30);

/// Sends `Home` and waits until the board is `Ready` (homed), polling its status; `tick_hz` is
/// the board's tick rate, for the board-time limit.
pub fn home(s: &mut Session, tick_hz: u32, say: &dyn Fn(&str)) -> Result<(), RunError> {
    match s.request(RequestBody::Home).map_err(link_err)? {
        Ok(_) => say("homing"),
        Err(r) => return Err(err(format!("Home refused: {}", describe_rejection(&r)))),
    }
    let mut watch: Option<JobWatch> = None;
    loop {
        let st = match s.request(RequestBody::GetStatus).map_err(link_err)? {
            Ok(Reply::Status(st)) => st,
            Ok(_) => return Err(err("the board answered GetStatus without a status")),
            Err(r) => return Err(err(format!("GetStatus refused: {}", describe_rejection(&r)))),
        };
        match st.machine {
            MachineState::Ready => {
                say(&format!("homed at {:?} steps", &st.positions[..]));
                return Ok(());
            }
            MachineState::Homing => {}
            m => {
                return Err(err(format!(
                    "homing ended in {m:?} (faults: {})",
                    fault_names(st.faults).if_empty("none")
                )))
            }
        }
        let watch = watch.get_or_insert_with(|| {
            JobWatch::new(0, 1.0, HOMING_BOARD_SECONDS * u64::from(tick_hz), HOMING_STUCK)
        });
        let moved: u64 = st.positions.iter().fold(0u64, |h, &p| h.rotate_left(7) ^ p as u64);
        if let Err(why) = watch.check(st.tick, moved) {
            let _ = s.request(RequestBody::Abort);
            return Err(err(format!("homing {why}: aborted")));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

trait IfEmpty {
    fn if_empty(self, alt: &str) -> String;
}

impl IfEmpty for String {
    fn if_empty(self, alt: &str) -> String {
        if self.is_empty() {
            alt.to_string()
        } else {
            self
        }
    }
}
