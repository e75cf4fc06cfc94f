//! A fifth capability added the way the registry says: one folder ([`indexer`]) and one line in
//! a registry. It compiles against the library as it is and runs a scenario through the machine
//! (feed hold, e-stop freeze, step counters and job end by the machine's own rules) without a
//! change to the protocol, the machine or motionctl.

mod indexer;

use indexer::scenario::{IndexerScenario, Operator};
use indexer::{IndexJob, CAPABILITY};
use motion::capabilities;
use motion::capability::{self, Capability, RegistryError};
use motion::machine::MachineState;
use motion::protocol::FaultCode;
use motion::scenario::run_to_end;
use motion::scenarios::faults::{config, Case};

/// The built-in registry plus the indexer's line.
const REGISTRY: [&Capability; 5] = [
    capabilities::REGISTRY[0],
    capabilities::REGISTRY[1],
    capabilities::REGISTRY[2],
    capabilities::REGISTRY[3],
    &CAPABILITY,
];

const JOB: IndexJob =
    IndexJob { stations: 6, steps_per_station: 40, step_every_ticks: 5, dwell_ticks: 300 };

/// Longest any of these runs may take.
const MAX_TICKS: u64 = 1_000_000;

#[test]
fn the_indexer_joins_the_registry_without_a_clash() {
    assert_eq!(capability::check(&REGISTRY), Ok(()));
    // Its tag and bit are its own; claiming a built-in tag is refused.
    let stolen = Capability { jobs: &[motion::turning::TURNING_JOB], ..CAPABILITY };
    let clash = [REGISTRY[0], REGISTRY[1], REGISTRY[2], REGISTRY[3], &stolen];
    assert_eq!(
        capability::check(&clash),
        Err(RegistryError::SameJob("turning", "indexer", motion::turning::TURNING_JOB))
    );
    let board_caps = motion::protocol::CAP_DDA | indexer::CAP_INDEXER_JOB;
    let on_board: Vec<&str> =
        REGISTRY.iter().filter(|c| c.on_board(board_caps)).map(|c| c.name).collect();
    assert_eq!(on_board, ["indexer"]);
}

#[test]
fn the_machine_runs_the_indexer_to_its_end() {
    let mut s = IndexerScenario::new(config(Case::EStop), JOB, Operator::default()).unwrap();
    let r = run_to_end(&mut s, MAX_TICKS);
    assert_eq!(r.fault, 0);
    assert_eq!(s.machine().state(), MachineState::Ready, "the machine ended the job");
    assert_eq!(r.figure("position_steps"), Some(JOB.total_steps() as i64));
    assert_eq!(r.figure("stations_done"), Some(JOB.stations.into()));
    assert_eq!(r.ticks, JOB.ticks_unheld(), "the job ends on the tick its source goes idle");
    assert_eq!(r.figure("held_ticks"), Some(0));
}

#[test]
fn a_feed_hold_stops_the_indexer_and_resume_finishes_it() {
    let hold_ticks = 2_500;
    let op = Operator { hold_at: Some(JOB.ticks_unheld() / 3), hold_ticks, estop_at: None };
    let mut s = IndexerScenario::new(config(Case::EStop), JOB, op).unwrap();
    let r = run_to_end(&mut s, MAX_TICKS);
    assert_eq!(r.fault, 0);
    assert_eq!(s.machine().state(), MachineState::Ready);
    assert_eq!(r.figure("position_steps"), Some(JOB.total_steps() as i64));
    assert_eq!(r.figure("held_ticks"), Some(hold_ticks as i64));
    assert_eq!(r.ticks, JOB.ticks_unheld() + hold_ticks, "the hold only delays the job");
}

#[test]
fn an_estop_freezes_the_indexer_the_same_tick() {
    let op = Operator { estop_at: Some(JOB.ticks_unheld() / 2), ..Operator::default() };
    let mut s = IndexerScenario::new(config(Case::EStop), JOB, op).unwrap();
    let r = run_to_end(&mut s, MAX_TICKS);
    assert_eq!(r.fault, FaultCode::EStop.code());
    assert_eq!(s.machine().state(), MachineState::Fault);
    assert_eq!(r.figure("moved_after_estop"), Some(0));
    let x = r.figure("position_steps").unwrap();
    assert!(x > 0 && x < JOB.total_steps() as i64, "stopped part way: {x}");
}
