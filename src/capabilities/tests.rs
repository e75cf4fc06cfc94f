use super::*;
use crate::capability::{check, Capability, RegistryError};
use crate::scenario::Scenario as _;

#[test]
fn the_registry_is_consistent() {
    assert_eq!(check(&REGISTRY), Ok(()));
    let names: heapless::Vec<&str, 8> = REGISTRY.iter().map(|c| c.name).collect();
    assert_eq!(names.as_slice(), ["polar", "turning", "milling", "wire"]);
}

#[test]
fn every_source_job_and_capability_fault_has_one_owner() {
    for c in REGISTRY {
        for &j in c.jobs {
            assert_eq!(owner_of_job(j).map(|o| o.name), Some(c.name));
        }
        for &f in c.faults {
            assert_eq!(owner_of_fault(f).map(|o| o.name), Some(c.name));
        }
    }
    // Machine faults belong to no capability.
    assert!(owner_of_fault(FaultCode::EStop).is_none());
    assert!(owner_of_fault(FaultCode::QueueUnderrun).is_none());
    assert_eq!(owner_of_fault(FaultCode::WireStall).map(|c| c.name), Some("wire"));
}

#[test]
fn check_refuses_every_kind_of_clash() {
    const A: Capability = Capability {
        name: "alpha",
        title: "",
        hello_bits: 1 << 20,
        jobs: &[SourceJob(40)],
        faults: &[FaultCode::ForceTrip],
    };
    const SAME_NAME: Capability = Capability { hello_bits: 1 << 21, jobs: &[], faults: &[], ..A };
    const SAME_BIT: Capability = Capability { name: "beta", jobs: &[], faults: &[], ..A };
    const SAME_JOB: Capability = Capability { name: "beta", hello_bits: 1 << 21, faults: &[], ..A };
    const SAME_FAULT: Capability = Capability { name: "beta", hello_bits: 1 << 21, jobs: &[], ..A };
    const TWICE: Capability = Capability { jobs: &[SourceJob(5), SourceJob(5)], ..A };
    const BAD: Capability = Capability { name: "Beta2", ..A };
    const NO_BIT: Capability = Capability { hello_bits: 0, ..A };
    assert_eq!(check(&[&A, &SAME_NAME]), Err(RegistryError::SameName("alpha")));
    assert_eq!(check(&[&A, &SAME_BIT]), Err(RegistryError::SameHelloBit("alpha", "beta")));
    assert_eq!(
        check(&[&A, &SAME_JOB]),
        Err(RegistryError::SameJob("alpha", "beta", SourceJob(40)))
    );
    assert_eq!(
        check(&[&A, &SAME_FAULT]),
        Err(RegistryError::SameFault("alpha", "beta", FaultCode::ForceTrip))
    );
    assert_eq!(check(&[&TWICE]), Err(RegistryError::SameJob("alpha", "alpha", SourceJob(5))));
    assert_eq!(check(&[&BAD]), Err(RegistryError::BadName("Beta2")));
    assert_eq!(check(&[&NO_BIT]), Err(RegistryError::NoHelloBit("alpha")));
    // The real entries plus one that claims a real tag.
    let clash: [&Capability; 5] = [
        REGISTRY[0],
        REGISTRY[1],
        REGISTRY[2],
        REGISTRY[3],
        &Capability { jobs: &[crate::turning::TURNING_JOB], ..A },
    ];
    assert_eq!(
        check(&clash),
        Err(RegistryError::SameJob("turning", "alpha", crate::turning::TURNING_JOB))
    );
}

#[test]
fn every_scenario_is_the_machines_or_one_capabilitys() {
    use crate::scenarios::AnyScenario;
    for i in 0..crate::scenarios::COUNT {
        let s = crate::scenarios::build(i).expect("listed");
        let is_core = matches!(
            s,
            AnyScenario::OverrideSweep(_) | AnyScenario::Fault(_) | AnyScenario::LaneKernel(_)
        );
        let name = s.name();
        let owners = REGISTRY.iter().filter(|c| c.owns_scenario(name)).count();
        assert_eq!(owners, usize::from(!is_core), "{name}");
    }
}

#[test]
fn a_board_runs_the_capabilities_it_announces() {
    use crate::protocol::{CAP_DDA, CAP_EVENTS, CAP_TURNING_JOB};
    let names: heapless::Vec<&str, 8> =
        on_board(CAP_DDA | CAP_EVENTS | CAP_TURNING_JOB).map(|c| c.name).collect();
    assert_eq!(names.as_slice(), ["polar", "turning"]);
    assert_eq!(by_name("milling").map(|c| c.hello_bits), Some(crate::protocol::CAP_MILLING_JOB));
    assert!(by_name("toy").is_none());
}
