//! A capability job driven from outside while its runner owns the link: every pass of the
//! runner's loop hands the latest status to a [`JobHook`] (the grbl bridge answers its sender's
//! real-time bytes there), which may ask for a hold, a resume or an abort; [`Steer`] puts that
//! on the board.

use super::watch::JobWatch;
use crate::link::{describe_rejection, Session};
use anyhow::{anyhow, bail, Result};
use motion::machine::MachineState;
use motion::protocol::{RequestBody, Status};

/// What a job's driver wants now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JobControl {
    /// Run (resume a hold).
    Go,
    /// Feed hold, kept until `Go`.
    Hold,
    /// Stop the job and end the run with an error.
    Abort,
}

pub trait JobHook {
    /// The job's latest status; what the job should do now.
    fn poll(&mut self, st: &Status) -> JobControl;
}

/// No one drives the job (the capability's own subcommand).
pub struct Unattended;

impl JobHook for Unattended {
    fn poll(&mut self, _: &Status) -> JobControl {
        JobControl::Go
    }
}

/// The hold a hook asked for, as the board has it; board time spent holding is not the job's.
#[derive(Debug, Default)]
pub struct Steer {
    /// The board tick the hold was sent at.
    held_at: Option<u64>,
}

impl Steer {
    /// The job is held by its driver (its progress watch waits).
    pub fn held(&self) -> bool {
        self.held_at.is_some()
    }

    /// Asks `hook` and acts: `Hold` on a running job, `Resume` once it lets go (the held board
    /// time added to `watch`'s budget), `Abort` (then an error saying so).
    pub fn step(
        &mut self,
        s: &mut Session,
        hook: &mut dyn JobHook,
        st: &Status,
        watch: &mut JobWatch,
    ) -> Result<()> {
        let link = |e: crate::link::LinkFailure| anyhow!("{e}");
        match (hook.poll(st), self.held_at) {
            (JobControl::Abort, _) => {
                let _ = s.request(RequestBody::Abort).map_err(link)?;
                bail!("aborted by the sender");
            }
            (JobControl::Hold, None) if st.machine == MachineState::Running => {
                if let Err(r) = s.request(RequestBody::Hold).map_err(link)? {
                    bail!("the board refused Hold: {}", describe_rejection(&r));
                }
                self.held_at = Some(st.tick);
            }
            (JobControl::Go, Some(at)) => {
                if st.machine == MachineState::Holding {
                    if let Err(r) = s.request(RequestBody::Resume).map_err(link)? {
                        bail!("the board refused Resume: {}", describe_rejection(&r));
                    }
                }
                watch.extend(st.tick.saturating_sub(at));
                self.held_at = None;
            }
            _ => {}
        }
        Ok(())
    }
}
