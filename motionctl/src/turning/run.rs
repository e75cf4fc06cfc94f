//! `motionctl turning run`: a Z-slide job on a board with `CAP_TURNING_JOB`, checked
//! against the host model.
//!
//! Hello -> the board ready (`runner::ready_board`: config, ConfigMissing cleared, homing) ->
//! `Sim(Spindle)` at the job's speed (QEMU only: the real spindle must already turn) -> the table
//! uploaded (`ZTableBegin`, `ZTableChunk`s, `ZTableEnd` with its CRC-32) -> wait until the board
//! senses the speed -> `StartZ` -> watch the status stream (board time, `runner::JobWatch`),
//! with an optional spindle speed step (`Sim(Spindle)` at `speed_step_at` seconds of board time
//! after the start) -> the final status against the host model: the same `ZJob` run on the host
//! with the same table, spec, config and spindle speeds (the step at the board tick it was sent
//! at). Checks: X and Z steps at the end equal the model's, no fault, the job finished, and the
//! largest following error near the model's (the spindle's angle at the start is the board's:
//! it differs from the model's, so that figure is compared with a tolerance).

use crate::link::{describe_rejection, LinkFailure, Session};
use crate::runner;
use crate::runner::{fault_names, seq_at_or_after};
use crate::transport::Transport;
use crate::turning::table_file::{Form, ZTable};
use anyhow::{anyhow, bail, Context};
use motion::config::{AxisLimits, MachineConfig, StepTiming, MAX_AXES};
use motion::dda::{Dda, Preparer};
use motion::machine::{BoardConfig, Inputs, Machine, MachineCommand, MachineState};
use motion::protocol::{
    AxisScale, BlockBytes, HomingConfig, HostConfig, HostEvent, LinkConfig, Reply, RequestBody,
    SimRequest, CAP_SIM_INPUTS, CRC32, MAX_Z_CHUNK,
};
use motion::spindle::{QuadratureEncoder, SimSpindle};
use motion::turning::link_job::{
    table_link_bytes, ZJob, ZJobSpec, ZOutputSpec, ZTableHeader, ZTableUpload, MAX_TABLE_BYTES,
};
use motion::turning::link_messages::TurningRequest;
use motion::turning::scenario as sc;
use motion::turning::TURNING_JOB;
use std::time::{Duration, Instant};

/// Machine axes of a Z job: Z (the slide) on axis 0, X (radial feed) on axis 1.
pub const Z_AXIS: u8 = 0;
pub const X_AXIS: u8 = 1;
/// Z steps per inch (10 uin steps, the scenario's stepper) and X steps per inch.
pub const Z_STEPS_PER_IN: u32 = 100_000;
pub const X_STEPS_PER_IN: u32 = 1_000;
/// DAC scale: +-0.010 in over the 12 bits (the thesis's gage range), mid-scale at rest.
pub const DAC_CODES_PER_IN: u32 = 204_800;
pub const DAC_MID_CODE: u16 = 2048;
/// Status period during the job, and the poll interval (also the heartbeat).
pub const STATUS_PERIOD_MS: u16 = 20;
pub const POLL_EVERY: Duration = Duration::from_millis(5);
/// Board-time limit: the model's ticks times this plus [`SLACK`].
pub const SLOWDOWN: f64 = 2.0;
pub const SLACK: Duration = Duration::from_secs(10);
pub const NO_PROGRESS: Duration = Duration::from_secs(15);
/// Ticks the spindle turns before the start in the model (the encoder's speed window fills).
pub const SPIN_UP_TICKS: u64 = 2_000;
/// The following-error comparison: within this fraction of the model's, or this many
/// nanoinches, whichever is larger (the spindle phase at the start differs).
pub const FOLLOWING_TOLERANCE: f64 = 0.5;
pub const FOLLOWING_SLACK_NIN: i64 = 3_000;

/// The Z output of a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ZOutput {
    Steps,
    Dac,
}

/// A table ready for the link.
#[derive(Clone, Debug)]
pub struct LinkTableBytes {
    pub header: ZTableHeader,
    pub bytes: Vec<u8>,
}

impl LinkTableBytes {
    /// The checked-in Douglass table (accurate mode, 81 rows, X 0..8 in).
    pub fn douglass() -> anyhow::Result<Self> {
        Self::from_table(&motion::turning::douglass_table::DOUGLASS_POWER)
    }

