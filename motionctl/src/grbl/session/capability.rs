//! The capability commands (`$MILL=`, `$POLAR=`; see [`crate::grbl::jobs`]): the job's runner
//! on the bridge's link, the sender answered meanwhile, then the bridge's own session, config
//! and status stream back, and the result said as `[MSG:]` lines and `ok`, or as an alarm.

use super::{link_err, Bridge, Pending};
use crate::grbl::jobs::{self, JobCmd, SenderHook};
use crate::grbl::protocol::{alarm, error};
use crate::grbl::settings;
use crate::milling::run::MillingRunOptions;
use crate::polar::run::PolarRunOptions;
use anyhow::Result;
use motion::protocol::{HostConfig, RequestBody, SimForceFault, WireConfig};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// What the bridge needs to run capability jobs and come back.
#[derive(Clone, Debug)]
pub struct JobSetup {
    /// Where relative job paths are read from.
    pub dir: PathBuf,
    pub host: HostConfig,
    /// The board may home after a job (a simulated or QEMU board, or `--home`).
    pub home: bool,
    /// The bridge's own config, sent again after a job.
    pub wire: WireConfig,
}

/// Longest wait for the bridge's requests in flight before a job takes the link.
const SETTLE: Duration = Duration::from_secs(5);

/// A job file read and checked, before the link is touched.
enum Loaded {
    Mill(Box<crate::milling::job::MillingJob>),
    Polar { bytes: Vec<u8>, speed: f64, scale: motion::polar::playback::SizeScale },
}

/// What a job gave back.
enum Done {
    /// The report, and the job's nominal force, N.
    Mill(crate::milling::run::MillingRunReport, f64),
    Polar(crate::polar::run::PolarReport),
}

fn file_name(p: &std::path::Path) -> String {
    p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
}

