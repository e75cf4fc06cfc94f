//! The board this build runs on, picked by a cargo feature (`board-netduinoplus2`, the
//! default; `board-f405-motion`, which wins when both are on), seen through the Board
//! contract: the apps name these aliases, never a board crate.

use board_contract::Board as Contract;

#[cfg(feature = "board-f405-motion")]
pub use board_f405_motion::Board as Selected;
#[cfg(all(feature = "board-netduinoplus2", not(feature = "board-f405-motion")))]
pub use board_netduinoplus2::Board as Selected;

#[cfg(not(any(feature = "board-netduinoplus2", feature = "board-f405-motion")))]
compile_error!("select a board: --features board-netduinoplus2 or --features board-f405-motion");

pub type Parts = board_contract::Parts<Selected>;
pub type TickTimer = <Selected as Contract>::TickTimer;
pub type TickRate = <Selected as Contract>::TickRate;
pub type StepPort = <Selected as Contract>::StepPort;
pub type EStop = <Selected as Contract>::EStop;
pub type MachineIo = <Selected as Contract>::MachineIo;
pub type HostSerial = <Selected as Contract>::HostSerial;
pub type Watchdog = <Selected as Contract>::Watchdog;
pub type ConfigStorage = <Selected as Contract>::ConfigStorage;
pub type CopyEncoders = <Selected as Contract>::CopyEncoders;
pub type ForceAdc = <Selected as Contract>::ForceAdc;
pub type Spindle = <Selected as Contract>::Spindle;
pub type CycleCounter = <Selected as Contract>::CycleCounter;

/// The streamed step output (`board_contract::StepStream`), on a board that has one; nothing
/// in a build whose tick writes the port (the app's resource list is the same in both).
// A late fill on a real board lets the DMA play the half's last words again: steps nobody
// asked for. Every machine state's fill must first fit its half at the stream's slot clocks
// (today a state that runs full ticks on every slot does not: BENCHMARKS.md).
#[cfg(all(feature = "step-stream", feature = "board-f405-motion"))]
compile_error!(
    "step-stream runs on the QEMU board only: the F405's TIM1/DMA2 stream waits until every \
     machine state's fill fits its half"
);
#[cfg(all(feature = "step-stream", not(feature = "board-f405-motion")))]
pub use board_netduinoplus2::StepStream;
#[cfg(not(feature = "step-stream"))]
pub type StepStream = ();

pub const NAME: &str = <Selected as Contract>::NAME;
pub const HOST_BAUD: u32 = <Selected as Contract>::HOST_BAUD;
pub const LINK_TIMEOUT_MS: u64 = <Selected as Contract>::LINK_TIMEOUT_MS;
/// QEMU's board, whose sensors are simulated (force jobs sample a plant; its timer
/// does not pace the scenario firmware: see `bin/scenarios.rs`).
pub const SIMULATED: bool =
    cfg!(all(feature = "board-netduinoplus2", not(feature = "board-f405-motion")));

/// The force job's interrupt (priority 3, the tick's): the real board's ADC DMA stream; the
/// simulator board's tick pends it for each plant sample, so both run the force chain outside
/// the tick handler.
pub const FORCE_IRQ: stm32f4::stm32f405::Interrupt = stm32f4::stm32f405::Interrupt::DMA2_STREAM0;

/// Brings the board up (see `board_contract::Board::init`).
pub fn init(
    device: <Selected as Contract>::Device,
    core: &mut <Selected as Contract>::Core,
    tick_hz: u32,
) -> Parts {
    <Selected as Contract>::init(device, core, tick_hz)
}

/// Ends the run with the outputs safe.
pub fn exit(ok: bool) -> ! {
    <Selected as Contract>::exit(ok)
}