    pub fn from_table<const R: usize, const W: usize>(
        t: &motion::turning::CoefficientTable<R, W>,
    ) -> anyhow::Result<Self> {
        let mut bytes = vec![0u8; MAX_TABLE_BYTES];
        let (header, n) = table_link_bytes(t, &mut bytes)
            .ok_or_else(|| anyhow!("the table does not fit an upload"))?;
        bytes.truncate(n);
        Ok(LinkTableBytes { header, bytes })
    }

    /// A table file (see [`crate::turning::table_file`]); `name` goes into the errors.
    pub fn parse(name: &str, src: &str) -> anyhow::Result<Self> {
        Self::from_ztable(&ZTable::parse(name, src)?)
    }

    /// A table in the link's fixed point (power form, or harmonic of order 1..=8).
    pub fn from_ztable(t: &ZTable) -> anyhow::Result<Self> {
        use crate::turning::firmware_table::fixed_table;
        const R: usize = motion::turning::link_job::LINK_TABLE_ROWS;
        macro_rules! harmonic {
            ($($k:literal => $w:literal),*) => {
                match t.form {
                    Form::Power => Self::from_table(&fixed_table::<R, 4>(t)?),
                    $(Form::Harmonic($k) => Self::from_table(&fixed_table::<R, $w>(t)?),)*
                    Form::Harmonic(k) => bail!("harmonic order {k} is outside 1..=8"),
                }
            };
        }
        harmonic!(1 => 3, 2 => 5, 3 => 7, 4 => 9, 5 => 11, 6 => 13, 7 => 15, 8 => 17)
    }

    pub fn crc(&self) -> u32 {
        CRC32.checksum(&self.bytes)
    }
}

/// The machine config of a Z job: `tick_hz`, axis 0 = Z, axis 1 = X (a rise every other tick
/// at most: max rate tick_hz / 2), wide soft limits.
pub fn machine_config(tick_hz: u32) -> LinkConfig {
    let axis =
        AxisLimits { max_rate_hz: tick_hz / 2, accel_steps_per_s2: 1_000_000, junction_jerk_hz: 0 };
    let mut axes = [AxisLimits::UNUSED; MAX_AXES];
    axes[0] = axis;
    axes[1] = axis;
    let mut scale = [AxisScale::UNUSED; MAX_AXES];
    // Steps per mm, times 1000.
    scale[0] = AxisScale {
        steps_per_unit_milli: (Z_STEPS_PER_IN as u64 * 1000 * 10 / 254) as u32,
        soft_min: -1_000_000,
        soft_max: 1_000_000,
    };
    scale[1] = AxisScale {
        steps_per_unit_milli: (X_STEPS_PER_IN as u64 * 1000 * 10 / 254) as u32,
        soft_min: -1_000_000,
        soft_max: 1_000_000,
    };
    LinkConfig {
        machine: MachineConfig {
            tick_hz,
            timing: StepTiming { pulse_ns: 2_500, dir_setup_ns: 5_000, dir_hold_ns: 5_000 },
            axis_count: 2,
            axes,
        },
        scale,
        inputs: motion::InputFilterConfig::DEFAULT,
    }
}

/// What a run does: the feed, the output, the spindle.
#[derive(Clone, Debug)]
pub struct ZRunOptions {
    pub tick_hz: u32,
    pub rpm_milli: u32,
    /// X from `x_start_in` to `x_end_in` at `feed_in_per_s`; the disengage blends over the last
    /// `blend_in`.
    pub x_start_in: f64,
    pub x_end_in: f64,
    pub feed_in_per_s: f64,
    pub blend_in: f64,
    pub output: ZOutput,
    /// A spindle speed step: at this many seconds of board time after the start, by this
    /// fraction (0.2 = +20 %). QEMU only (`Sim(Spindle)`).
    pub speed_step: Option<(f64, f64)>,
    pub host: HostConfig,
    pub home: bool,
    pub progress: bool,
}

impl Default for ZRunOptions {
    fn default() -> Self {
        ZRunOptions {
            tick_hz: sc::TICK_HZ,
            rpm_milli: 360_000,
            x_start_in: 0.0,
            x_end_in: 0.5,
            feed_in_per_s: 1.0,
            blend_in: 0.1,
            output: ZOutput::Steps,
            speed_step: None,
            host: HostConfig { rto_ms: 100, window: 8 },
            home: true,
            progress: true,
        }
    }
}

