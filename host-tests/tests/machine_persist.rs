//! The config record in NOR flash: round trip, missing, corrupt, generations, and power cuts at
//! every byte of a save (the old record survives or the new one is complete; never garbage).

use motion::dda::Dda;
use motion::machine::persist::{ConfigStore, LoadError, RECORD_AREA};
use motion::machine::ram_flash::NorFlash;
use motion::machine::ram_flash::{RamFlash, RamFlashError};
use motion::machine::{BoardConfig, BootConfig, Machine, MachineCommand, MachineState, Refusal};
use motion::protocol::FaultCode;
use motion::scenarios::faults::{config, Case};

const SLOT: u32 = 1024;
type Flash = RamFlash<4096, 1024>;

fn store() -> ConfigStore<Flash> {
    ConfigStore::new(Flash::new(), 1024, SLOT).unwrap()
}

#[test]
fn round_trip_and_generations() {
    let mut s = store();
    assert_eq!(s.load(), Err(LoadError::Missing));
    let a = config(Case::EStop);
    let b = config(Case::HomingOk);
    s.save(&a).unwrap();
    assert_eq!(s.load(), Ok(a));
    s.save(&b).unwrap();
    assert_eq!(s.load(), Ok(b));
    s.save(&a).unwrap();
    assert_eq!(s.load(), Ok(a));
    // Three saves alternate the two slots: two erases of the slot area, never outside it.
    assert_eq!(s.flash().erases, 3);
    assert!(s.flash().bytes()[..1024].iter().all(|&x| x == 0xFF));
    assert!(s.flash().bytes()[3072..].iter().all(|&x| x == 0xFF));
}

#[test]
fn the_mock_enforces_nor_rules() {
    let mut f = Flash::new();
    f.write(0, &[0, 1, 2, 3]).unwrap();
    assert_eq!(f.write(0, &[0, 1, 2, 3]), Err(RamFlashError::NotErased { offset: 0 }));
    assert_eq!(f.write(2, &[0; 4]), Err(RamFlashError::NotAligned));
    assert_eq!(f.erase(0, 512), Err(RamFlashError::NotAligned));
    f.erase(0, 1024).unwrap();
    f.write(0, &[9; 4]).unwrap();
}

#[test]
fn corrupt_newest_falls_back_and_corrupt_only_reports_corrupt() {
    let a = config(Case::EStop);
    let b = config(Case::HomingOk);
    let mut s = store();
    s.save(&a).unwrap();
    s.save(&b).unwrap();
    // b went to the second slot; flip a payload bit there.
    s.flash().corrupt(1024 + SLOT as usize + 20, 0x10);
    assert_eq!(s.load(), Ok(a));
    let mut s = store();
    s.save(&a).unwrap();
    s.flash().corrupt(1024 + 30, 0x01);
    assert_eq!(s.load(), Err(LoadError::Corrupt));
}

#[test]
fn power_cut_at_every_byte_of_a_save_never_yields_garbage() {
    let a = config(Case::EStop);
    let b = config(Case::HomingOk);
    // Bytes one save changes: the slot erase plus the record body and the commit word.
    let total = SLOT as usize + RECORD_AREA;
    let (mut old_seen, mut new_seen) = (0, 0);
    for cut in 0..total {
        let mut s = store();
        s.save(&a).unwrap();
        s.flash().cut_power_after(cut);
        let _ = s.save(&b);
        s.flash().restore_power();
        match s.load() {
            Ok(c) if c == a => old_seen += 1,
            Ok(c) if c == b => new_seen += 1,
            other => panic!("cut at byte {cut}: {other:?}"),
        }
    }
    assert!(old_seen > 0 && new_seen > 0, "old {old_seen} new {new_seen}");
    // With no old record a cut leaves "missing"/"corrupt" or the complete new one.
    for cut in (0..total).step_by(7) {
        let mut s = store();
        s.flash().cut_power_after(cut);
        let _ = s.save(&b);
        s.flash().restore_power();
        match s.load() {
            Ok(c) => assert_eq!(c, b),
            Err(e) => assert!(matches!(e, LoadError::Missing | LoadError::Corrupt), "{e:?}"),
        }
    }
}

#[test]
fn boot_with_a_corrupt_record_uses_safe_defaults_and_says_so() {
    let mut s = store();
    s.save(&config(Case::EStop)).unwrap();
    s.flash().corrupt(1024 + 40, 0xFF);
    let loaded = s.load().map_err(LoadError::boot);
    assert_eq!(loaded, Err(BootConfig::Corrupt));
    let mut m = Machine::new();
    assert_eq!(m.boot(loaded), MachineState::Fault);
    // The fault says corrupt, not missing.
    assert_eq!(m.faults().first(), Some(FaultCode::ConfigCorrupt));
    assert!(!m.faults().has(FaultCode::ConfigMissing));
    assert_eq!(*m.config(), motion::machine::BoardConfig::safe_default());
    // The defaults allow no travel at all.
    assert_eq!(m.config().link.scale[0].soft_max, 0);
}

/// Missing (erased flash, as QEMU's reads), corrupt (a bit flipped), invalid (a complete record
/// whose values fail validation): each boots into Fault with safe defaults and the code that
/// names it, refuses motion, and refuses ClearFault until a valid SetConfig replaced it.
#[test]
fn missing_corrupt_and_invalid_each_latch_their_own_code_until_a_valid_config() {
    let good = config(Case::EStop);
    let mut invalid = good;
    invalid.link.machine.tick_hz = 0;
    assert!(invalid.validate().is_err());
    type Prepare = fn(&mut ConfigStore<Flash>, &BoardConfig);
    let cases: [(&str, Prepare, FaultCode); 3] = [
        ("missing", |_, _| {}, FaultCode::ConfigMissing),
        (
            "corrupt",
            |s, c| {
                s.save(c).unwrap();
                s.flash().corrupt(1024 + 20, 0x04);
            },
            FaultCode::ConfigCorrupt,
        ),
        ("invalid", |s, c| s.save(c).unwrap(), FaultCode::ConfigCorrupt),
    ];
    for (name, prepare, code) in cases {
        let mut s = store();
        prepare(&mut s, &invalid);
        let loaded = s.load().map_err(LoadError::boot);
        if name == "invalid" {
            // The record itself is intact: the machine's validation rejects it.
            assert_eq!(loaded, Ok(invalid), "{name}");
        }
        let mut m = Machine::new();
        assert_eq!(m.boot(loaded), MachineState::Fault, "{name}");
        assert_eq!(m.faults().mask(), code.bit(), "{name}: exactly its own code");
        assert_eq!(m.active_causes(), code.bit(), "{name}: a level until a valid config");
        let mc = m.config().link.machine;
        let mut dda = Dda::new(&mc).unwrap();
        assert_eq!(
            m.command(MachineCommand::ClearFault, &mut dda),
            Err(Refusal::CauseActive(code)),
            "{name}"
        );
        assert!(m.command(MachineCommand::Home, &mut dda).is_err(), "{name}: no motion");
        m.set_config(&good).unwrap();
        assert_eq!(m.active_causes(), 0, "{name}");
        assert_eq!(m.command(MachineCommand::ClearFault, &mut dda), Ok(MachineState::Idle));
        assert_eq!(*m.config(), good);
    }
}

#[test]
fn the_following_limits_persist_with_the_record() {
    let cfg = config(Case::FollowingError);
    assert!(cfg.following.enabled());
    let mut s = store();
    s.save(&cfg).unwrap();
    assert_eq!(s.load().map(|c| c.following), Ok(cfg.following));
}