impl Bridge<'_> {
    /// A `$` line that names a capability: `false` when it does not.
    pub(super) fn capability_line(&mut self, raw: &str) -> Result<bool> {
        let Some(dir) = self.jobs.as_ref().map(|j| j.dir.clone()) else { return Ok(false) };
        let Some(parsed) = jobs::parse(raw, &dir) else { return Ok(false) };
        match parsed {
            Err(why) => {
                self.say(&format!("[MSG:{why}]"));
                let unsupported = why.contains("not run behind the bridge");
                self.error(if unsupported {
                    error::UNSUPPORTED_COMMAND
                } else {
                    error::INVALID_STATEMENT
                });
            }
            Ok(_) if self.alarm.is_some() => self.error(error::SYSTEM_GC_LOCK),
            Ok(_) if self.check || self.moving() => self.error(error::IDLE_ERROR),
            Ok(cmd) => self.capability(cmd)?,
        }
        Ok(true)
    }

    fn capability(&mut self, cmd: JobCmd) -> Result<()> {
        let (name, loaded) = match &cmd {
            JobCmd::Mill(path) => (
                file_name(path),
                crate::milling::job::read(path).map(|j| Loaded::Mill(Box::new(j))),
            ),
            JobCmd::Polar { file, speed, scale } => (
                file_name(file),
                std::fs::read(file)
                    .map_err(|e| anyhow::anyhow!("reading {}: {e}", file.display()))
                    .and_then(|bytes| {
                        crate::polar::run::blocks(&bytes)?;
                        Ok(Loaded::Polar { bytes, speed: *speed, scale: *scale })
                    }),
            ),
        };
        let loaded = match loaded {
            Ok(l) => l,
            Err(e) => {
                self.say(&format!("[MSG:{e:#}]"));
                self.error(error::FILE_READ);
                return Ok(());
            }
        };
        self.settle_requests()?;
        eprintln!("motionctl: {name}: the job takes the link");
        let Some(setup) = self.jobs.clone() else { return Ok(()) };
        let mut hook = SenderHook {
            ep: &mut *self.ep,
            rx: &mut self.rx,
            interrupt: self.interrupt.clone(),
            axes: self.spm.len(),
            positions: jobs::milling_mm,
            overrides: self.ovr,
            mask: self.settings.get(settings::STATUS_MASK) as u16,
            inches: self.settings.flag(settings::REPORT_INCHES),
            hold: false,
            abort: false,
        };
        let t = self.s.transport_mut();
        let result = match &loaded {
            Loaded::Mill(job) => {
                let opts = MillingRunOptions {
                    host: setup.host,
                    home: setup.home,
                    progress: true,
                    fault: SimForceFault::None,
                };
                crate::milling::run::run_with(t, job, &opts, &mut hook)
                    .map(|r| Done::Mill(r, job.fnom_n))
            }
            Loaded::Polar { bytes, speed, scale } => {
                hook.positions = jobs::polar_mm;
                let opts = PolarRunOptions {
                    speed: *speed,
                    scale: *scale,
                    host: setup.host,
                    home: setup.home,
                    progress: true,
                };
                crate::polar::run::run_with(t, bytes, &opts, &mut hook).map(Done::Polar)
            }
        };
        let aborted = hook.abort;
        let faults = self.take_link_back(&setup)?;
        match result {
            _ if aborted => {
                self.alarm = Some(alarm::ABORT_CYCLE);
                self.say(&format!("ALARM:{}", alarm::ABORT_CYCLE));
                self.say(&format!("[MSG:{name}: aborted by the sender]"));
                self.soft_reset()?;
            }
            Err(e) => {
                eprintln!("motionctl: {name}: {e:#}");
                if faults != 0 {
                    self.fault_alarm(faults);
                } else {
                    self.alarm = Some(alarm::ABORT_CYCLE);
                    self.say(&format!("ALARM:{}", alarm::ABORT_CYCLE));
                }
                self.say(&format!("[MSG:{name}: {e:#}]"));
                self.error(error::SYSTEM_GC_LOCK);
            }
            Ok(done) => {
                let (lines, job_faults) = match &done {
                    Done::Mill(r, fnom_n) => (jobs::milling_summary(&name, r, *fnom_n), r.faults),
                    Done::Polar(r) => (jobs::polar_summary(&name, r), 0),
                };
                for l in lines {
                    self.say(&format!("[MSG:{l}]"));
                }
                if faults | job_faults != 0 {
                    self.fault_alarm(faults | job_faults);
                    self.error(error::SYSTEM_GC_LOCK);
                } else if self.alarm.is_some() {
                    // The board must be homed again for the bridge's machine.
                    self.say("[MSG:the board has the machine file's config again and must be homed: '$H' to home]");
                    self.ok();
                } else {
                    self.ok();
                }
            }
        }
        Ok(())
    }

    /// Waits (at most [`SETTLE`]) until every request the bridge sent is answered, so none is
    /// left to a job's session.
    fn settle_requests(&mut self) -> Result<()> {
        let start = Instant::now();
        while self.s.host.in_flight() > 0 && start.elapsed() < SETTLE {
            self.s.pump(Duration::from_millis(2)).map_err(link_err)?;
        }
        self.answers();
        self.pending.retain(|_, p| !matches!(p, Pending::Poll | Pending::Ignore));
        Ok(())
    }

    /// After a job: the bridge's own session (Hello), its config and status stream, and a
    /// fault the job left cleared (its bits returned, for the alarm). A board that needs homing
    /// and may not home leaves the bridge in `ALARM:11`, as at start.
    fn take_link_back(&mut self, setup: &JobSetup) -> Result<u32> {
        self.s.connect().map_err(link_err)?;
        self.refresh()?;
        let faults = self.latest.faults;
        if faults != 0 {
            let _ = self.s.request(RequestBody::Abort).map_err(link_err)?;
            let _ = self.s.request(RequestBody::ClearFault).map_err(link_err)?;
        }
        if let Err(e) = self.configure(setup.wire, setup.home, "machine file")? {
            eprintln!("motionctl: {e}; '$H' homes");
            self.alarm = Some(alarm::HOMING_REQUIRED);
        }
        self.rebase();
        Ok(faults)
    }
}
