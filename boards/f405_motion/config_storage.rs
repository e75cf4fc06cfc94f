//! The persisted board config: `motion::machine::persist::ConfigStore` over flash sectors 2-3
//! (`flash.rs`), one 16 KiB sector per slot.

use super::flash::{ConfigFlash, SECTOR_BYTES};
use motion::machine::persist::{ConfigStore, LoadError, SaveError};
use motion::machine::{BoardConfig, BootConfig};
use stm32f4::stm32f405 as pac;

pub struct ConfigStorage {
    store: Option<ConfigStore<ConfigFlash>>,
}

impl ConfigStorage {
    /// This board keeps its config across power cycles.
    pub const PERSISTS: bool = true;

    pub fn new(regs: pac::FLASH) -> Self {
        ConfigStorage { store: ConfigStore::new(ConfigFlash::new(regs), 0, SECTOR_BYTES).ok() }
    }

    /// The stored config, or why there is none (the machine boots with safe defaults and
    /// `ConfigMissing` then).
    pub fn load(&mut self) -> Result<BoardConfig, BootConfig> {
        let store = self.store.as_mut().ok_or(BootConfig::Corrupt)?;
        store.load().map_err(|e| match e {
            LoadError::Missing => BootConfig::Missing,
            LoadError::Corrupt | LoadError::Flash => BootConfig::Corrupt,
        })
    }

    /// Saves `cfg` as the next generation (the old record survives a power cut mid-save).
    /// Stalls every flash fetch for a sector erase: call only with the machine at rest.
    pub fn save(&mut self, cfg: &BoardConfig) -> Result<(), SaveError> {
        self.store.as_mut().ok_or(SaveError::Geometry)?.save(cfg)
    }
}
