//! `motionctl grbl`: the board behind grbl 1.1's serial protocol, for the G-code senders people
//! already use (Universal Gcode Sender, cncjs, bCNC, Candle, scripts), on a pseudo-terminal or
//! a TCP socket.
//!
//! - [`protocol`]: real-time bytes, the 128-byte receive buffer, error and alarm numbers;
//! - [`report`]: `?` status reports;
//! - [`settings`]: `$$` from the machine file, `$N=V` onto the board and into the overlay file;
//! - [`program`]: program lines one block at a time through `motion-gcode`;
//! - [`pipeline`]: the moves into an incremental planner, segments and events out;
//! - [`session`]: the loop between the sender and the board's link;
//! - [`endpoint`]: the pseudo-terminal and the TCP socket;
//! - [`jobs`]: the thesis capabilities as `$` commands (`$MILL=`, `$POLAR=`, `$TURN=`,
//!   `$WIRE=`); [`job_summary`]: the `[MSG:]` lines that sum up their jobs.

pub mod endpoint;
pub mod job_summary;
pub mod jobs;
pub mod pipeline;
pub mod program;
pub mod protocol;
pub mod report;
pub mod session;
pub mod settings;

use crate::board_link::LinkArgs;
use crate::convert::{self, Program};
use crate::job::{self, Job};
use crate::link::Session;
use crate::polar::sim::EventSim;
use crate::runner;
use crate::sim_board::SIM_CAPACITY;
use crate::transport::Transport;
use anyhow::{bail, Context, Result};
use clap::Args;
use endpoint::Endpoint;
use motion::machine::MachineState;
use motion::protocol::RequestBody;
use std::path::PathBuf;
use std::sync::atomic::Ordering;

/// Status period asked of the board, ms.
pub(crate) const STATUS_MS: u16 = 40;

#[derive(Args, Debug)]
pub struct GrblArgs {
    /// The machine: a job TOML whose `[machine]` is used (`$$` reports it); settings a sender
    /// changes (`$N=V`) and its startup lines are kept in NAME.grbl.toml beside it.
    pub machine: PathBuf,
    #[command(flatten)]
    pub link: LinkArgs,
    /// Create a pseudo-terminal and a symlink to it at PATH; a sender opens PATH as a serial
    /// port.
    #[arg(
        long,
        value_name = "PATH",
        conflicts_with = "listen",
        required_unless_present = "listen"
    )]
    pub pty: Option<PathBuf>,
    /// Serve raw TCP (grblHAL's socket stream) on HOST:PORT, one sender at a time.
    #[arg(long, value_name = "HOST:PORT")]
    pub listen: Option<String>,
    /// Directory the capability commands' job files (`$MILL=FILE`, `$POLAR=FILE`,
    /// `$TURN=TABLE`, `$WIRE=FILE`) are read from when relative [default: the working
    /// directory].
    #[arg(long, value_name = "DIR", default_value = ".")]
    pub jobs: PathBuf,
    /// With --sim: machine time per wall time of the simulated board.
    #[arg(long, hide = true, value_name = "X", default_value_t = 1.0)]
    pub sim_speed: f64,
    /// A simulated board's probe surface for G38.x probe moves (--sim, --qemu), as `run
    /// --sim-probe` takes it: the probe touches while a machine axis is at or below (`z=-3.2`
    /// or `z<=-3.2`) or at or above (`x>=40`) that many mm, machine coordinates.
    #[arg(long, value_name = "AXIS=MM")]
    pub sim_probe: Option<crate::board_link::SimProbeSpec>,
}

/// The machine as the board's config: steps-space config and the link config with the axes'
/// scale, soft limits and input filter (as every job runner sends it).
pub fn board_config(
    machine: &job::Machine,
) -> Result<(motion::MachineConfig, motion::protocol::LinkConfig)> {
    let cfg = convert::machine_config(machine)?;
    let program = Program {
        config: cfg,
        steps_per_mm: machine.axes.iter().map(|a| a.steps_per_mm).collect(),
        items: Vec::new(),
        commands: Vec::new(),
        final_steps: [0; motion::MAX_AXES],
        skipped_moves: 0,
    };
    let job = Job { machine: machine.clone(), items: Vec::new(), feed_commands: Vec::new() };
    Ok((cfg, runner::link_config(&job, &program)))
}

