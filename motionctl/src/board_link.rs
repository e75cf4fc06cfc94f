//! How a subcommand reaches a board: the link flags every board command takes, and streaming a
//! planned job to the board with the host model's check at the end (`motionctl run` and the
//! capabilities' `run` commands).

use crate::convert::Program;
use crate::job::Job;
use crate::noise::Noisy;
use crate::plan;
use crate::qemu::{self, Qemu};
use crate::runner::{self, RunOptions};
use crate::transport::{self, LinkTarget, Transport};
use anyhow::{bail, Result};
use clap::Args;
use motion::capabilities;
use motion::capability::Capability;
use motion::protocol::{HelloInfo, HostConfig};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

#[derive(Args, Debug)]
pub struct LinkArgs {
    /// Serial port of the board.
    #[arg(long, value_name = "PATH", conflicts_with_all = ["qemu", "tcp"])]
    pub port: Option<String>,
    /// Serial speed (8N1).
    #[arg(long, value_name = "N", default_value_t = transport::DEFAULT_BAUD)]
    pub baud: u32,
    /// Start the link firmware in QEMU (netduinoplus2) and talk to it (`run` only; implies
    /// --home: the simulated machine has no switches).
    #[arg(long, conflicts_with = "tcp")]
    pub qemu: bool,
    /// Home the board before the job if it is not homed (`run` only); without it an unhomed
    /// board is an error.
    #[arg(long)]
    pub home: bool,
    /// With --qemu: the firmware ELF [default: target/fw-netduinoplus2-link/firmware, built
    /// with `cargo xtask build --board netduinoplus2 --link` when missing].
    #[arg(long, value_name = "PATH", requires = "qemu")]
    pub firmware: Option<PathBuf>,
    /// A board UART bridged to TCP, e.g. a QEMU started by hand.
    #[arg(long, value_name = "HOST:PORT")]
    pub tcp: Option<String>,
    /// The in-process simulated board (for trying motionctl without hardware).
    #[arg(long, hide = true, conflicts_with_all = ["qemu", "tcp", "port"])]
    pub sim: bool,
    /// Test only: corrupt or drop this fraction of bytes both ways (0..=1).
    #[arg(long, hide = true, value_name = "RATE", value_parser = parse_rate, default_value_t = 0.0)]
    pub noise: f64,
    /// Test only: seed of the --noise generator.
    #[arg(long, hide = true, value_name = "N", default_value_t = 1)]
    pub seed: u64,
    /// Retransmission timeout, ms [default: 100 for serial, 50 otherwise].
    #[arg(long, hide = true, value_name = "MS")]
    pub rto_ms: Option<u64>,
    /// Most unanswered requests.
    #[arg(long, hide = true, value_name = "N", default_value_t = 8)]
    pub window: usize,
    /// Most segments per QueueSegments request (1..=4).
    #[arg(long, hide = true, value_name = "N", default_value_t = 4)]
    pub batch: usize,
}

fn parse_rate(s: &str) -> Result<f64, String> {
    let f: f64 = s.parse().map_err(|_| format!("expected a number, found {s:?}"))?;
    if !(0.0..=1.0).contains(&f) {
        return Err(format!("must be within 0..=1, got {f}"));
    }
    Ok(f)
}

impl LinkArgs {
    pub fn target(&self) -> Result<LinkTarget> {
        if self.qemu {
            return Ok(LinkTarget::Qemu { firmware: self.firmware.clone() });
        }
        if self.sim {
            return Ok(LinkTarget::Sim);
        }
        if let Some(addr) = &self.tcp {
            return Ok(LinkTarget::Tcp { addr: addr.clone() });
        }
        match &self.port {
            Some(port) => Ok(LinkTarget::Serial { port: port.clone(), baud: self.baud }),
            None => bail!("no link given: pass --port PATH, --tcp HOST:PORT or --qemu"),
        }
    }

    pub fn host_config(&self, target: &LinkTarget) -> HostConfig {
        let rto = match target {
            LinkTarget::Serial { .. } => 100,
            _ => 50,
        };
        HostConfig { rto_ms: self.rto_ms.unwrap_or(rto).max(1), window: self.window.clamp(1, 32) }
    }

    /// Opens the link (starting QEMU for --qemu; the guard kills it when dropped), with the
    /// noise proxy in between when asked for.
    pub fn open(&self) -> Result<(Box<dyn Transport>, Option<Qemu>)> {
        let target = self.target()?;
        let (t, guard): (Box<dyn Transport>, Option<Qemu>) = match &target {
            LinkTarget::Qemu { firmware } => {
                let say = |m: &str| eprintln!("motionctl: {m}");
                let elf = qemu::find_firmware(firmware.as_deref(), &say)?;
                let (q, tcp) = Qemu::start(&elf)?;
                eprintln!(
                    "motionctl: QEMU netduinoplus2 running {} (UART on 127.0.0.1:{}, log {})",
                    elf.display(),
                    q.port,
                    q.log.display()
                );
                (Box::new(tcp), Some(q))
            }
            other => (open_transport(other)?, None),
        };
        if self.noise > 0.0 {
            eprintln!(
                "motionctl: noise proxy: {:.2} % of bytes corrupted or dropped, seed {}",
                self.noise * 100.0,
                self.seed
            );
            return Ok((Box::new(Noisy::new(t, self.noise, self.seed)), guard));
        }
        Ok((t, guard))
    }
}

