//! The stored config of the QEMU board: QEMU's flash is read-only ROM, so the config record lives
//! in a NOR-flash model (`motion::machine::ram_flash::RamFlash`, NOR's erase and write rules)
//! in RAM the runtime does not zero (`.uninit`). QEMU keeps RAM across a `system_reset`, so the
//! record survives a board reset as it would in flash, and is lost when QEMU stops (a power
//! cut loses it, where real flash would keep it: then the board boots with `ConfigMissing`).
//!
//! The fault tests corrupt it (`Sim(CorruptConfig)`): every slot gets a flipped byte at the
//! next boot, as disturbed flash cells would, and the board must boot into `ConfigCorrupt`.

use core::mem::MaybeUninit;
use core::ptr::{addr_of, addr_of_mut};

use board_contract::{ConfigStorage, FlashConfig};
use motion::machine::persist::SaveError;
use motion::machine::ram_flash::RamFlash;
use motion::machine::{BoardConfig, BootConfig};

/// One erase block per slot, two slots (the store's two generations).
const SLOT_BYTES: usize = 1024;
const SLOTS: usize = 2;
type Flash = RamFlash<{ SLOT_BYTES * SLOTS }, SLOT_BYTES>;

/// Marks a region this firmware set up: anything else (QEMU's zeroed RAM at start-up) is
/// replaced by an erased flash.
const MAGIC: u32 = 0x4346_4731;
/// `corrupt_at_boot` when the host asked for corruption.
const CORRUPT: u32 = 0xBAD0_C0DE;
/// Where in each slot the flipped byte goes: inside the record's header, so no record
/// survives it.
const CORRUPT_OFFSET: usize = 4;

#[repr(C)]
struct Region {
    magic: u32,
    corrupt_at_boot: u32,
    flash: Flash,
}

#[link_section = ".uninit.CONFIG_RAM_FLASH"]
static mut REGION: MaybeUninit<Region> = MaybeUninit::uninit();

/// The QEMU board's [`ConfigStorage`].
pub struct RamConfig {
    store: FlashConfig<&'static mut Flash>,
}

impl RamConfig {
    /// Takes the region: an erased flash on QEMU's first boot, else what the last run left
    /// (corrupted first if the host asked). Call once, at boot.
    pub fn take() -> RamConfig {
        let region = addr_of_mut!(REGION).cast::<Region>();
        // SAFETY: called once at boot before interrupts run, so this is the only access. The
        // two words are read as plain integers (any bit pattern is valid); the flash is used
        // only after `magic` says this firmware wrote a valid one there.
        let flash = unsafe {
            if addr_of!((*region).magic).read_volatile() != MAGIC {
                region.write(Region { magic: MAGIC, corrupt_at_boot: 0, flash: Flash::new() });
            }
            let flash = &mut *addr_of_mut!((*region).flash);
            if addr_of!((*region).corrupt_at_boot).read_volatile() == CORRUPT {
                addr_of_mut!((*region).corrupt_at_boot).write_volatile(0);
                for slot in 0..SLOTS {
                    flash.corrupt(slot * SLOT_BYTES + CORRUPT_OFFSET, 0x5A);
                }
            }
            flash
        };
        RamConfig { store: FlashConfig::new(flash, SLOT_BYTES as u32) }
    }
}

impl ConfigStorage for RamConfig {
    /// Across resets (QEMU keeps its RAM), not across a power cut.
    const PERSISTS: bool = true;

    fn load(&mut self) -> Result<BoardConfig, BootConfig> {
        self.store.load()
    }

    fn save(&mut self, cfg: &BoardConfig) -> Result<(), SaveError> {
        self.store.save(cfg)
    }

    fn corrupt_at_next_boot() -> bool {
        let region = addr_of_mut!(REGION).cast::<Region>();
        // SAFETY: one aligned word of the region, written whole; the flash part (which the
        // status task may be using) is not touched. Read back only at boot.
        unsafe { addr_of_mut!((*region).corrupt_at_boot).write_volatile(CORRUPT) };
        true
    }
}
