//! The `polar` subcommands that drive a board over a link: `run` plays a stream, `copy` copies
//! a template (and records what it taught).

use anyhow::{bail, Context};
use motion::polar::playback::SizeScale;

/// `polar run`: opens the link (QEMU, serial, TCP or the simulated board), plays the stream.
/// Theta steps from home in degrees, r steps in inches (the polar machine's scales).
fn deg(theta_steps: i64) -> f64 {
    theta_steps as f64 * 360.0 / motion::polar::job::THETA_STEPS_PER_REV as f64
}
fn inches(r_steps: i64) -> f64 {
    r_steps as f64 / motion::polar::job::R_STEPS_PER_IN as f64
}

pub(super) fn run_stream(
    file: &std::path::Path,
    link: &crate::board_link::LinkArgs,
    speed: f64,
    size: SizeScale,
    json: bool,
) -> anyhow::Result<()> {
    use crate::transport::Transport;
    let bytes = std::fs::read(file).with_context(|| format!("reading {}", file.display()))?;
    // The whole file checked before a board is touched: a cut, corrupt or v1 file names itself.
    motion::polar::stream::decode_all(&bytes, |_| {})
        .map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;
    let target = link.target()?;
    let host = link.host_config(&target);
    let (mut t, qemu_guard): (Box<dyn Transport>, _) = if link.sim {
        let sim = crate::polar::sim::EventSim::new(crate::polar::sim::SIM_SPEED);
        if link.noise > 0.0 {
            eprintln!(
                "motionctl: noise proxy: {:.2} % of bytes corrupted or dropped, seed {}",
                link.noise * 100.0,
                link.seed
            );
            (Box::new(crate::noise::Noisy::new(sim, link.noise, link.seed)), None)
        } else {
            (Box::new(sim), None)
        }
    } else {
        link.open()?
    };
    let opts = crate::polar::run::PolarRunOptions {
        speed,
        scale: size,
        host,
        home: link.home || link.qemu || link.sim,
        progress: true,
    };
    let result = crate::polar::run::run(&mut t, &bytes, &opts);
    let r = crate::qemu::finish(qemu_guard, result)?;
    if json {
        let v = serde_json::json!({
            "file": file.display().to_string(),
            "events": r.events,
            "events_fired": r.events_fired,
            "blocks": r.blocks,
            "theta_deg": deg(r.positions[0]),
            "r_in": inches(r.positions[1]),
            "theta_steps": r.positions[0],
            "r_steps": r.positions[1],
            "model_theta_steps": r.expected_positions[0],
            "model_r_steps": r.expected_positions[1],
            "board_s": r.board_ticks as f64 / motion::polar::scenario::TICK_HZ as f64,
            "wall_s": r.seconds,
            "retransmissions": r.retransmissions,
            "ok": r.ok(),
            "problems": r.problems,
        });
        crate::outln!("{v}");
        if !r.ok() {
            bail!("verification failed: {}", r.problems.join("; "));
        }
        return Ok(());
    }
    crate::outln!(
        "events     {} fired, {} in {} ({} blocks)",
        r.events_fired,
        r.events,
        file.display(),
        r.blocks
    );
    crate::outln!(
        "positions  theta {:.3} deg, r {:.4} in ({} and {} steps); host model {} and {} steps",
        deg(r.positions[0]),
        inches(r.positions[1]),
        r.positions[0],
        r.positions[1],
        r.expected_positions[0],
        r.expected_positions[1]
    );
    crate::outln!(
        "time       {:.2} s wall; model {} ticks, board ~{} ticks (status-resolution)",
        r.seconds,
        r.model_ticks,
        r.board_ticks
    );
    crate::outln!(
        "link       {} frames out, {} retransmitted, {} link NAKs, {} garbled frames in",
        r.frames_out,
        r.retransmissions,
        r.link_naks,
        r.bad_frames_in
    );
    crate::outln!("{}", r.machine_line());
    if !r.ok() {
        bail!("verification failed: {}", r.problems.join("; "));
    }
    crate::outln!("result     OK: every event fired once; positions match the host model");
    Ok(())
}

