//! Every (state, command) pair of the machine's table, driven for real: the answer matches the
//! table, and a refusal changes nothing at all (machine and DDA compared before and after).

use motion::dda::{Dda, Preparer};
use motion::machine::{
    cell, BoardConfig, Cell, CommandKind, Inputs, Machine, MachineCommand, MachineState, Refusal,
};
use motion::planner::{Move, Planner};
use motion::protocol::FaultCode;
use motion::scenarios::faults::{config, Case};
use motion::segment::Segment;

struct Rig {
    m: Machine,
    dda: Dda,
    prep: Preparer,
}

impl Rig {
    fn new(cfg: Option<BoardConfig>) -> Rig {
        let mut m = Machine::new();
        if let Some(c) = cfg {
            m.boot(Ok(c));
        }
        let mc = m.config().link.machine;
        Rig { m, dda: Dda::new(&mc).unwrap(), prep: Preparer::new(&mc).unwrap() }
    }

    fn settle(&mut self) {
        while self.m.wants_background() {
            self.m.background(&mut self.dda, &mut self.prep);
        }
    }

    fn tick(&mut self, inp: &Inputs) {
        self.settle();
        self.m.tick(&mut self.dda, inp);
        self.settle();
    }

    /// `inp` for as long as the machine's switch debounce takes to believe a new level.
    fn hold(&mut self, inp: &Inputs) {
        let c = self.m.config().link;
        for _ in 0..c.inputs.debounce_ticks(c.machine.tick_hz).max(1) {
            self.tick(inp);
        }
    }

    fn cmd(&mut self, c: MachineCommand<'_>) -> Result<MachineState, Refusal> {
        self.m.command(c, &mut self.dda)
    }

    fn snapshot(&self) -> String {
        format!(
            "{:?} {:?} {:?} {} {}",
            self.m,
            self.dda.state(),
            self.dda.positions(),
            self.dda.ready_free(),
            self.dda.now()
        )
    }
}

fn segment(steps: i32) -> Segment {
    let mut p = Planner::new(&config(Case::EStop).link.machine);
    p.push(&Move { steps: [steps, 0, 0, 0, 0, 0], feed_hz: 5_000 }).unwrap();
    p.finish();
    p.pop().unwrap()
}

/// A rig in `s`, reached through commands and ticks only.
fn rig_in(s: MachineState) -> Rig {
    let mut r = match s {
        MachineState::Boot => return Rig::new(None),
        MachineState::Homing => Rig::new(Some(config(Case::HomingOk))),
        _ => Rig::new(Some(config(Case::EStop))),
    };
    if s == MachineState::Idle {
        return r;
    }
    r.cmd(MachineCommand::Home).unwrap();
    r.settle();
    if s == MachineState::Homing {
        return r;
    }
    r.tick(&Inputs::QUIET);
    assert_eq!(r.m.state(), MachineState::Ready);
    match s {
        MachineState::Ready => {}
        MachineState::Running | MachineState::Holding => {
            let seg = segment(2_000);
            r.cmd(MachineCommand::Queue(&seg)).unwrap();
            r.dda.push(&r.prep.prepare(&seg).unwrap()).unwrap();
            r.cmd(MachineCommand::Start).unwrap();
            for _ in 0..100 {
                r.tick(&Inputs::QUIET);
            }
            if s == MachineState::Holding {
                r.cmd(MachineCommand::Hold).unwrap();
            }
        }
        MachineState::Fault => {
            r.tick(&Inputs { estop: true, ..Inputs::QUIET });
            // E-stop released again (for the debounce): the cause is gone, the fault stays
            // latched.
            r.hold(&Inputs::QUIET);
        }
        _ => unreachable!(),
    }
    assert_eq!(r.m.state(), s);
    r
}

/// Runs command kind `k` (SetConfig with `cfg`, Queue with `seg`).
fn run_kind(
    r: &mut Rig,
    k: CommandKind,
    cfg: &BoardConfig,
    seg: &Segment,
) -> Result<MachineState, Refusal> {
    match k {
        CommandKind::SetConfig => r.m.set_config(cfg),
        _ => r.cmd(command_of(k, seg)),
    }
}