fn q24(x_in: f64) -> i32 {
    (x_in * (1u64 << 24) as f64).round() as i32
}

/// The job's `StartZ` spec (the scenario's command settings, this run's feed and output).
pub fn job_spec(o: &ZRunOptions) -> anyhow::Result<ZJobSpec> {
    if !(o.x_end_in > o.x_start_in && o.feed_in_per_s > 0.0 && o.blend_in >= 0.0) {
        bail!("need x_end > x_start, feed > 0 and blend >= 0");
    }
    let c = sc::command_config();
    let feed = q24(o.feed_in_per_s / o.tick_hz as f64);
    if feed <= 0 {
        bail!("the feed {} in/s is below one Q24 step per tick", o.feed_in_per_s);
    }
    let output = match o.output {
        ZOutput::Steps => ZOutputSpec::Steps { axis: Z_AXIS, steps_per_in: Z_STEPS_PER_IN },
        ZOutput::Dac => ZOutputSpec::Dac { codes_per_in: DAC_CODES_PER_IN, mid_code: DAC_MID_CODE },
    };
    Ok(ZJobSpec {
        output,
        x_axis: X_AXIS,
        x_steps_per_in: X_STEPS_PER_IN,
        x_negative: false,
        x_start_in_q24: q24(o.x_start_in),
        x_end_in_q24: q24(o.x_end_in),
        x_feed_in_q24_per_tick: feed,
        cubic: true,
        advance_ticks_q16: match o.output {
            ZOutput::Steps => sc::STEPPER_LATENCY_TICKS_Q16,
            ZOutput::Dac => sc::VOICE_COIL_LATENCY_TICKS_Q16,
        },
        engage_ticks: o.tick_hz / 20,
        blend_start_x_in_q24: q24(o.x_end_in - o.blend_in),
        blend_end_x_in_q24: q24(o.x_end_in),
        max_velocity_uin_per_s: c.max_velocity_uin_per_s,
        max_accel_uin_per_s2: c.max_accel_uin_per_s2,
        min_speed_turn_q32_per_tick: motion::spindle::speed_turn_q32_per_tick(60_000, o.tick_hz)
            as u32,
    })
}

/// The board's sim-spindle speed for `rpm_milli` (as the link firmware converts it).
pub fn sim_speed(rpm_milli: u32, tick_hz: u32) -> u32 {
    motion::spindle::speed_turn_q32_per_tick(rpm_milli as u64, tick_hz.max(1)) as u32
}

/// The host model's figures.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ZModel {
    pub x_steps: i64,
    pub z_steps: i64,
    pub max_following_nin: i64,
    pub ticks: u64,
    pub faults: u32,
    pub finished: bool,
}

