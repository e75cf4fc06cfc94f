//! The stored config of the QEMU board: QEMU's flash is read-only ROM, so the config record lives
//! in a NOR-flash model (`motion::machine::ram_flash::RamFlash`, NOR's erase and write rules)
//! in RAM the runtime does not zero (`.uninit`). QEMU keeps RAM across a `system_reset`, so the
//! record survives a board reset as it would in flash, and is lost when QEMU stops (a power
//! cut loses it, where real flash would keep it: then the board boots with `ConfigMissing`).

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

#[repr(C)]
struct Region {
    magic: u32,
    flash: Flash,
}

#[link_section = ".uninit.CONFIG_RAM_FLASH"]
static mut REGION: MaybeUninit<Region> = MaybeUninit::uninit();

/// The QEMU board's [`ConfigStorage`].
pub struct RamConfig {
    store: FlashConfig<&'static mut Flash>,
}

impl RamConfig {
    /// Takes the region: an erased flash on QEMU's first boot, else what the last run left.
    /// Call once, at boot.
    pub fn take() -> RamConfig {
        let region = addr_of_mut!(REGION).cast::<Region>();
        // SAFETY: called once at boot before interrupts run, so this is the only access. The
        // magic is read as a plain integer (any bit pattern is valid); the flash is used
        // only after `magic` says this firmware wrote a valid one there.
        let flash = unsafe {
            if addr_of!((*region).magic).read_volatile() != MAGIC {
                region.write(Region { magic: MAGIC, flash: Flash::new() });
            }
            &mut *addr_of_mut!((*region).flash)
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
}
