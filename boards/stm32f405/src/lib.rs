//! STM32F405 peripherals both boards use the same way: TIM2 as the DDA tick, USART1 as the
//! host serial, the IWDG as the watchdog. Each implements its Board contract trait; only the
//! clocks they run from differ per board.
#![no_std]

mod host_serial;
mod tick_timer;
mod watchdog;

pub use host_serial::HostSerial;
pub use stm32f4::stm32f405 as pac;
pub use tick_timer::{TickRate, TickTimer};
pub use watchdog::Watchdog;