/// Runs the job on the host: the firmware's `Machine`, `ZJob`, sim spindle and encoder logic,
/// tick by tick. `step`: (ticks after the start, rpm) of a speed step.
pub fn model(
    cfg: &LinkConfig,
    table: &LinkTableBytes,
    spec: &ZJobSpec,
    rpm_milli: u32,
    step: Option<(u64, u32)>,
    max_ticks: u64,
) -> anyhow::Result<ZModel> {
    let bcfg = BoardConfig::with_homing(*cfg, &HomingConfig::NONE);
    let mut m = Machine::new();
    m.boot(Ok(bcfg));
    let mut dda = Dda::new(&cfg.machine).map_err(|e| anyhow!("config: {e:?}"))?;
    let mut prep = Preparer::new(&cfg.machine).map_err(|e| anyhow!("config: {e:?}"))?;
    m.command(MachineCommand::Home, &mut dda).map_err(|e| anyhow!("Home: {e:?}"))?;
    for _ in 0..100 {
        m.tick(&mut dda, &Inputs::QUIET);
        if m.wants_background() {
            m.background(&mut dda, &mut prep);
        }
    }
    if m.state() != MachineState::Ready {
        bail!("the model machine did not home");
    }
    let mut up = ZTableUpload::new();
    let link_table = (|| {
        up.begin(table.header)?;
        for (i, c) in table.bytes.chunks(MAX_Z_CHUNK).enumerate() {
            up.chunk(i as u16, c)?;
        }
        up.end(table.crc())
    })()
    .map_err(|e| anyhow!("the table: {e:?}"))?;
    let mut job = ZJob::new();
    job.install(link_table).map_err(|e| anyhow!("{e:?}"))?;
    let tick_hz = cfg.machine.tick_hz;
    let mut sim = SimSpindle::new(0);
    let enc_cfg = sc::encoder_config();
    let mut enc = QuadratureEncoder::new(enc_cfg, sim.encoder(enc_cfg.counts_per_rev).0)
        .map_err(|e| anyhow!("{e:?}"))?;
    let mut speed = sim_speed(rpm_milli, tick_hz);
    let mut tick = |m: &mut Machine, dda: &mut Dda, job: &mut ZJob, speed: u32| {
        sim.advance(speed);
        let (c, i) = sim.encoder(enc_cfg.counts_per_rev);
        enc.update(c, i);
        job.sense_from(&enc);
        let inp = Inputs { sensor_faults: job.take_sensor_faults(), ..Inputs::QUIET };
        if m.runs(TURNING_JOB) {
            m.tick_with(dda, &inp, job);
        } else {
            m.tick(dda, &inp);
        }
    };
    for _ in 0..SPIN_UP_TICKS {
        tick(&mut m, &mut dda, &mut job, speed);
    }
    let base = m.positions();
    job.start(spec, tick_hz).map_err(|e| anyhow!("StartZ refused by the model: {e:?}"))?;
    m.command(MachineCommand::StartSource(TURNING_JOB), &mut dda)
        .map_err(|e| anyhow!("StartZ: {e:?}"))?;
    let mut ticks = 0u64;
    while m.runs(TURNING_JOB) && m.faults().mask() == 0 && ticks < max_ticks {
        if let Some((at, rpm)) = step {
            if ticks == at {
                speed = sim_speed(rpm, tick_hz);
            }
        }
        tick(&mut m, &mut dda, &mut job, speed);
        ticks += 1;
    }
    let p = m.positions();
    Ok(ZModel {
        x_steps: p[X_AXIS as usize] - base[X_AXIS as usize],
        z_steps: p[Z_AXIS as usize] - base[Z_AXIS as usize],
        max_following_nin: job.max_following_nin(),
        ticks,
        faults: m.faults().mask(),
        finished: !m.runs(TURNING_JOB) && m.state() == MachineState::Ready,
    })
}

/// What the run did; `problems` is empty when every check passed.
#[derive(Clone, Debug, Default)]
pub struct ZRunReport {
    pub x_steps: i64,
    pub z_steps: i64,
    pub max_following_nin: i64,
    pub faults: u32,
    pub z_state: u8,
    pub board_ticks: u64,
    pub step_at_tick: Option<u64>,
    pub final_rpm_milli: i64,
    pub model: ZModel,
    pub seconds: f64,
    pub problems: Vec<String>,
}

impl ZRunReport {
    pub fn ok(&self) -> bool {
        self.problems.is_empty()
    }
}

/// Connects, readies the board, uploads `table`, runs the job and checks it; see the module doc.
pub fn run(
    transport: &mut dyn Transport,
    table: &LinkTableBytes,
    o: &ZRunOptions,
    say: &dyn Fn(&str),
) -> anyhow::Result<ZRunReport> {
    run_with(transport, table, o, say, &mut runner::Unattended)
}

