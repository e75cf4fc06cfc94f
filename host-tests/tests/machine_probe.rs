//! Probe moves through the whole machine (`motion::machine::probe`): the tick trips on the
//! debounced probe input, latches every axis's position at that tick, decelerates, drops the
//! rest of the move and ends in `Ready`; no trip and a wrong initial state are the probe
//! faults; a bouncing probe signal trips only once it holds for the debounce.

use motion::dda::{Dda, Preparer};
use motion::machine::{
    BoardConfig, Inputs, Machine, MachineCommand, MachineState, ProbeKind, ProbePhase, Refusal,
};
use motion::planner::{Move, Planner};
use motion::protocol::FaultCode;
use motion::scenarios::faults::{config, Case};
use motion::segment::Segment;

/// Feed of the probe moves, steps per second (X).
const FEED_HZ: u32 = 5_000;
/// Longest a test runs, ticks (a 4000-step move at 5 kHz takes 40 000 ticks at 50 kHz).
const MAX_TICKS: u32 = 200_000;

struct Rig {
    m: Machine,
    dda: Dda,
    prep: Preparer,
    cfg: BoardConfig,
}

impl Rig {
    /// Booted, homed (`Ready`) at position 0.
    fn new() -> Rig {
        let cfg = config(Case::EStop);
        let mut m = Machine::new();
        m.boot(Ok(cfg));
        let mc = m.config().link.machine;
        let mut r = Rig { m, dda: Dda::new(&mc).unwrap(), prep: Preparer::new(&mc).unwrap(), cfg };
        r.m.command(MachineCommand::Home, &mut r.dda).unwrap();
        for _ in 0..10 {
            r.tick(false);
        }
        assert_eq!(r.m.state(), MachineState::Ready);
        r
    }

    /// The switch debounce in ticks (the probe's too).
    fn debounce_ticks(&self) -> u32 {
        let c = self.cfg.link;
        c.inputs.debounce_ticks(c.machine.tick_hz) as u32
    }

    /// The raw probe input at `level` for as long as the debounce takes to believe it.
    fn hold_input(&mut self, level: bool) {
        for _ in 0..self.debounce_ticks() {
            self.tick(level);
        }
    }

    fn settle(&mut self) {
        while self.m.wants_background() {
            self.m.background(&mut self.dda, &mut self.prep);
        }
    }

    /// One tick with the raw probe input `probe`, then the control task's work: the
    /// background and, as the link's feeder does, the probe discard and feeding the DDA.
    fn tick(&mut self, probe: bool) {
        self.m.tick(&mut self.dda, &Inputs { probe, ..Inputs::QUIET });
        self.settle();
    }

    fn x(&self) -> i64 {
        self.m.positions()[0]
    }

    /// Queues an X move of `steps` (planned as one job) straight into the DDA.
    fn queue_x(&mut self, steps: i32) {
        let mut p = Planner::new(&self.cfg.link.machine);
        p.push(&Move { steps: [steps, 0, 0, 0, 0, 0], feed_hz: FEED_HZ }).unwrap();
        p.finish();
        let segs: Vec<Segment> = std::iter::from_fn(|| p.pop()).collect();
        for s in &segs {
            self.m.command(MachineCommand::Queue(s), &mut self.dda).unwrap();
            self.dda.push(&self.prep.prepare(s).unwrap()).unwrap();
        }
    }

    /// Arms `kind`, queues the move and starts it.
    fn start_probe(&mut self, kind: ProbeKind, steps: i32) -> MachineState {
        self.m.arm_probe(kind, &self.dda).unwrap();
        self.queue_x(steps);
        self.m.command(MachineCommand::Start, &mut self.dda).unwrap()
    }

    /// Ticks with the probe input `probe(x, tick)` until the job ends (not `Running`).
    fn run(&mut self, probe: impl Fn(i64, u32) -> bool) {
        for t in 0..MAX_TICKS {
            if self.m.state() != MachineState::Running {
                return;
            }
            let level = probe(self.x(), t);
            self.tick(level);
            // The link's feeder: drop the rest of a tripped probe move.
            self.m.take_probe_discard();
        }
        panic!("the job did not end in {MAX_TICKS} ticks");
    }
}

#[test]
fn a_toward_move_latches_the_trip_decelerates_and_ends_ready() {
    let mut r = Rig::new();
    let surface = 1_000;
    assert_eq!(r.start_probe(ProbeKind::TowardError, 4_000), MachineState::Running);
    r.run(|x, _| x >= surface);
    assert_eq!(r.m.state(), MachineState::Ready);
    assert!(r.m.faults().is_clear(), "{:?}", r.m.faults());
    let p = r.m.probe();
    assert_eq!(p.phase(), ProbePhase::Tripped);
    let latched = p.latched_steps()[0];
    // The debounce delays the trip by its ticks: at most that many ticks of steps past the
    // surface (one step per tick at most; at FEED_HZ, debounce * FEED_HZ / tick_hz steps).
    let late = (r.debounce_ticks() * FEED_HZ / r.cfg.link.machine.tick_hz) as i64 + 1;
    assert!((surface..=surface + late).contains(&latched), "latched {latched}");
    assert_eq!(p.latched_steps()[1], 0);
    // Stopped with a deceleration: a little past the latch, far from the move's end; the rest
    // of the move is gone.
    let stop = r.x();
    assert!(stop > latched && stop < 2_000, "stopped at {stop}");
    assert!(r.dda.is_idle());
    assert_eq!(r.m.in_flight(&r.dda), 0);
    assert_eq!(r.m.planned_end()[0], stop);
    // The next job runs from where the axes stopped.
    r.queue_x(-500);
    r.m.command(MachineCommand::Start, &mut r.dda).unwrap();
    r.run(|_, _| true);
    assert_eq!(r.m.state(), MachineState::Ready);
    assert_eq!(r.x(), stop - 500);
    assert_eq!(r.m.probe().phase(), ProbePhase::Tripped, "a plain job keeps the result");
}

