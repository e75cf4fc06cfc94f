//! The scenario firmware: runs every closed-loop scenario of `motion::scenarios` in turn, each
//! stepped by the TIM2 interrupt at its own tick rate, and prints each report over defmt. The sim
//! board inside each scenario stands in for the sensors and records the step outputs, so QEMU
//! (which models no GPIO, ADC signal or encoder) runs the same control code as a machine would,
//! and xtask compares every report with the host model's, line for line.
//!
//! Priorities: `tick` (TIM2, 3) advances the active scenario by one tick; `runner` (1) builds the
//! next scenario, sets the tick rate, starts the timer, runs the planning-rate work a scenario
//! asks for (the tick waits for it) and prints the report when the tick says the scenario has
//! finished.
#![no_std]
#![no_main]

#[cfg(all(feature = "board-netduinoplus2", feature = "board-f405-motion"))]
compile_error!("select exactly one board feature");

#[cfg_attr(feature = "board-netduinoplus2", path = "../boards/netduinoplus2/mod.rs")]
#[cfg_attr(feature = "board-f405-motion", path = "../boards/f405_motion/mod.rs")]
// The scenario firmware uses only the board's tick timer: the sim board inside each scenario
// stands in for pins and sensors.
#[allow(dead_code, unused_imports)]
mod board;

/// Under QEMU each timer interrupt runs a batch of scenario ticks back to back, and the timer
/// fires faster than a batch can finish, so the CPU never sleeps: QEMU (`-icount`, `sleep=off`)
/// spends far more wall time delivering an interrupt than running a tick. A scenario's outcome
/// depends only on its own tick count, never on the timer, so this changes nothing but the wall
/// time. On hardware every interrupt is one tick at the scenario's rate.
const QEMU_TICK_HZ: u32 = 1_000_000;
const TICKS_PER_IRQ: u32 = if cfg!(feature = "board-netduinoplus2") { 256 } else { 1 };

/// Tick rate the timer starts with; every scenario sets its own before the timer runs.
const INITIAL_TICK_HZ: u32 = 10_000;

#[rtic::app(device = stm32f4::stm32f405, dispatchers = [SPI2])]
mod app {
    use super::{board, INITIAL_TICK_HZ, QEMU_TICK_HZ, TICKS_PER_IRQ};
    use core::sync::atomic::Ordering::Relaxed;
    use motion::scenario::Scenario;
    use motion::scenarios::{self, AnyScenario};
    use rtic_sync::make_signal;
    use rtic_sync::signal::{SignalReader, SignalWriter};

    #[shared]
    struct Shared {
        active: Option<AnyScenario>,
        tick_timer: board::TickTimer,
    }

    /// What the tick tells the runner.
    #[derive(Clone, Copy)]
    pub enum Event {
        /// The scenario wants planning-rate work before its next tick.
        Background,
        Finished,
    }

    #[local]
    struct Local {
        rate: board::TickRate,
        events: SignalWriter<'static, Event>,
        wait_event: SignalReader<'static, Event>,
        /// A background request is out; the tick does not repeat it.
        asked: &'static core::sync::atomic::AtomicBool,
    }

    #[init]
    fn init(mut cx: init::Context) -> (Shared, Local) {
        let board::Board { tick_timer, .. } = board::init(cx.device, &mut cx.core, INITIAL_TICK_HZ);
        defmt::println!(
            "motion-board {=str} board={=str} scenarios={=usize}",
            env!("CARGO_PKG_VERSION"),
            board::NAME,
            scenarios::COUNT
        );
        let rate = tick_timer.rate_control();
        let (events, wait_event) = make_signal!(Event);
        defmt::unwrap!(runner::spawn().ok());
        (Shared { active: None, tick_timer }, Local { rate, events, wait_event, asked: &ASKED })
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }

    static ASKED: core::sync::atomic::AtomicBool = core::sync::atomic::AtomicBool::new(false);

    /// Scenario ticks (see [`TICKS_PER_IRQ`]) until the scenario waits for background work. The
    /// highest priority: its resources need no lock here.
    #[task(binds = TIM2, priority = 3, shared = [active, tick_timer], local = [events, asked])]
    fn tick(cx: tick::Context) {
        let tick::SharedResources { mut active, mut tick_timer, .. } = cx.shared;
        let l = cx.local;
        tick_timer.lock(|t| t.clear_update());
        let event = active.lock(|a| {
            let Some(s) = a.as_mut() else { return Some(Event::Finished) };
            for _ in 0..TICKS_PER_IRQ {
                if s.wants_background() {
                    return Some(Event::Background);
                }
                if !s.tick() {
                    return Some(Event::Finished);
                }
            }
            None
        });
        match event {
            // Asked once; the runner clears `asked` when the work is done.
            Some(Event::Background) if !l.asked.swap(true, Relaxed) => {
                l.events.write(Event::Background);
            }
            Some(Event::Finished) => {
                tick_timer.lock(|t| t.stop());
                l.events.write(Event::Finished);
            }
            _ => {}
        }
    }

    #[task(priority = 1, shared = [active, tick_timer], local = [rate, wait_event])]
    async fn runner(cx: runner::Context) {
        let runner::SharedResources { mut active, mut tick_timer, .. } = cx.shared;
        let mut ok = true;
        for index in 0..scenarios::COUNT {
            let Some(scenario) = scenarios::build(index) else {
                defmt::error!("scenario {=usize} does not build", index);
                ok = false;
                continue;
            };
            let hz = if cfg!(feature = "board-netduinoplus2") {
                QEMU_TICK_HZ
            } else {
                scenario.tick_hz()
            };
            if !cx.local.rate.set(hz) {
                defmt::error!("scenario {=str}: tick {=u32} Hz not supported", scenario.name(), hz);
                ok = false;
                continue;
            }
            active.lock(|a| *a = Some(scenario));
            tick_timer.lock(|t| t.start());
            while let Event::Background = cx.local.wait_event.wait().await {
                active.lock(|a| a.as_mut().map(|s| s.background()));
                ASKED.store(false, Relaxed);
            }
            active.lock(|a| {
                if let Some(s) = a.take() {
                    s.report().write_lines(|line: &str| defmt::println!("{=str}", line));
                }
            });
        }
        defmt::println!("scenarios done");
        board::exit(ok);
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    defmt::error!("{}", defmt::Display2Format(info));
    board::exit(false)
}

#[cortex_m_rt::exception]
unsafe fn HardFault(ef: &cortex_m_rt::ExceptionFrame) -> ! {
    defmt::error!(
        "HardFault: pc={=u32:#010x} lr={=u32:#010x} xpsr={=u32:#010x}",
        ef.pc(),
        ef.lr(),
        ef.xpsr()
    );
    board::exit(false)
}
