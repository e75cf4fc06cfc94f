//! The benchmark firmware: the DDA and capability micro-benchmarks (`motion_firmware::bench`)
//! in one low-priority task, figures as `bench key=value` lines over defmt, then exit. The
//! tick timer is never started: nothing preempts the measurements.
#![no_std]
#![no_main]

use motion_firmware::board;

#[rtic::app(device = stm32f4::stm32f405, dispatchers = [SPI2])]
mod app {
    use super::board;
    use motion::demo_job;
    use motion_firmware::step::RecordedPort;

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        step_port: RecordedPort,
        cycles: board::CycleCounter,
    }

    #[init]
    fn init(mut cx: init::Context) -> (Shared, Local) {
        let cfg = demo_job::config();
        let board::Parts { step_port, cycles, .. } =
            board::init(cx.device, &mut cx.core, cfg.tick_hz);
        defmt::println!(
            "motion-board {=str} board={=str} bench",
            env!("CARGO_PKG_VERSION"),
            board::NAME
        );
        defmt::unwrap!(run::spawn().ok());
        (Shared {}, Local { step_port: RecordedPort::new(step_port), cycles })
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }

    #[task(priority = 1, local = [step_port, cycles])]
    async fn run(cx: run::Context) {
        motion_firmware::bench::run(cx.local.cycles, cx.local.step_port);
        board::exit(true);
    }
}
