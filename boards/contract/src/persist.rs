//! Config persistence: the machine's `ConfigStore` over any NOR flash.

use embedded_storage::nor_flash::NorFlash;
use motion::machine::persist::{ConfigStore, LoadError, SaveError};
use motion::machine::{BoardConfig, BootConfig};

pub trait ConfigStorage {
    /// The board keeps a saved config across power cycles.
    const PERSISTS: bool;
    /// The stored config, or why there is none.
    fn load(&mut self) -> Result<BoardConfig, BootConfig>;
    /// Saves `cfg` as the next generation. May stall flash fetches: machine at rest only.
    fn save(&mut self, cfg: &BoardConfig) -> Result<(), SaveError>;
    /// A simulated board's fault test (`Sim(CorruptConfig)`): the stored records read corrupt
    /// from the next boot on, as disturbed flash would. False: not simulated, nothing done.
    fn corrupt_at_next_boot() -> bool {
        false
    }
}

/// [`ConfigStorage`] over a NOR flash region of two slots of `slot_bytes` from offset 0.
pub struct FlashConfig<F> {
    store: Option<ConfigStore<F>>,
}

impl<F: NorFlash> FlashConfig<F> {
    pub fn new(flash: F, slot_bytes: u32) -> Self {
        FlashConfig { store: ConfigStore::new(flash, 0, slot_bytes).ok() }
    }
}

impl<F: NorFlash> ConfigStorage for FlashConfig<F> {
    const PERSISTS: bool = true;

    fn load(&mut self) -> Result<BoardConfig, BootConfig> {
        let store = self.store.as_mut().ok_or(BootConfig::Corrupt)?;
        store.load().map_err(|e| match e {
            LoadError::Missing => BootConfig::Missing,
            LoadError::Corrupt | LoadError::Flash => BootConfig::Corrupt,
        })
    }

    fn save(&mut self, cfg: &BoardConfig) -> Result<(), SaveError> {
        self.store.as_mut().ok_or(SaveError::Geometry)?.save(cfg)
    }
}

/// No persistent storage (QEMU's flash is ROM): always missing at boot, saves ignored.
pub struct NoConfigStorage;

impl ConfigStorage for NoConfigStorage {
    const PERSISTS: bool = false;

    fn load(&mut self) -> Result<BoardConfig, BootConfig> {
        Err(BootConfig::Missing)
    }

    fn save(&mut self, _cfg: &BoardConfig) -> Result<(), SaveError> {
        Ok(())
    }
}