fn command_of(k: CommandKind, seg: &Segment) -> MachineCommand<'_> {
    match k {
        CommandKind::SetConfig => unreachable!("SetConfig is Machine::set_config"),
        CommandKind::Home => MachineCommand::Home,
        CommandKind::Start => MachineCommand::Start,
        CommandKind::Queue => MachineCommand::Queue(seg),
        CommandKind::Hold => MachineCommand::Hold,
        CommandKind::Resume => MachineCommand::Resume,
        CommandKind::Abort => MachineCommand::Abort,
        CommandKind::ClearFault => MachineCommand::ClearFault,
        CommandKind::JogOff => MachineCommand::JogOff,
    }
}

#[test]
fn every_state_command_pair_is_answered_as_the_table_says() {
    let cfg = config(Case::EStop);
    let seg = segment(100);
    let mut pairs = 0;
    for s in MachineState::ALL {
        for k in CommandKind::ALL {
            let mut r = rig_in(s);
            let before = r.snapshot();
            let got = run_kind(&mut r, k, &cfg, &seg);
            let want = match cell(s, k) {
                Cell::Refused => Err(Refusal::OutOfState(s)),
                // The rig's fault is an e-stop: nothing to jog off, refused, nothing changes
                // (the jog itself: the `fault_limit_jog_off` scenario).
                Cell::Stay if k == CommandKind::JogOff => Err(Refusal::NotOnLimit),
                Cell::Stay => Ok(s),
                Cell::To(t) => Ok(t),
                // After an e-stop the homing is not trusted: Idle.
                Cell::Recover => Ok(MachineState::Idle),
            };
            assert_eq!(got, want, "{s:?} {k:?}");
            if got.is_err() {
                assert_eq!(r.snapshot(), before, "{s:?} {k:?} refused but changed something");
            } else {
                assert_eq!(r.m.state(), want.unwrap());
            }
            pairs += 1;
        }
    }
    assert_eq!(pairs, MachineState::COUNT * CommandKind::COUNT);
}

#[test]
fn clear_fault_is_refused_while_the_cause_is_active_and_changes_nothing() {
    let mut r = rig_in(MachineState::Ready);
    let pressed = Inputs { limit_max: 0b10, ..Inputs::QUIET };
    // A pressed switch with nothing moving is no fault; it becomes one once motion may happen.
    r.tick(&pressed);
    assert_eq!(r.m.state(), MachineState::Ready);
    let seg = segment(1_000);
    r.cmd(MachineCommand::Queue(&seg)).unwrap();
    r.dda.push(&r.prep.prepare(&seg).unwrap()).unwrap();
    r.cmd(MachineCommand::Start).unwrap();
    // Believed once it has held for the debounce.
    r.hold(&pressed);
    assert_eq!(r.m.state(), MachineState::Fault);
    assert_eq!(r.m.faults().first(), Some(FaultCode::LimitSwitch));
    let before = r.snapshot();
    assert_eq!(
        r.cmd(MachineCommand::ClearFault),
        Err(Refusal::CauseActive(FaultCode::LimitSwitch))
    );
    assert_eq!(r.snapshot(), before);
    // Released (for the debounce): the limit kept the homing, so ClearFault goes to Ready.
    r.hold(&Inputs::QUIET);
    assert_eq!(r.cmd(MachineCommand::ClearFault), Ok(MachineState::Ready));
    assert!(r.m.faults().is_clear());
}

#[test]
fn invalid_config_is_refused_with_its_field() {
    let mut r = rig_in(MachineState::Idle);
    let mut bad = config(Case::HomingOk);
    bad.home[1].latch_hz = bad.home[1].search_hz + 1;
    let before = r.snapshot();
    match r.m.set_config(&bad) {
        Err(Refusal::InvalidConfig(e)) => assert_eq!((e.field, e.axis), ("latch_hz", Some(1))),
        other => panic!("{other:?}"),
    }
    assert_eq!(r.snapshot(), before);
}