/// As [`run`], with `hook` asked every pass of the job's loop once the job started (it may
/// hold the X feed, resume it or abort the job: the grbl bridge's sender does).
pub fn run_with(
    transport: &mut dyn Transport,
    table: &LinkTableBytes,
    o: &ZRunOptions,
    say: &dyn Fn(&str),
    hook: &mut dyn runner::JobHook,
) -> anyhow::Result<ZRunReport> {
    let t0 = Instant::now();
    let cfg = machine_config(o.tick_hz);
    let spec = job_spec(o)?;
    // The model without the step, for the board-time limit.
    let plain = model(&cfg, table, &spec, o.rpm_milli, None, 100 * o.tick_hz as u64)?;
    let mut s = Session::new(transport, o.host);
    let link = |e: LinkFailure| anyhow!("{e}");
    let info = s.connect().map_err(link)?;
    crate::board_link::require_capability(&info, &motion::turning::CAPABILITY)?;
    let sim = info.capabilities & CAP_SIM_INPUTS != 0;
    if o.speed_step.is_some() && !sim {
        bail!("the board ({:?}) has no simulated spindle: no speed step", info.firmware.as_str());
    }
    say(&format!("connected to {}: firmware {:?}", s.describe(), info.firmware.as_str()));
    let (query, status) = (runner::ask, runner::ask_status);
    runner::ready_board(&mut s, cfg, runner::Home::allowed(o.home), "Z-slide machine (Z, X)", say)
        .map_err(|e| anyhow!("{e}"))?;
    if sim {
        query(
            &mut s,
            RequestBody::Sim(SimRequest::Spindle { rpm_milli: o.rpm_milli, index: true }),
            "Sim(Spindle)",
        )?;
    }
    query(&mut s, RequestBody::from(TurningRequest::ZTableBegin(table.header)), "ZTableBegin")?;
    for (i, c) in table.bytes.chunks(MAX_Z_CHUNK).enumerate() {
        let bytes = BlockBytes::from_slice(c).ok_or_else(|| anyhow!("chunk too long"))?;
        query(
            &mut s,
            RequestBody::from(TurningRequest::ZTableChunk { index: i as u16, bytes }),
            "ZTableChunk",
        )?;
    }
    query(&mut s, RequestBody::from(TurningRequest::ZTableEnd { crc: table.crc() }), "ZTableEnd")?;
    say(&format!(
        "table uploaded: {} rows, {} bytes, CRC {:#010x}",
        table.header.rows,
        table.bytes.len(),
        table.crc()
    ));
    // The board senses the speed (the encoder's window fills).
    let spun = Instant::now();
    loop {
        let st = status(&mut s)?;
        if (st.z_spindle_rpm_milli - o.rpm_milli as i64).abs() * 100 <= o.rpm_milli as i64 {
            break;
        }
        if spun.elapsed() > Duration::from_secs(20) {
            bail!(
                "the board senses {} rpm, not {} rpm",
                st.z_spindle_rpm_milli as f64 / 1e3,
                o.rpm_milli as f64 / 1e3
            );
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    query(&mut s, RequestBody::SetStatusPeriod { ms: STATUS_PERIOD_MS }, "SetStatusPeriod")?;
    s.streaming = true;
    let base = status(&mut s)?;
    let start_seq = s.send(RequestBody::from(TurningRequest::StartZ(spec))).map_err(link)?;
    let mut started = false;
    let mut latest = base.clone();
    let mut start_tick: Option<u64> = None;
    let mut step_at: Option<u64> = None;
    let slack_ticks = (SLACK.as_secs_f64() * f64::from(o.tick_hz)) as u64;
    let mut watch = runner::JobWatch::new(plain.ticks, SLOWDOWN, slack_ticks, NO_PROGRESS);
    let mut poll_seq: Option<u32> = None;
    let mut last_poll = Instant::now();
    let mut last_say = Instant::now();
    let mut steer = runner::Steer::default();
    loop {
        s.pump(Duration::from_millis(5)).map_err(link)?;
        for n in s.notices.drain(..) {
            say(&n);
        }
        for (seq, result) in s.take_answers() {
            if seq == start_seq {
                match result {
                    Ok(_) => {
                        started = true;
                        say("StartZ accepted");
                    }
                    Err(r) => bail!("StartZ refused: {}", describe_rejection(&r)),
                }
            } else if Some(seq) == poll_seq {
                poll_seq = None;
                if let Ok(Reply::Status(st)) = result {
                    if seq_at_or_after(st.next_seq, latest.next_seq) {
                        latest = st;
                    }
                }
            } else if let Err(r) = result {
                bail!("request {seq} refused: {}", describe_rejection(&r));
            }
        }
        while let Some(ev) = s.events.pop_front() {
            match ev {
                HostEvent::Status(st) if seq_at_or_after(st.next_seq, latest.next_seq) => {
                    latest = st;
                }
                HostEvent::SessionLost(code) => {
                    bail!("{}: the job cannot resume safely", LinkFailure::SessionLost(code))
                }
                _ => {}
            }
        }
        if last_poll.elapsed() >= POLL_EVERY && poll_seq.is_none() && s.host.window_free() > 0 {
            poll_seq = Some(s.send(RequestBody::GetStatus).map_err(link)?);
            last_poll = Instant::now();
        }
        if !started || !seq_at_or_after(latest.next_seq, start_seq.wrapping_add(1)) {
            continue;
        }
        let t_start = *start_tick.get_or_insert(base.tick);
        if latest.faults != 0 {
            break;
        }
        if let (Some((at_s, frac)), None) = (o.speed_step, step_at) {
            let at = (at_s * o.tick_hz as f64) as u64;
            let dt = latest.tick.saturating_sub(t_start);
            if dt >= at && s.host.window_free() > 0 {
                let rpm = (o.rpm_milli as f64 * (1.0 + frac)).round() as u32;
                s.send(RequestBody::Sim(SimRequest::Spindle { rpm_milli: rpm, index: true }))
                    .map_err(link)?;
                step_at = Some(dt);
                say(&format!("spindle step to {:.1} rpm at board tick {dt}", rpm as f64 / 1e3));
            }
        }
        if o.progress && last_say.elapsed() >= Duration::from_secs(2) {
            last_say = Instant::now();
            say(&format!(
                "X {:.4} in, Z {:+.6} in, max following {:.3} uin, {:.1} rpm, state {}",
                latest.z_x_in_q24 as f64 / (1u64 << 24) as f64,
                latest.z_cmd_in_q32 as f64 / (1u64 << 32) as f64,
                latest.z_max_following_nin as f64 / 1e3,
                latest.z_spindle_rpm_milli as f64 / 1e3,
                latest.z_state
            ));
        }
        if latest.machine == MachineState::Ready && latest.z_state != 2 {
            break;
        }
        steer.step(&mut s, hook, &latest, &mut watch)?;
        if steer.held() {
            continue;
        }
        let marker = (latest.tick as i64 ^ (latest.z_x_in_q24 as i64).rotate_left(20)) as u64;
        if let Err(why) = watch.check(latest.tick, marker) {
            let _ = s.request(RequestBody::Abort);
            bail!("the job {why}: aborted");
        }
    }
    let fin = status(&mut s)?;
    let _ = s.request(RequestBody::SetStatusPeriod { ms: 0 });
    let t_start = start_tick.unwrap_or(base.tick);
    let step = o
        .speed_step
        .zip(step_at)
        .map(|((_, frac), at)| (at, (o.rpm_milli as f64 * (1.0 + frac)).round() as u32));
    let m = model(&cfg, table, &spec, o.rpm_milli, step, 100 * o.tick_hz as u64)?;
    let mut r = ZRunReport {
        x_steps: fin.positions[X_AXIS as usize] - base.positions[X_AXIS as usize],
        z_steps: fin.positions[Z_AXIS as usize] - base.positions[Z_AXIS as usize],
        max_following_nin: fin.z_max_following_nin,
        faults: fin.faults,
        z_state: fin.z_state,
        board_ticks: fin.tick.saturating_sub(t_start),
        step_at_tick: step_at,
        final_rpm_milli: fin.z_spindle_rpm_milli,
        model: m.clone(),
        seconds: t0.elapsed().as_secs_f64(),
        problems: Vec::new(),
    };
    if (r.x_steps, r.z_steps) != (m.x_steps, m.z_steps) {
        r.problems.push(format!(
            "final X, Z steps ({}, {}) != host model ({}, {})",
            r.x_steps, r.z_steps, m.x_steps, m.z_steps
        ));
    }
    if r.faults != 0 {
        r.problems.push(format!("faults latched: {}", fault_names(r.faults)));
    }
    if m.faults != 0 || !m.finished {
        r.problems.push(format!("the host model did not finish cleanly (faults {:#x})", m.faults));
    }
    if r.z_state != 3 {
        r.problems.push(format!("the Z job ended in state {} (3 = finished)", r.z_state));
    }
    let tol = ((m.max_following_nin as f64 * FOLLOWING_TOLERANCE) as i64).max(FOLLOWING_SLACK_NIN);
    if (r.max_following_nin - m.max_following_nin).abs() > tol {
        r.problems.push(format!(
            "max following error {} nin, host model {} nin (tolerance {tol})",
            r.max_following_nin, m.max_following_nin
        ));
    }
    Ok(r)
}

/// Reads a `--table` file.
pub fn read_table(path: &std::path::Path) -> anyhow::Result<(ZTable, LinkTableBytes)> {
    let src =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let name = path.display().to_string();
    let t = ZTable::parse(&name, &src)?;
    let bytes =
        LinkTableBytes::from_ztable(&t).with_context(|| format!("{name}: for the board"))?;
    Ok((t, bytes))
}