/// How a streamed run reports: the status CSV, whether to wait for the operator at a pause,
/// the status period, the summary as JSON, the run journal.
#[derive(Default)]
pub struct Reporting<'a> {
    pub log_csv: Option<&'a Path>,
    pub yes: bool,
    pub status_ms: u16,
    pub json: bool,
    pub journal: Option<crate::journal::Writer>,
    /// The simulated board's probe surface (`run --sim-probe`).
    pub sim_probe: Option<SimProbeSpec>,
}

/// `run --sim-probe AXIS=MM`: where a simulated board's probe touches, mm from the job's origin
/// on a machine axis: `AXIS=MM` or `AXIS<=MM` at or below it (a surface under the tool),
/// `AXIS>=MM` at or above it.
#[derive(Clone, Debug, PartialEq)]
pub struct SimProbeSpec {
    pub axis: String,
    pub at_mm: f64,
    pub below: bool,
}

impl std::str::FromStr for SimProbeSpec {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("expected AXIS=MM, AXIS<=MM or AXIS>=MM (e.g. z=-3.2), found {s:?}");
        let (axis, below, value) = if let Some((a, v)) = s.split_once(">=") {
            (a, false, v)
        } else if let Some((a, v)) = s.split_once("<=") {
            (a, true, v)
        } else if let Some((a, v)) = s.split_once('=') {
            (a, true, v)
        } else {
            return Err(bad());
        };
        let axis = axis.trim();
        let at_mm: f64 = value.trim().parse().map_err(|_| bad())?;
        if axis.is_empty() || !at_mm.is_finite() {
            return Err(bad());
        }
        Ok(SimProbeSpec { axis: axis.to_string(), at_mm, below })
    }
}

impl SimProbeSpec {
    /// On `machine`: its axis by name.
    pub fn resolve(&self, machine: &crate::job::Machine) -> Result<runner::SimProbe> {
        let Some(axis) = machine.axis_index(&self.axis) else {
            bail!(
                "--sim-probe: the machine has no axis {} (it has {})",
                self.axis,
                machine.axis_names()
            );
        };
        Ok(runner::SimProbe { axis, at_mm: self.at_mm, below: self.below })
    }
}

/// Streams planned `outputs` to the board and checks the result against `expected` (the host
/// model's final positions): the end of `motionctl run` and of the capability `run` commands.
pub fn stream(
    label: &str,
    parsed: &Job,
    program: &Program,
    outputs: &[plan::Output],
    expected: &[i64; motion::MAX_AXES],
    link: &LinkArgs,
    how: Reporting<'_>,
) -> Result<()> {
    let outputs = runner::Outputs::planned(outputs);
    stream_outputs(label, parsed, program, outputs, expected, link, how)
}

/// [`stream`] with the outputs pulled as the board takes them (a job planned while it runs).
pub fn stream_outputs(
    label: &str,
    parsed: &Job,
    program: &Program,
    outputs: runner::Outputs<'_>,
    expected: &[i64; motion::MAX_AXES],
    link: &LinkArgs,
    how: Reporting<'_>,
) -> Result<()> {
    let Reporting { log_csv, yes, status_ms, json, journal, sim_probe } = how;
    if status_ms != 0 && status_ms < motion::protocol::MIN_STATUS_PERIOD_MS {
        bail!("--status-ms must be 0 or at least {}", motion::protocol::MIN_STATUS_PERIOD_MS);
    }
    let target = link.target()?;
    let host = link.host_config(&target);
    let axes = runner::axes_of(parsed);
    let sim_probe = sim_probe.map(|p| p.resolve(&parsed.machine)).transpose()?;
    let csv = match log_csv {
        Some(p) => Some(crate::csv_log::CsvLog::create(p, axes.clone())?),
        None => None,
    };
    let interactive = !yes && std::io::stdin().is_terminal();
    let interrupt = Arc::new(AtomicBool::new(false));
    {
        let flag = interrupt.clone();
        // Fails only if a handler is already set (tests calling this twice): keep the first.
        let _ = ctrlc::set_handler(move || flag.store(true, std::sync::atomic::Ordering::SeqCst));
    }
    let (mut t, qemu_guard) = link.open()?;
    let opts = RunOptions {
        interactive,
        status_period_ms: status_ms,
        host,
        max_batch: link.batch,
        csv,
        progress: true,
        interrupt: Some(interrupt),
        home: link.home || link.qemu || link.sim,
        zero_here: runner::ZeroHere::for_run(
            link.qemu || link.sim,
            yes,
            std::io::stdin().is_terminal(),
        ),
        journal,
        sim_probe,
    };
    let journal_path = opts.journal.as_ref().map(|j| j.path().to_path_buf());
    let segments = outputs.segments();
    let intro = format!("job        {label} ({segments} segments) on {target}");
    if json {
        eprintln!("motionctl: {}", intro.split_whitespace().collect::<Vec<_>>().join(" "));
    } else {
        crate::outln!("{intro}");
    }
    let result = runner::run_outputs(&mut t, parsed, program, outputs, expected, opts);
    let report = crate::qemu::finish(qemu_guard, result).map_err(|e| {
        // A journal left behind: the job can go on from where it stopped.
        let line = journal_path
            .filter(|p| p.exists())
            .and_then(|_| crate::journal::read(Path::new(label)).ok().map(|j| j.line));
        match line {
            Some(line) => anyhow::anyhow!(
                "{e:#}; the job can go on from line {line}, where it stopped: home the board, \
                 then `motionctl run {label} --resume`"
            ),
            None => e,
        }
    })?;
    if json {
        crate::outln!("{}", report.json(&axes));
    } else {
        crate::out!("{}", report.text(&axes));
        crate::outln!("{}", report.machine_line());
    }
    if !report.ok() {
        bail!("verification failed: {}", report.problems.join("; "));
    }
    if !json {
        crate::outln!(
            "result     OK: every segment executed once, in order; positions match the host model"
        );
    }
    Ok(())
}