#[test]
fn an_away_move_trips_when_contact_is_lost() {
    let mut r = Rig::new();
    // In contact below 600 steps (the probe is on the surface at 0).
    r.hold_input(true);
    r.start_probe(ProbeKind::Away, 3_000);
    r.run(|x, _| x < 600);
    assert_eq!(r.m.state(), MachineState::Ready);
    let latched = r.m.probe().latched_steps()[0];
    assert!((600..=612).contains(&latched), "latched {latched}");
}

#[test]
fn no_contact_is_a_fault_only_for_the_error_kinds() {
    for (kind, fault) in [
        (ProbeKind::TowardError, Some(FaultCode::ProbeFail)),
        (ProbeKind::Toward, None),
        (ProbeKind::AwayError, Some(FaultCode::ProbeFail)),
        (ProbeKind::Away, None),
    ] {
        let mut r = Rig::new();
        // Toward: never touches; away: always in contact.
        let level = !kind.trip_level();
        r.hold_input(level);
        r.start_probe(kind, 800);
        r.run(|_, _| level);
        for _ in 0..r.debounce_ticks() + 10 {
            r.tick(level);
        }
        assert_eq!(r.x(), 800, "{kind:?} ran the whole move");
        assert_eq!(r.m.probe().phase(), ProbePhase::Missed, "{kind:?}");
        match fault {
            Some(f) => {
                assert_eq!(r.m.state(), MachineState::Fault, "{kind:?}");
                assert_eq!(r.m.faults().first(), Some(f));
            }
            None => {
                assert_eq!(r.m.state(), MachineState::Ready, "{kind:?}");
                assert!(r.m.faults().is_clear());
            }
        }
    }
}

#[test]
fn a_probe_already_in_its_trip_state_faults_at_start_and_nothing_moves() {
    for kind in ProbeKind::ALL {
        let mut r = Rig::new();
        // The trip level, long enough for the debounce to believe it.
        let level = kind.trip_level();
        r.hold_input(level);
        assert_eq!(r.m.probe_input(), level);
        assert_eq!(r.start_probe(kind, 800), MachineState::Fault, "{kind:?}");
        assert_eq!(r.m.faults().first(), Some(FaultCode::ProbeInitial));
        assert_eq!(r.m.probe().phase(), ProbePhase::Refused);
        for _ in 0..1_000 {
            r.tick(level);
        }
        assert_eq!(r.x(), 0, "{kind:?} moved");
        // The fault is an event: cleared at once, the job dropped.
        r.m.command(MachineCommand::ClearFault, &mut r.dda).unwrap();
        r.settle();
        assert_eq!(r.m.state(), MachineState::Ready);
    }
}

#[test]
fn a_bouncing_probe_trips_only_once_the_contact_holds() {
    let mut r = Rig::new();
    let d = r.debounce_ticks();
    assert_eq!(d, 100, "2 ms at 50 kHz");
    // Before the surface at 1500: one-tick spikes every 50 ticks and bursts of d - 1 ticks
    // every 1000 ticks (chatter shorter than the debounce); from the surface on, steady.
    let surface = 1_500;
    r.start_probe(ProbeKind::TowardError, 4_000);
    r.run(|x, t| x >= surface || t % 50 == 0 || t % 1_000 < d - 1);
    let latched = r.m.probe().latched_steps()[0];
    assert!((surface..=surface + 11).contains(&latched), "tripped by the chatter at {latched}");
    assert_eq!(r.m.state(), MachineState::Ready);
}

#[test]
fn arming_needs_a_ready_machine_with_nothing_queued_and_abort_drops_the_move() {
    let mut r = Rig::new();
    r.queue_x(500);
    let refused = r.m.arm_probe(ProbeKind::Toward, &r.dda);
    assert_eq!(refused, Err(Refusal::OutOfState(MachineState::Ready)));
    r.m.command(MachineCommand::Start, &mut r.dda).unwrap();
    assert!(r.m.arm_probe(ProbeKind::Toward, &r.dda).is_err());
    r.run(|_, _| false);
    r.start_probe(ProbeKind::TowardError, 2_000);
    for _ in 0..100 {
        r.tick(false);
    }
    r.m.command(MachineCommand::Abort, &mut r.dda).unwrap();
    r.settle();
    assert_eq!(r.m.probe().phase(), ProbePhase::Dropped);
    for _ in 0..r.debounce_ticks() + 10 {
        r.tick(true);
    }
    assert!(r.m.faults().is_clear(), "a dropped probe move does not trip or fault");
}