#[test]
fn first_fault_is_kept_and_every_fault_is_in_the_mask() {
    let mut r = rig_in(MachineState::Running);
    let inp = Inputs {
        sensor_faults: FaultCode::ForceStuck.bit() | FaultCode::ResolverLoss.bit(),
        ..Inputs::QUIET
    };
    r.tick(&inp);
    r.tick(&Inputs { estop: true, ..inp });
    let l = r.m.faults();
    assert_eq!(l.first(), Some(FaultCode::ForceStuck));
    assert_eq!(
        l.mask(),
        FaultCode::ForceStuck.bit() | FaultCode::ResolverLoss.bit() | FaultCode::EStop.bit()
    );
    // The e-stop came second but still killed the outputs.
    assert_eq!(r.m.outputs(), motion::machine::Outputs::SAFE);
}

#[test]
fn rendered_docs_are_stable_and_cover_the_table() {
    let render = || {
        let mut s = String::new();
        motion::machine::markdown(&mut s).unwrap();
        s
    };
    let doc = render();
    assert_eq!(doc, render());
    for s in MachineState::ALL {
        let row = doc.lines().find(|l| l.starts_with(&format!("| {} |", s.name()))).unwrap();
        assert_eq!(row.matches(" |").count(), CommandKind::COUNT + 1, "{row}");
        for k in CommandKind::ALL {
            if let Cell::To(t) = cell(s, k) {
                assert!(doc.contains(&format!("    {} --> {}: {}", s.name(), t.name(), k.name())));
            }
        }
    }
    for f in FaultCode::ALL {
        assert!(doc.contains(&format!("| {} | {} |", f.code(), f.name())));
    }
}

#[test]
fn estop_switches_the_spindle_and_coolant_off_and_keeps_them_off() {
    use motion::protocol::{ProgramOutputs, SpindleDir};
    let mut r = rig_in(MachineState::Running);
    let on = ProgramOutputs { spindle: SpindleDir::Ccw, mist: true, flood: true };
    assert!(r.m.set_outputs(on.applied_to(r.m.outputs())));
    assert_eq!(ProgramOutputs::of(&r.m.outputs()), on);
    r.hold(&Inputs { estop: true, ..Inputs::QUIET });
    assert!(r.m.faults().has(FaultCode::EStop));
    assert_eq!(r.m.outputs(), motion::machine::Outputs::SAFE);
    // Refused while the e-stop is latched: nothing switches back on.
    assert!(!r.m.set_outputs(on.applied_to(r.m.outputs())));
    assert_eq!(ProgramOutputs::of(&r.m.outputs()), ProgramOutputs::OFF);
}

#[test]
fn an_abort_with_the_dda_queue_full_is_background_work_for_the_feeder() {
    // A long job: the DDA's ready queue full of prepared segments, the machine running.
    let mut r = rig_in(MachineState::Ready);
    let seg = segment(2_000);
    while r.dda.ready_free() > 0 {
        r.cmd(MachineCommand::Queue(&seg)).unwrap();
        r.dda.push(&r.prep.prepare(&seg).unwrap()).unwrap();
    }
    r.cmd(MachineCommand::Start).unwrap();
    assert!(r.m.feeder_blocked(&r.dda), "a full queue and nothing due: the feeder waits");
    // The jog cancel's or the reset's abort: the queue is still full, and the feeder must run
    // the background (which empties it), not wait for room that never comes.
    r.cmd(MachineCommand::Abort).unwrap();
    assert_eq!(r.dda.ready_free(), 0);
    assert!(!r.m.feeder_blocked(&r.dda));
    r.m.background(&mut r.dda, &mut r.prep);
    assert!(r.dda.ready_free() > 0 && r.m.in_flight(&r.dda) == 0);
    assert!(!r.m.feeder_blocked(&r.dda));
}
