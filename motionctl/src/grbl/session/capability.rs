//! The capability commands (`$MILL=`, `$POLAR=`, `$TURN=`, `$WIRE=`; see [`crate::grbl::jobs`]):
//! the job's runner
//! on the bridge's link, the sender answered meanwhile, then the bridge's own session, config
//! and status stream back, and the result said as `[MSG:]` lines and `ok`, or as an alarm.

use super::{link_err, Bridge, Pending};
use crate::grbl::job_summary as summary;
use crate::grbl::jobs::{self, JobCmd, SenderHook};
use crate::grbl::protocol::{alarm, error};
use crate::grbl::settings;
use crate::milling::run::MillingRunOptions;
use crate::polar::run::PolarRunOptions;
use crate::turning::run::{LinkTableBytes, ZRunOptions};
use crate::wire::cli::WireBoardJob;
use anyhow::Result;
use motion::protocol::{
    HostConfig, LinkConfig, RequestBody, SimForceFault, CAP_EVENTS, CAP_MILLING_JOB,
    CAP_TURNING_JOB, CAP_WIRE_JOB,
};
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
    pub link_cfg: LinkConfig,
    /// The board's capabilities (its Hello): a job it cannot run is refused before it starts.
    pub caps: u32,
}

/// Longest wait for the bridge's requests in flight before a job takes the link.
const SETTLE: Duration = Duration::from_secs(5);

/// A job file read and checked, before the link is touched.
enum Loaded {
    Mill(Box<crate::milling::job::MillingJob>),
    Polar { bytes: Vec<u8>, speed: f64, scale: motion::polar::playback::SizeScale },
    Turn(LinkTableBytes, ZRunOptions),
    Wire(Box<WireBoardJob>),
}

/// What a job gave back.
enum Done {
    /// The report, and the job's nominal force, N.
    Mill(crate::milling::run::MillingRunReport, f64),
    Polar(crate::polar::run::PolarReport),
    /// The report, and the options it ran with.
    Turn(crate::turning::run::ZRunReport, ZRunOptions),
    /// The report, and the job it ran.
    Wire(crate::wire::run::WireRunReport, Box<WireBoardJob>),
}

/// The capability a command's job needs on the board, and what it is called.
fn needs(cmd: &JobCmd) -> (u32, &'static str) {
    match cmd {
        JobCmd::Mill(_) => (CAP_MILLING_JOB, "milling jobs (CAP_MILLING_JOB)"),
        JobCmd::Polar { .. } => (CAP_EVENTS, "event jobs (CAP_EVENTS)"),
        JobCmd::Turn { .. } => (CAP_TURNING_JOB, "turning jobs (CAP_TURNING_JOB)"),
        JobCmd::Wire { .. } => (CAP_WIRE_JOB, "wire jobs (CAP_WIRE_JOB)"),
    }
}

fn file_name(p: &std::path::Path) -> String {
    p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
}

impl Bridge<'_> {
    /// A `$` line that names a capability: `false` when it does not.
    pub(super) fn capability_line(&mut self, raw: &str) -> Result<bool> {
        let Some((dir, caps)) = self.jobs.as_ref().map(|j| (j.dir.clone(), j.caps)) else {
            return Ok(false);
        };
        let Some(parsed) = jobs::parse(raw, &dir) else { return Ok(false) };
        match parsed {
            Err(why) => {
                self.say(&format!("[MSG:{why}]"));
                self.error(error::INVALID_STATEMENT);
            }
            Ok(_) if self.alarm.is_some() => self.error(error::SYSTEM_GC_LOCK),
            Ok(_) if self.check || self.moving() => self.error(error::IDLE_ERROR),
            Ok(cmd) if caps & needs(&cmd).0 == 0 => {
                self.say(&format!("[MSG:the board runs no {}]", needs(&cmd).1));
                self.error(error::UNSUPPORTED_COMMAND);
            }
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
            JobCmd::Turn { name, flags } => (
                name.clone(),
                crate::turning::cli::turn_job(flags).map(|(t, o)| Loaded::Turn(t, o)),
            ),
            JobCmd::Wire { file, segments } => (
                file_name(file),
                crate::wire::cli::wire_board_job(file, segments.clone())
                    .map(|j| Loaded::Wire(Box::new(j))),
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
            positions: Box::new(jobs::milling_mm),
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
                hook.positions = Box::new(jobs::polar_mm);
                let opts = PolarRunOptions {
                    speed: *speed,
                    scale: *scale,
                    host: setup.host,
                    home: setup.home,
                    progress: true,
                };
                crate::polar::run::run_with(t, bytes, &opts, &mut hook).map(Done::Polar)
            }
            Loaded::Turn(table, o) => {
                hook.positions = Box::new(jobs::turning_mm);
                let o = ZRunOptions { host: setup.host, home: setup.home, ..o.clone() };
                let say = |m: &str| eprintln!("motionctl: {m}");
                crate::turning::run::run_with(t, table, &o, &say, &mut hook)
                    .map(|r| Done::Turn(r, o))
            }
            Loaded::Wire(job) => {
                let spu = job.steps_per_unit;
                hook.positions = Box::new(move |st| jobs::wire_mm(st, spu));
                let opts = crate::wire::run::WireRunOptions {
                    params: job.params,
                    host: setup.host,
                    home: setup.home,
                    progress: true,
                    stall: None,
                    slack: crate::wire::run::SLACK,
                };
                let (cfg, segs) = (job.cfg, &job.segments);
                crate::wire::run::run_with(
                    t,
                    cfg,
                    segs,
                    job.expected,
                    job.model_ticks,
                    &opts,
                    &mut hook,
                )
                .map(|r| Done::Wire(r, job.clone()))
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
                    Done::Mill(r, fnom_n) => {
                        (summary::milling_summary(&name, r, *fnom_n), r.faults)
                    }
                    Done::Polar(r) => (summary::polar_summary(&name, r), 0),
                    Done::Turn(r, o) => (summary::turning_summary(&name, o, r), r.faults),
                    Done::Wire(r, job) => (summary::wire_summary(&name, job, r), 0),
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
        if let Err(e) = self.configure(setup.link_cfg, setup.home, "machine file")? {
            eprintln!("motionctl: {e}; '$H' homes");
            self.alarm = Some(alarm::HOMING_REQUIRED);
        }
        self.rebase();
        Ok(faults)
    }
}