/// Refuses a board that runs none of `cap`'s jobs (its Hello sets none of the capability's
/// registry bits), saying which capabilities it does run.
pub fn require_capability(info: &HelloInfo, cap: &Capability) -> Result<()> {
    if cap.on_board(info.capabilities) {
        return Ok(());
    }
    let runs: Vec<&str> = capabilities::on_board(info.capabilities).map(|c| c.name).collect();
    let runs = if runs.is_empty() { "none".to_string() } else { runs.join(", ") };
    bail!(
        "the board ({:?}) runs no {} jobs (its capabilities: {runs})",
        info.firmware.as_str(),
        cap.name
    )
}

/// Opens the link to a serial, TCP or simulated target. QEMU goes through
/// [`crate::qemu::Qemu::start`], which owns the emulator process.
fn open_transport(target: &LinkTarget) -> std::io::Result<Box<dyn Transport>> {
    match target {
        LinkTarget::Serial { port, baud } => Ok(Box::new(transport::Serial::open(port, *baud)?)),
        LinkTarget::Tcp { addr } => Ok(Box::new(transport::Tcp::connect(addr)?)),
        LinkTarget::Sim => Ok(Box::new(crate::sim_board::SimBoard::bench_machine())),
        LinkTarget::Qemu { .. } => Err(std::io::Error::new(
            std::io::ErrorKind::Unsupported,
            "QEMU is started by motionctl run --qemu (use --tcp HOST:PORT for a running QEMU)",
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::SimProbeSpec;

    #[test]
    fn sim_probe_specs_read_an_axis_a_side_and_millimetres() {
        let spec = |axis: &str, at_mm, below| SimProbeSpec { axis: axis.into(), at_mm, below };
        assert_eq!("z=-3.2".parse(), Ok(spec("z", -3.2, true)));
        assert_eq!(" Z <= -3.2 ".parse(), Ok(spec("Z", -3.2, true)));
        assert_eq!("x>=40".parse(), Ok(spec("x", 40.0, false)));
        for bad in ["z", "=1", "z=", "z=abc", "z=inf", "z>1"] {
            let e = bad.parse::<SimProbeSpec>().unwrap_err();
            assert!(e.contains("expected AXIS=MM"), "{bad}: {e}");
        }
    }

    #[test]
    fn a_board_without_a_capability_is_refused_with_what_it_runs() {
        use motion::protocol::{FixedStr, HelloInfo, CAP_DDA, CAP_EVENTS, CAP_WIRE_JOB};
        let hello = |capabilities| HelloInfo {
            version: 1,
            firmware: FixedStr::truncated("test-board"),
            capabilities,
            axes: 4,
            queue_capacity: 64,
            tick_hz: 100_000,
            max_window: 8,
            max_segments_per_frame: 8,
            last_panic: None,
        };
        let info = hello(CAP_DDA | CAP_EVENTS | CAP_WIRE_JOB);
        assert!(super::require_capability(&info, &motion::wire::CAPABILITY).is_ok());
        let e = super::require_capability(&info, &motion::turning::CAPABILITY).unwrap_err();
        assert_eq!(
            e.to_string(),
            "the board (\"test-board\") runs no turning jobs (its capabilities: polar, wire)"
        );
        let e = super::require_capability(&hello(CAP_DDA), &motion::milling::CAPABILITY);
        assert!(e.unwrap_err().to_string().ends_with("(its capabilities: none)"));
    }
}