/// `--template`: the built-in limacon piece or a waypoint file.
fn template(spec: &str) -> anyhow::Result<crate::polar::copy::Trace> {
    if let Some(rest) = spec.strip_prefix("limacon") {
        let end = match rest.strip_prefix(':') {
            Some(t) => {
                t.parse::<f64>().map_err(|_| anyhow::anyhow!("bad THETA_END in {spec:?}"))?
            }
            None if rest.is_empty() => 0.5,
            None => bail!("expected limacon[:THETA_END_RAD], found {spec:?}"),
        };
        if !(0.0..=crate::polar::THETA_MAX_RAD).contains(&end) {
            bail!("THETA_END must be within 0..={} rad", crate::polar::THETA_MAX_RAD);
        }
        return Ok(crate::polar::copy::limacon_trace(end, 40));
    }
    let text = std::fs::read_to_string(spec).with_context(|| format!("reading {spec}"))?;
    crate::polar::copy::parse_trace(&text)
}

/// `polar copy`: opens the link, copies, saves the taught stream, prints the summary.
pub(super) fn run_copy(
    link: &crate::board_link::LinkArgs,
    size: SizeScale,
    teach: Option<&std::path::Path>,
    template_spec: Option<&str>,
    seconds: f64,
    json: bool,
) -> anyhow::Result<()> {
    use crate::transport::Transport;
    let target = link.target()?;
    let host = link.host_config(&target);
    let simulated = link.sim || link.qemu;
    let trace = match (template_spec, simulated) {
        (Some(t), _) => Some(template(t)?),
        (None, true) => Some(template("limacon")?),
        (None, false) => None,
    };
    let (mut t, qemu_guard): (Box<dyn Transport>, _) = if link.sim {
        (Box::new(crate::polar::copy_sim::CopySimBoard::new(crate::polar::sim::SIM_SPEED)), None)
    } else {
        link.open()?
    };
    let opts = crate::polar::copy::CopyOptions {
        scale: size,
        teach: teach.is_some(),
        host,
        home: link.home || simulated,
        progress: true,
        trace,
        seconds,
    };
    let result = crate::polar::copy::copy(&mut t, &opts);
    let r = crate::qemu::finish(qemu_guard, result)?;
    if let Some(path) = teach {
        std::fs::write(path, &r.stream).with_context(|| format!("writing {}", path.display()))?;
    }
    if json {
        let v = serde_json::json!({
            "ok": r.ok(),
            "waypoints": r.waypoints,
            "encoder_moves": r.encoder_moves,
            "theta_deg": deg(r.positions[0]),
            "r_in": inches(r.positions[1]),
            "theta_steps": r.positions[0],
            "r_steps": r.positions[1],
            "model_theta_steps": r.model.positions[0],
            "model_r_steps": r.model.positions[1],
            "size": format!("{}:{}", size.m, size.k),
            "taught_events": teach.map(|_| r.stream_events),
            "taught_blocks": teach.map(|_| r.blocks),
            "lost_events": r.lost_events,
            "problems": r.problems,
        });
        crate::outln!("{v}");
        if !r.ok() {
            bail!("verification failed: {}", r.problems.join("; "));
        }
        return Ok(());
    }
    crate::outln!(
        "copy       {} waypoints; encoders moved arm {} carriage {} counts",
        r.waypoints,
        r.encoder_moves[0],
        r.encoder_moves[1]
    );
    crate::outln!(
        "positions  theta {:.3} deg, r {:.4} in ({} and {} steps, size {}:{}); host model {} and {} \
         steps",
        deg(r.positions[0]),
        inches(r.positions[1]),
        r.positions[0],
        r.positions[1],
        size.m,
        size.k,
        r.model.positions[0],
        r.model.positions[1]
    );
    if let Some(path) = teach {
        crate::outln!(
            "teach      {} events in {} blocks -> {} ({} lost)",
            r.stream_events,
            r.blocks,
            path.display(),
            r.lost_events
        );
    }
    crate::outln!("{}", r.machine_line());
    if !r.ok() {
        bail!("verification failed: {}", r.problems.join("; "));
    }
    crate::outln!("result     OK");
    Ok(())
}
