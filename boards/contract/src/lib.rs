//! The Board contract: what the firmware needs from a board, as traits the board crates
//! (`boards/netduinoplus2`, `boards/f405-motion`) implement and the firmware crate uses,
//! the way grblHAL's `hal.h` or embassy's HALs keep the chip out of the core. Pure logic
//! that serves every board (debouncing, the pin-by-pin step port, config persistence over any
//! NOR flash) lives here too, host-tested.
//!
//! | part | trait | edges |
//! | --- | --- | --- |
//! | DDA tick | [`TickTimer`], [`TickRate`] | start/stop/clear/update pending; retime, supported rates |
//! | step/dir/enable | [`StepPort`] | one store-level word write per tick; [`PinStepPort`] over `OutputPin`s |
//! | streamed steps | [`StepStream`] | a half buffer of set/reset words per fill interrupt (timer + DMA) |
//! | e-stop, limits, probe, outputs | [`MachineIo`], [`EStopLine`] | read raw (the machine debounces limits and e-stop); the probe through [`Debounced`] |
//! | host link | [`HostSerial`] | bytes in/out, interrupts |
//! | watchdog | [`Watchdog`] | start, feed, stretch |
//! | config persistence | [`ConfigStorage`] | [`FlashConfig`] over `embedded_storage::nor_flash::NorFlash` |
//! | spindle encoder | [`SpindleEncoder`] | `motion::spindle::SpindleSource` |
//! | copy encoders | [`CopyEncoders`] | two counts per tick |
//! | force ADC | [`ForceAdc`] | half-buffer frames per interrupt |
//! | reset cause, cycle counter, log/exit | [`Parts::reset`], [`CycleCounter`], [`Board::exit`] | the board crate links the defmt logger |
#![no_std]

#[cfg(test)]
extern crate std;

pub mod debounce;
mod io;
mod persist;
mod sensors;
mod serial;
mod step;
mod tick;

pub use debounce::{Debounced, DebouncedBank, Debouncer};
pub use io::{EStopLine, MachineIo, RawInputs};
pub use persist::{ConfigStorage, FlashConfig, NoConfigStorage};
pub use sensors::{
    CopyEncoders, CycleCounter, ForceAdc, ForceFrame, NoForceAdc, SpindleEncoder,
    FORCE_CHANNEL_COUNT,
};
pub use serial::HostSerial;
pub use step::{PinStepPort, StepPort, StepStream, STREAM_SLOTS};
pub use tick::{TickRate, TickTimer, Watchdog};

use motion::machine::ResetCause;

/// A board: its parts' types, how to bring them up, how to end a run.
pub trait Board: Sized {
    /// Reported in the boot line and `HelloInfo`.
    const NAME: &'static str;
    /// Host link baud rate.
    const HOST_BAUD: u32;
    /// A job (Running or Holding) with no valid frame from the host for this long, in the
    /// board's own milliseconds, is a lost link: the machine holds and latches `LinkLost`.
    const LINK_TIMEOUT_MS: u64;
    /// The chip's peripherals (the PAC's `Peripherals`) and the core's.
    type Device;
    type Core;
    type TickTimer: TickTimer<Rate = Self::TickRate>;
    type TickRate: TickRate;
    type StepPort: StepPort;
    type EStop: EStopLine;
    type MachineIo: MachineIo;
    type HostSerial: HostSerial;
    type Watchdog: Watchdog;
    type ConfigStorage: ConfigStorage;
    type CopyEncoders: CopyEncoders;
    type ForceAdc: ForceAdc;
    type Spindle: SpindleEncoder;
    type CycleCounter: CycleCounter;
    /// Whatever else the board builds (drivers no firmware task uses yet).
    type Extras;

    /// Clocks, pins and every part, configured and idle (drivers disabled, timer stopped, the
    /// tick timer set to `tick_hz`).
    fn init(device: Self::Device, core: &mut Self::Core, tick_hz: u32) -> Parts<Self>;

    /// Ends the run with the outputs safe: QEMU exits (status 0 when `ok`); a real board halts
    /// for the debugger or parks.
    fn exit(ok: bool) -> !;
}

/// Everything [`Board::init`] hands the firmware.
pub struct Parts<B: Board> {
    /// Why the chip reset (read at init, before anything could change it).
    pub reset: ResetCause,
    pub tick_timer: B::TickTimer,
    pub step_port: B::StepPort,
    pub estop: B::EStop,
    pub io: B::MachineIo,
    pub host: B::HostSerial,
    /// Not started: the firmware that wants it starts it.
    pub watchdog: B::Watchdog,
    pub config: B::ConfigStorage,
    pub copy_encoders: B::CopyEncoders,
    /// `None` where the board has none (or init ran twice).
    pub force_adc: Option<B::ForceAdc>,
    pub spindle: B::Spindle,
    pub cycles: B::CycleCounter,
    pub extras: B::Extras,
}
