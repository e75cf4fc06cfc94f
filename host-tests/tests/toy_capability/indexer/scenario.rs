//! The indexer's closed-loop scenario: the machine homed on the fault suite's board, the job
//! started as a source job, and a simulated operator who may press feed hold and resume, or
//! the e-stop, at given ticks. Reported like every built-in scenario.

use motion::dda::{Dda, Preparer};
use motion::machine::{BoardConfig, Inputs, Machine, MachineCommand, MachineState};
use motion::scenario::{Scenario, ScenarioReport, TraceHash};

use super::source::Indexer;
use super::{IndexJob, INDEXER_JOB};

/// What the simulated operator does, in ticks from the job's start.
#[derive(Clone, Copy, Debug, Default)]
pub struct Operator {
    /// Feed hold at this tick, resume `hold_ticks` later.
    pub hold_at: Option<u64>,
    pub hold_ticks: u64,
    /// E-stop pressed from this tick on.
    pub estop_at: Option<u64>,
}

pub struct IndexerScenario {
    m: Machine,
    dda: Dda,
    prep: Preparer,
    source: Indexer,
    op: Operator,
    ticks: u64,
    trace: TraceHash,
    held_ticks: u64,
    /// Axis 0's position when the e-stop latched, and whether it moved since.
    estop_position: Option<i64>,
    moved_after_estop: bool,
    finished: bool,
}

impl IndexerScenario {
    /// The machine homed with `cfg` (Ready), then the job started: `None` if the machine
    /// refuses either.
    pub fn new(cfg: BoardConfig, job: IndexJob, op: Operator) -> Option<Self> {
        let mut m = Machine::new();
        m.boot(Ok(cfg));
        let mc = m.config().link.machine;
        let mut dda = Dda::new(&mc).ok()?;
        let mut prep = Preparer::new(&mc).ok()?;
        m.command(MachineCommand::Home, &mut dda).ok()?;
        for _ in 0..16 {
            if m.state() == MachineState::Ready {
                break;
            }
            m.tick(&mut dda, &Inputs::QUIET);
            while m.wants_background() {
                m.background(&mut dda, &mut prep);
            }
        }
        m.command(MachineCommand::StartSource(INDEXER_JOB), &mut dda).ok()?;
        Some(IndexerScenario {
            m,
            dda,
            prep,
            source: Indexer::new(job),
            op,
            ticks: 0,
            trace: TraceHash::new(),
            held_ticks: 0,
            estop_position: None,
            moved_after_estop: false,
            finished: false,
        })
    }

    pub fn machine(&self) -> &Machine {
        &self.m
    }
}

impl Scenario for IndexerScenario {
    fn name(&self) -> &'static str {
        "indexer_stations"
    }

    fn tick_hz(&self) -> u32 {
        self.m.config().link.machine.tick_hz
    }

    fn tick(&mut self) -> bool {
        if self.finished {
            return false;
        }
        let t = self.ticks;
        if let Some(h) = self.op.hold_at {
            if t == h {
                let _ = self.m.command(MachineCommand::Hold, &mut self.dda);
            } else if t == h + self.op.hold_ticks {
                let _ = self.m.command(MachineCommand::Resume, &mut self.dda);
            }
        }
        let estop = self.op.estop_at.is_some_and(|e| t >= e);
        let inputs = Inputs { estop, ..Inputs::QUIET };
        // As the link firmware does: the source ticks only while the machine says its job
        // runs (an abort or a fault's stop ends it); otherwise the machine's plain tick.
        let out = if self.m.runs(INDEXER_JOB) {
            self.m.tick_with(&mut self.dda, &inputs, &mut self.source)
        } else {
            self.m.tick(&mut self.dda, &inputs)
        };
        while self.m.wants_background() {
            self.m.background(&mut self.dda, &mut self.prep);
        }
        self.ticks += 1;
        self.trace.u32(out.step.rise().into());
        self.trace.u32(out.step.dir_write().into());
        if self.m.state() == MachineState::Holding {
            self.held_ticks += 1;
        }
        let x = self.m.positions()[0];
        match self.estop_position {
            Some(p) => self.moved_after_estop |= p != x,
            None if self.m.faults().has(motion::protocol::FaultCode::EStop) => {
                self.estop_position = Some(x);
            }
            None => {}
        }
        // The machine decides the end: the source went idle (Ready), or a fault, after which
        // the run watches a while longer for any step the freeze should have stopped.
        let fault_seen_long_enough = self.op.estop_at.is_some_and(|e| t >= e + 1_000);
        self.finished = self.m.state() == MachineState::Ready
            || (self.m.state() == MachineState::Fault && fault_seen_long_enough);
        true
    }

    fn report(&self) -> ScenarioReport {
        let fault = self.m.faults().first().map_or(0, |f| f.code());
        let mut r = ScenarioReport::new(self.name(), self.ticks, self.trace.value(), fault);
        r.push("position_steps", self.m.positions()[0]);
        r.push("stations_done", self.source.stations_done().into());
        r.push("held_ticks", self.held_ticks as i64);
        r.push("moved_after_estop", self.moved_after_estop.into());
        r
    }
}
