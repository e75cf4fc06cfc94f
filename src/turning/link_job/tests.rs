use super::run::Gen;
use super::*;
use crate::dda::{Dda, StepOutput};
use crate::machine::machine::SUPERVISE_TICKS;
use crate::machine::{BoardConfig, Inputs, Machine, MachineCommand, MachineState};
use crate::protocol::errors::FaultCode;
use crate::protocol::HomingConfig;
use crate::protocol::CRC32;
use crate::scenario::Scenario;
use crate::spindle::{QuadratureEncoder, SimSpindle};
use crate::turning::command::ZState;
use crate::turning::douglass_table::DOUGLASS_POWER;
use crate::turning::scenario::{self as sc, TurningScenario, TurningVariant};
use crate::turning::table::TableError;

/// The checked-in Douglass table as link bytes and header.
fn douglass_bytes() -> (ZTableHeader, std::vec::Vec<u8>) {
    let t = &DOUGLASS_POWER;
    let h = ZTableHeader {
        form: 0,
        rows: t.len() as u16,
        x0_in_q24: t.x0_in_q24(),
        dx_in_q24: t.dx_in_q24(),
    };
    let mut b = std::vec::Vec::new();
    for r in 0..t.len() {
        for c in t.row(r).unwrap() {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    (h, b)
}

fn upload(
    u: &mut ZTableUpload,
    h: ZTableHeader,
    b: &[u8],
    crc: u32,
) -> Result<LinkTable, ZTableError> {
    u.begin(h)?;
    for (i, c) in b.chunks(200).enumerate() {
        u.chunk(i as u16, c)?;
    }
    u.end(crc)
}

#[test]
fn upload_checks_order_length_and_crc() {
    let (h, b) = douglass_bytes();
    let crc = CRC32.checksum(&b);
    let mut u = ZTableUpload::new();
    let t = upload(&mut u, h, &b, crc).unwrap();
    let LinkTable::Power(p) = &t else { panic!("form") };
    assert_eq!(p.len(), DOUGLASS_POWER.len());
    for r in 0..p.len() {
        assert_eq!(p.row(r), DOUGLASS_POWER.row(r));
    }
    // CRC mismatch: refused, and the upload is over.
    assert_eq!(upload(&mut u, h, &b, crc ^ 1), Err(ZTableError::Crc));
    assert_eq!(u.end(crc), Err(ZTableError::NoUpload));
    // Out-of-order chunk.
    u.begin(h).unwrap();
    u.chunk(0, &b[..200]).unwrap();
    assert_eq!(u.chunk(2, &b[200..400]), Err(ZTableError::Sequence { expected: 1 }));
    // Short and long.
    assert_eq!(u.end(crc), Err(ZTableError::Short));
    u.begin(h).unwrap();
    let mut long = b.clone();
    long.push(0);
    assert_eq!(u.chunk(0, &long), Err(ZTableError::TooLong));
    // Bad headers.
    assert_eq!(u.begin(ZTableHeader { form: 9, ..h }), Err(ZTableError::Header));
    assert_eq!(u.begin(ZTableHeader { rows: 0, ..h }), Err(ZTableError::Header));
    assert_eq!(
        u.begin(ZTableHeader { rows: LINK_TABLE_ROWS as u16 + 1, ..h }),
        Err(ZTableError::Header)
    );
    // An invalid grid passes the CRC but not the table check.
    let bad = ZTableHeader { dx_in_q24: 0, ..h };
    assert_eq!(upload(&mut u, bad, &b, crc), Err(ZTableError::Table(TableError::Grid)));
}

const Z_AXIS: u8 = 0;
const X_AXIS: u8 = 1;

fn spec() -> ZJobSpec {
    let c = sc::command_config();
    ZJobSpec {
        output: ZOutputSpec::Steps { axis: Z_AXIS, steps_per_in: 100_000 },
        x_axis: X_AXIS,
        x_steps_per_in: 1000,
        x_negative: false,
        x_start_in_q24: 0,
        x_end_in_q24: sc::X_END_IN_Q24,
        x_feed_in_q24_per_tick: sc::X_END_IN_Q24 / sc::FEED_TICKS as i32,
        cubic: true,
        advance_ticks_q16: c.advance_ticks_q16,
        engage_ticks: c.engage_ticks,
        blend_start_x_in_q24: c.blend_start_x_in_q24,
        blend_end_x_in_q24: c.blend_end_x_in_q24,
        max_velocity_uin_per_s: c.max_velocity_uin_per_s,
        max_accel_uin_per_s2: c.max_accel_uin_per_s2,
        min_speed_turn_q32_per_tick: c.min_speed_turn_q32_per_tick,
    }
}

fn ready() -> (Machine, Dda) {
    let (m, dda, _) = crate::machine::homed(BoardConfig::with_homing(
        crate::polar::job::link_config(),
        &HomingConfig::NONE,
    ));
    (m, dda)
}

struct Rig {
    m: Machine,
    dda: Dda,
    job: ZJob,
    sim: SimSpindle,
    enc: QuadratureEncoder,
    /// The spindle's speed per tick is the scenario's shifted right by this: a faster tick.
    tick_shift: u32,
}

impl Rig {
    fn new() -> Self {
        let (m, dda) = ready();
        let (h, b) = douglass_bytes();
        let mut job = ZJob::new();
        let t = upload(&mut ZTableUpload::new(), h, &b, CRC32.checksum(&b)).unwrap();
        job.install(t).unwrap();
        let sim = SimSpindle::new(0x4000_0000);
        let enc = QuadratureEncoder::new(sc::encoder_config(), sim.encoder(sc::CPR).0).unwrap();
        Rig { m, dda, job, sim, enc, tick_shift: 0 }
    }

    /// One firmware tick with full ticks only: spindle, sense, inputs (the job's faults),
    /// machine.
    fn tick(&mut self, t: u32, index_lost: bool) -> StepOutput {
        self.sense(t, index_lost);
        self.full_tick()
    }

    /// One firmware tick as the link firmware runs it: a step-only tick when the machine
    /// grants one (and true), else a full one.
    fn tick_step_only(&mut self, t: u32, index_lost: bool) -> (StepOutput, bool) {
        self.sense(t, index_lost);
        let step = if self.m.runs(crate::turning::TURNING_JOB) {
            self.m.fast_tick_with(&mut self.dda, &mut self.job)
        } else {
            self.m.fast_tick(&mut self.dda)
        };
        match step {
            Some(s) => (s, true),
            None => (self.full_tick(), false),
        }
    }

    fn sense(&mut self, t: u32, index_lost: bool) {
        self.sim.advance(sc::spindle_speed_at(t) >> self.tick_shift);
        let (c, i) = self.sim.encoder(sc::CPR);
        self.enc.update(c, if index_lost { None } else { i });
        self.job.sense_from(&self.enc);
    }

    fn full_tick(&mut self) -> StepOutput {
        let inp = Inputs { sensor_faults: self.job.take_sensor_faults(), ..Inputs::QUIET };
        if self.m.runs(crate::turning::TURNING_JOB) {
            self.m.tick_with(&mut self.dda, &inp, &mut self.job).step
        } else {
            self.m.tick(&mut self.dda, &inp).step
        }
    }

    fn start(&mut self) {
        self.start_at(sc::TICK_HZ);
    }

    /// Started at `tick_hz` (the generator's update period follows it), with the spindle's speed
    /// per tick set to match from the first tick ([`Rig::tick_shift`]).
    fn start_at(&mut self, tick_hz: u32) {
        self.job.start(&spec(), tick_hz).unwrap();
        self.m
            .command(MachineCommand::StartSource(crate::turning::TURNING_JOB), &mut self.dda)
            .unwrap();
    }
}

#[test]
fn the_generator_updates_at_20_khz_or_faster() {
    let rpm = |rpm: u64, tick_hz: u64| ((rpm << 32) / 60 / tick_hz) as i32;
    for (tick_hz, shift) in [(10_000, 0), (39_999, 0), (40_000, 1), (50_000, 1), (100_000, 2)] {
        assert_eq!(update_shift(tick_hz, rpm(360, tick_hz as u64)), shift, "{tick_hz} Hz");
    }
    // At most every 8th tick (the interpolation's range), however fast the tick.
    assert_eq!(update_shift(1_000_000, rpm(360, 1_000_000)), 3);
    for hz in (1_000..=400_000).step_by(997) {
        assert!(hz >> update_shift(hz, 0) >= Z_UPDATE_MIN_HZ.min(hz), "{hz}");
    }
    // A fast spindle keeps more updates: the fastest the generator takes is unchanged.
    assert_eq!(update_shift(100_000, rpm(1_000, 100_000)), 1);
    assert_eq!(update_shift(100_000, rpm(2_000, 100_000)), 0);
    assert_eq!(update_shift(100_000, -rpm(2_000, 100_000)), 0);
}

#[test]
fn link_job_reproduces_the_scenario_z_trace_through_the_machine() {
    let mut s = TurningScenario::new(TurningVariant::Encoder);
    let mut rig = Rig::new();
    let mut compared = 0u32;
    // Largest change of Z over one encoder count of angle, 2^-32 in: the sampling step of
    // the scenario's per-tick command, which reads the encoder every tick.
    let mut one_count = 0i64;
    let mut between = 0i64;
    let mut on_update = 0i64;
    let mut ended_at = None;
    for t in 0..sc::RUN_TICKS {
        if s.wants_background() {
            s.background();
        }
        assert!(s.tick());
        if t == sc::ENGAGE_TICK {
            rig.start();
            let count_per_tick = ((1u64 << 32) / sc::CPR as u64) as i32;
            one_count = match &rig.job.run.as_ref().unwrap().gen {
                Gen::Power(g) => g.required_at(count_per_tick).0,
                Gen::Harmonic(g) => g.required_at(count_per_tick).0,
            } >> 16;
            // A table upload is refused while the job runs.
            assert_eq!(rig.job.install(LinkTable::None), Err(ZStartError::Running));
        }
        rig.tick(t, false);
        if t >= sc::ENGAGE_TICK && rig.job.is_running() {
            let z = rig.job.last().unwrap().z_in_q32;
            let d = (z as i64 - s.command_z_in_q32() as i64).abs();
            // The generator updated on this tick (the phase after it is 1).
            if rig.job.run.as_ref().unwrap().update_phase == 1 {
                on_update = on_update.max(d);
            } else {
                between = between.max(d);
            }
            compared += 1;
        }
        if ended_at.is_none() && t > sc::ENGAGE_TICK && !rig.m.runs(crate::turning::TURNING_JOB) {
            ended_at = Some(t);
        }
    }
    eprintln!(
        "|link - scenario|, 2^-32 in: {on_update} on updates, {between} between \
         (one encoder count of angle: {one_count})"
    );
    // The generator updates every other tick at 50 kHz: on its ticks it is the scenario's
    // command to rounding; between, its command taken forward by its derivatives differs
    // from the scenario's fresh encoder reading by less than one count of angle.
    assert_eq!(update_shift(sc::TICK_HZ, sc::speed_at_rpm(360)), 1);
    assert!(on_update <= 4, "{on_update}");
    assert!(between > 0 && between < one_count, "{between} vs {one_count}");
    eprintln!(
        "compared {compared} ticks; job ended at tick {ended_at:?}; max following {} nin; steps {:?}",
        rig.job.max_following_nin(),
        rig.job.steps()
    );
    assert!(compared > sc::FEED_TICKS);
    assert_eq!(rig.m.faults().mask(), 0);
    // The job ended by itself: X fed to 7.5 in (7500 steps), Z back at rest, machine Ready.
    assert_eq!(rig.m.state(), MachineState::Ready);
    assert_eq!(rig.job.steps(), Some((7500, 0)));
    assert_eq!(rig.m.positions()[X_AXIS as usize], 7500);
    assert_eq!(rig.m.positions()[Z_AXIS as usize], 0);
    // The pin rules allow a rise every other tick: 10 uin steps at 25 kHz = 0.25 in/s,
    // below the command's 0.33 in/s peak at X 7.2 in, so the Z axis saturates there
    // (measured 56.9 uin; the scenario's ideal one-step-per-tick stepper: < 12 uin). Finer
    // Z steps do not help (the rate halves with them): a Z job at this feed wants the DAC.
    let fe = rig.job.max_following_nin();
    assert!(fe > 12_000 && fe < 60_000, "{fe}");
}

#[test]
fn index_loss_latches_encoder_index_in_the_machine() {
    let mut rig = Rig::new();
    for t in 0..sc::RUN_TICKS / 2 {
        if t == sc::ENGAGE_TICK {
            rig.start();
        }
        let lost = rig.sim.turns() > 5;
        rig.tick(t, lost);
    }
    assert!(rig.m.faults().has(FaultCode::EncoderIndex), "{:#x}", rig.m.faults().mask());
    assert_eq!(rig.m.state(), MachineState::Fault);
    assert_eq!(rig.job.state(), Some(ZState::Faulted(FaultCode::EncoderIndex)));
    // The hold stopped X; the cause is not a level: ClearFault is accepted, then the
    // firmware drops the run and a new table may be installed.
    let x = rig.job.x_in_q24();
    rig.tick(sc::RUN_TICKS / 2, true);
    assert_eq!(rig.job.x_in_q24(), x);
    rig.m.command(MachineCommand::ClearFault, &mut rig.dda).unwrap();
    rig.job.drop_run();
    assert!(rig.job.install(LinkTable::None).is_ok());
}

#[test]
fn start_refusals_change_nothing() {
    let mut job = ZJob::new();
    assert_eq!(job.start(&spec(), sc::TICK_HZ), Err(ZStartError::NoTable));
    let mut rig = Rig::new();
    // Spindle not turning yet: SpindleStopped from the pre-start check.
    assert_eq!(
        rig.job.start(&spec(), sc::TICK_HZ),
        Err(ZStartError::Fault(FaultCode::SpindleStopped))
    );
    assert!(!rig.job.is_running());
    let bad = ZJobSpec { x_axis: Z_AXIS, ..spec() };
    assert_eq!(rig.job.start(&bad, sc::TICK_HZ), Err(ZStartError::Spec));
}

#[test]
fn coefficients_interpolated_a_tick_ahead_change_no_command() {
    // Two boards in lockstep; one forgets the coefficients taken ahead before every tick, so
    // each of its updates interpolates afresh. Holds begin and end on both ticks of the
    // update cycle (a hold beginning on an update tick leaves X where the ahead tick did not
    // expect it).
    let (mut a, mut b) = (Rig::new(), Rig::new());
    let (mut used, mut refused) = (0u32, 0u32);
    const HOLD_EVERY_TICKS: u32 = 997;
    const HOLD_TICKS: u32 = 13;
    for t in 0..sc::RUN_TICKS {
        if t == sc::ENGAGE_TICK {
            a.start();
            b.start();
        }
        if t > sc::ENGAGE_TICK && a.m.runs(crate::turning::TURNING_JOB) {
            let cmd = match t % HOLD_EVERY_TICKS {
                0 => Some(MachineCommand::Hold),
                HOLD_TICKS => Some(MachineCommand::Resume),
                _ => None,
            };
            if let Some(c) = cmd {
                for r in [&mut a, &mut b] {
                    r.m.command(c, &mut r.dda).unwrap();
                }
            }
        }
        if let Some(run) = b.job.run.as_mut() {
            run.ahead.valid = false;
        }
        let ahead_x = a.job.run.as_ref().filter(|r| r.ahead.valid).map(|r| r.ahead.x_in_q24);
        a.tick(t, false);
        b.tick(t, false);
        if let (Some(x), Some(run)) = (ahead_x, a.job.run.as_ref()) {
            if run.update_phase == 1 {
                if Some(x) == a.job.x_in_q24() {
                    used += 1;
                } else {
                    refused += 1;
                }
            }
        }
        assert_eq!(a.job.last(), b.job.last(), "tick {t}");
        assert_eq!(a.m.positions(), b.m.positions(), "tick {t}");
        assert_eq!(a.m.state(), b.m.state(), "tick {t}");
    }
    eprintln!("ahead coefficients used on {used} updates, not on {refused}");
    assert_eq!(a.m.faults().mask(), 0);
    assert_eq!(a.m.state(), MachineState::Ready);
    assert!(used > sc::FEED_TICKS / 4, "{used}");
    assert!(refused > 0, "no hold began on an update tick");
}

#[test]
fn step_only_ticks_step_a_z_job_as_full_ticks_do() {
    let (mut full, mut fast) = (Rig::new(), Rig::new());
    let (mut job_ticks, mut step_only) = (0u32, 0u32);
    let mut ended = None;
    for t in 0..sc::RUN_TICKS {
        if t == sc::ENGAGE_TICK {
            full.start();
            fast.start();
        }
        let running = full.m.runs(crate::turning::TURNING_JOB);
        let a = full.tick(t, false);
        let (b, was_step_only) = fast.tick_step_only(t, false);
        if running {
            assert_eq!(a, b, "tick {t}");
            job_ticks += 1;
            step_only += u32::from(was_step_only);
        } else if t > sc::ENGAGE_TICK && ended.is_none() {
            ended = Some(t);
        }
    }
    eprintln!("{step_only} of the job's {job_ticks} ticks were step-only");
    // Every full tick grants the next 7 (the job's end waits for a full one).
    assert!(u64::from(step_only) * 8 >= u64::from(job_ticks) * 7 - 8, "{step_only}/{job_ticks}");
    assert!(ended.is_some());
    for r in [&full, &fast] {
        assert_eq!(r.m.state(), MachineState::Ready);
        assert_eq!(r.m.faults().mask(), 0);
        assert_eq!(r.job.steps(), Some((7500, 0)));
    }
    assert_eq!(full.m.positions(), fast.m.positions());
}

#[test]
fn a_z_job_fault_on_a_step_only_tick_freezes_the_command_at_once_and_latches_within_a_period() {
    let lose_after_turns = 5;
    let run = |step_only: bool| {
        let mut r = Rig::new();
        let mut latched = None;
        let mut frozen_from = None;
        for t in 0..sc::RUN_TICKS / 2 {
            if t == sc::ENGAGE_TICK {
                r.start();
            }
            let lost = r.sim.turns() > lose_after_turns;
            if step_only {
                r.tick_step_only(t, lost);
            } else {
                r.tick(t, lost);
            }
            if frozen_from.is_none()
                && r.job.state() == Some(ZState::Faulted(FaultCode::EncoderIndex))
            {
                frozen_from = Some(t);
            }
            if latched.is_none() && r.m.faults().has(FaultCode::EncoderIndex) {
                latched = Some(t);
            }
        }
        (frozen_from.expect("the command froze"), latched.expect("the fault latched"), r)
    };
    let (frozen_full, latched_full, _) = run(false);
    let (frozen_fast, latched_fast, r) = run(true);
    assert_eq!(frozen_fast, frozen_full, "the generator froze on the same tick");
    assert!(
        latched_fast >= latched_full && latched_fast < latched_full + u32::from(SUPERVISE_TICKS)
    );
    assert_eq!(r.m.state(), MachineState::Fault);
}

#[test]
fn full_ticks_keep_off_the_generators_heavy_ticks() {
    // The default 100 kHz tick: the scenario's spindle at half its speed per tick.
    let mut r = Rig::new();
    r.tick_shift = 1;
    let (mut full, mut on_heavy, mut job_ticks) = (0u32, 0u32, 0u32);
    for t in 0..sc::RUN_TICKS {
        if t == sc::ENGAGE_TICK {
            r.start_at(2 * sc::TICK_HZ);
        }
        let running = r.m.runs(crate::turning::TURNING_JOB);
        let (shift, phase) =
            r.job.run.as_ref().map_or((0, 0), |z| (z.update_shift, z.update_phase));
        let (_, was_step_only) = r.tick_step_only(t, false);
        // The job's first full tick (its start's) may fall anywhere; the machine aligns after it.
        if running && job_ticks > u32::from(SUPERVISE_TICKS) {
            assert_eq!(shift, 2, "100 kHz: an update every 4 ticks");
            let mask = (1u8 << shift) - 1;
            if !was_step_only {
                full += 1;
                on_heavy += u32::from(phase == 0 || phase == mask);
            }
        }
        job_ticks += u32::from(running);
    }
    assert!(full > job_ticks / u32::from(SUPERVISE_TICKS) / 2, "{full} full ticks");
    assert_eq!(on_heavy, 0, "{on_heavy} of {full} full ticks ran beside an update");
}