/// `motionctl grbl`.
pub fn run(args: GrblArgs) -> Result<()> {
    let text = std::fs::read_to_string(&args.machine)
        .with_context(|| format!("reading {}", args.machine.display()))?;
    let file_machine =
        job::parse_machine_toml(&text).with_context(|| args.machine.display().to_string())?;
    convert::machine_config(&file_machine).with_context(|| args.machine.display().to_string())?;
    // The settings a sender changed before, over the machine file's.
    let overlay_path = settings::overlay_path(&args.machine);
    let overlay = settings::Overlay::read(&overlay_path)?;
    let mut values = settings::Settings::from_machine(&file_machine);
    for (n, v) in &overlay.settings {
        values
            .set(&n.to_string(), &v.to_string())
            .map_err(|e| anyhow::anyhow!("{}: settings.{n} = {v}: {e}", overlay_path.display()))?;
    }
    let machine = settings::machine_with(&text, &values).map_err(|e| {
        anyhow::anyhow!("{} over {}: {e}", overlay_path.display(), args.machine.display())
    })?;
    if !overlay.settings.is_empty() {
        eprintln!(
            "motionctl: {} settings from {} over {}",
            overlay.settings.len(),
            overlay_path.display(),
            args.machine.display()
        );
    }
    let (cfg, link_cfg) = board_config(&machine)?;
    // A bad --sim-probe is said before any link is opened (serve sets it once connected).
    if let Some(p) = &args.sim_probe {
        p.resolve(&machine)?;
    }
    let machine: &'static job::Machine = Box::leak(Box::new(machine));
    let persist = session::Persist {
        machine_path: args.machine.clone(),
        machine_src: text,
        overlay: overlay_path,
        settings: values,
        startup: overlay.startup,
    };

    let target = args.link.target()?;
    let speed = args.sim_speed;
    if !(speed.is_finite() && speed > 0.0 && speed <= 1000.0) {
        bail!("--sim-speed must be within (0, 1000]");
    }
    let (mut t, guard): (Box<dyn Transport>, _) = if args.link.sim {
        // A simulated board that also plays event jobs (`$POLAR=`).
        let sim = EventSim::scaled(SIM_CAPACITY, speed);
        if args.link.noise > 0.0 {
            (Box::new(crate::noise::Noisy::new(sim, args.link.noise, args.link.seed)), None)
        } else {
            (Box::new(sim), None)
        }
    } else {
        args.link.open()?
    };
    let result = serve(&args, &mut t, &target, machine, cfg, link_cfg, persist);
    crate::qemu::finish(guard, result)
}

fn serve(
    args: &GrblArgs,
    t: &mut Box<dyn Transport>,
    target: &crate::transport::LinkTarget,
    machine: &'static job::Machine,
    cfg: motion::MachineConfig,
    link_cfg: motion::protocol::LinkConfig,
    persist: session::Persist,
) -> Result<()> {
    let mut s = Session::new(t, args.link.host_config(target));
    let info = s.connect().map_err(|e| anyhow::anyhow!("{e}"))?;
    eprintln!(
        "motionctl: connected to {}: firmware {:?}, protocol v{}",
        s.describe(),
        info.firmware.as_str(),
        info.version
    );
    let say = |m: &str| eprintln!("motionctl: {m}");
    let home_ok = args.link.home || args.link.qemu || args.link.sim;
    // The machine file's switches, for `$H` too; on a machine without any, `--home` (or a
    // simulated board) is the operator's word that the axes stand at machine zero, as `$H` is.
    let home = runner::Home::Switches {
        homing: &machine.homing(),
        allowed: home_ok,
        zero_here: &|_: &str| true,
    };
    let alarm = match runner::ready_board(&mut s, link_cfg, home, "machine file", &say) {
        Ok(_) => None,
        Err(e) => {
            let st = runner::ask_status(&mut s)?;
            if st.faults == 0 && st.machine == MachineState::Idle {
                say(&format!("{e}; a sender starts in Alarm ('$H' homes)"));
                Some(protocol::alarm::HOMING_REQUIRED)
            } else {
                bail!(e);
            }
        }
    };
    if let Some(sim) = args.sim_probe.as_ref().map(|p| p.resolve(machine)).transpose()? {
        // Machine coordinates: the surface stays where it is whatever the bridge started at.
        let spm: Vec<f64> = machine.axes.iter().map(|a| a.steps_per_mm).collect();
        runner::set_sim_probe(&mut s, sim, &[0; motion::MAX_AXES], &spm)
            .map_err(anyhow::Error::msg)?;
    }
    runner::ask(&mut s, RequestBody::SetStatusPeriod { ms: STATUS_MS }, "SetStatusPeriod")?;
    s.streaming = true;
    let latest = runner::ask_status(&mut s)?;

    let mut ep: Box<dyn Endpoint> = match (&args.pty, &args.listen) {
        (Some(path), _) => {
            let p = endpoint::Pty::open(path)?;
            eprintln!(
                "motionctl: grbl 1.1 on {} -> {} (open it as a serial port)",
                path.display(),
                p.slave_name().display()
            );
            Box::new(p)
        }
        (None, Some(addr)) => {
            let l = endpoint::Tcp::listen(addr)?;
            eprintln!("motionctl: grbl 1.1 on TCP {} (one sender at a time)", l.local_addr());
            Box::new(l)
        }
        (None, None) => bail!("pass --pty PATH or --listen HOST:PORT"),
    };
    let jobs = session::JobSetup {
        dir: args.jobs.clone(),
        host: args.link.host_config(target),
        home: home_ok,
        link_cfg,
        caps: info.capabilities,
    };
    let mut bridge =
        session::Bridge::new(s, &mut *ep, machine, cfg, latest, alarm, persist).with_jobs(jobs);
    let flag = bridge.interrupt.clone();
    // Fails only if a handler is already set: keep that one.
    let _ = ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst));
    bridge.run()
}

/// The corpus machine file, which the bridge's unit tests read settings and jogs against.
#[cfg(test)]
fn test_machine() -> crate::job::Machine {
    let src = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/corpus-machine.toml"
    ))
    .unwrap();
    crate::job::parse_machine_toml(&src).unwrap()
}
