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

// The streamed step output changes what the board's tick timer is (the fill interrupt): only
// the link firmware has the fill.
#[cfg(feature = "step-stream")]
compile_error!("step-stream is the link firmware's: build this firmware without it");

// The scenario firmware uses only the board's tick timer and cycle counter: the sim board
// inside each scenario stands in for pins and sensors.
use motion_firmware::board;

/// Under QEMU the timer does not pace the scenario: the runner pends the TIM2 interrupt itself and
/// each interrupt runs a batch of ticks and pends the next, so ticks run back to back and the CPU
/// never sleeps. QEMU (`-icount`, `sleep=off`) spends far more wall time delivering a timer
/// interrupt than running a tick, and its STM32 timer model stops firing once a handler
/// outlasts a few timer periods. A scenario's outcome depends only on its own tick count, never
/// on the timer, so this changes nothing but the wall time. On hardware every timer interrupt
/// is one tick at the scenario's rate.
const SELF_PACED: bool = board::SIMULATED;
const TICKS_PER_IRQ: u32 = if SELF_PACED { 256 } else { 1 };

/// Tick rate the timer starts with; every scenario sets its own before the timer runs.
const INITIAL_TICK_HZ: u32 = 10_000;

#[rtic::app(device = stm32f4::stm32f405, dispatchers = [SPI2])]
mod app {
    use super::{board, INITIAL_TICK_HZ, SELF_PACED, TICKS_PER_IRQ};
    use board_contract::{CycleCounter as _, TickRate as _, TickTimer as _};
    use motion::scenario::Scenario;
    use motion::scenarios::{self, AnyScenario};
    use rtic_sync::make_signal;
    use rtic_sync::signal::{SignalReader, SignalWriter};
    use stm32f4::stm32f405::Interrupt;

    #[shared]
    struct Shared {
        active: Option<AnyScenario>,
        /// Who owns the next step of the active scenario. Only the tick moves it out of
        /// `Running`, only the runner moves it back, so a late or repeated timer interrupt (one
        /// can be pending while the tick stops the timer) never ticks or reports twice.
        phase: Phase,
        tick_timer: board::TickTimer,
        /// Cycles (under QEMU: instructions) the tick spent in the active scenario, and its ticks.
        cost: Cost,
    }

    #[derive(Clone, Copy, Default)]
    pub struct Cost {
        cycles: u64,
        ticks: u64,
    }

    #[derive(Clone, Copy, PartialEq, Eq)]
    pub enum Phase {
        /// No scenario, or one being built or reported.
        Idle,
        /// The tick advances the scenario.
        Running,
        /// The scenario waits for planning-rate work: the runner's turn.
        Background,
        /// The scenario has ended: the runner reports it.
        Finished,
    }

    #[local]
    struct Local {
        rate: board::TickRate,
        wake_runner: SignalWriter<'static, ()>,
        runner_waits: SignalReader<'static, ()>,
        cycles: board::CycleCounter,
    }

    #[init]
    fn init(mut cx: init::Context) -> (Shared, Local) {
        let board::Parts { tick_timer, cycles, .. } =
            board::init(cx.device, &mut cx.core, INITIAL_TICK_HZ);
        defmt::println!(
            "motion-board {=str} board={=str} scenarios={=usize} slot={=usize}",
            env!("CARGO_PKG_VERSION"),
            board::NAME,
            scenarios::COUNT,
            core::mem::size_of::<AnyScenario>()
        );
        let rate = tick_timer.rate_control();
        let (wake_runner, runner_waits) = make_signal!(());
        defmt::unwrap!(runner::spawn().ok());
        (
            Shared { active: None, phase: Phase::Idle, tick_timer, cost: Cost::default() },
            Local { rate, wake_runner, runner_waits, cycles },
        )
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// Scenario ticks (see [`TICKS_PER_IRQ`]) until the scenario waits for background work. The
    /// highest priority: its resources need no lock here.
    #[task(binds = TIM2, priority = 3, shared = [active, phase, tick_timer, cost],
        local = [wake_runner, cycles])]
    fn tick(cx: tick::Context) {
        let tick::SharedResources { mut active, mut phase, mut tick_timer, mut cost, .. } =
            cx.shared;
        let l = cx.local;
        tick_timer.lock(|t| t.clear_update());
        if phase.lock(|p| *p) != Phase::Running {
            return;
        }
        let start = l.cycles.now();
        let mut ticks = 0;
        let next = active.lock(|a| {
            let Some(s) = a.as_mut() else { return Phase::Finished };
            for _ in 0..TICKS_PER_IRQ {
                if s.wants_background() {
                    return Phase::Background;
                }
                if !s.tick() {
                    return Phase::Finished;
                }
                ticks += 1;
            }
            Phase::Running
        });
        let spent = l.cycles.now().wrapping_sub(start);
        cost.lock(|c| {
            c.cycles += spent as u64;
            c.ticks += ticks;
        });
        if next != Phase::Running {
            if next == Phase::Finished {
                tick_timer.lock(|t| t.stop());
            }
            phase.lock(|p| *p = next);
            l.wake_runner.write(());
        } else if SELF_PACED {
            rtic::pend(Interrupt::TIM2);
        }
    }

    /// Hands the scenario to the tick: the timer paces it, or (self-paced) one pend starts it.
    fn start(
        phase: &mut impl rtic::Mutex<T = Phase>,
        tick_timer: &mut impl rtic::Mutex<T = board::TickTimer>,
    ) {
        phase.lock(|p| *p = Phase::Running);
        if SELF_PACED {
            rtic::pend(Interrupt::TIM2);
        } else {
            tick_timer.lock(|t| t.start());
        }
    }

    #[task(priority = 1, shared = [active, phase, tick_timer, cost], local = [rate, runner_waits])]
    async fn runner(cx: runner::Context) {
        let runner::SharedResources { mut active, mut phase, mut tick_timer, mut cost, .. } =
            cx.shared;
        let mut ok = true;
        for index in 0..scenarios::COUNT {
            let Some(scenario) = scenarios::build(index) else {
                defmt::error!("scenario {=usize} does not build", index);
                ok = false;
                continue;
            };
            let hz = scenario.tick_hz();
            if !SELF_PACED && !cx.local.rate.set(hz) {
                defmt::error!("scenario {=str}: tick {=u32} Hz not supported", scenario.name(), hz);
                ok = false;
                continue;
            }
            active.lock(|a| *a = Some(scenario));
            cost.lock(|c| *c = Cost::default());
            start(&mut phase, &mut tick_timer);
            loop {
                cx.local.runner_waits.wait().await;
                match phase.lock(|p| *p) {
                    Phase::Background => {
                        active.lock(|a| a.as_mut().map(|s| s.background()));
                        start(&mut phase, &mut tick_timer);
                    }
                    Phase::Finished => break,
                    // A wake from before the last phase change: nothing to do.
                    Phase::Running | Phase::Idle => {}
                }
            }
            phase.lock(|p| *p = Phase::Idle);
            active.lock(|a| {
                if let Some(s) = a.take() {
                    s.report().write_lines(|line: &str| defmt::println!("{=str}", line));
                    // Not part of the report: the host model has no cycle counter.
                    let c = cost.lock(|c| *c);
                    defmt::println!(
                        "scenario_cost name={=str} ticks={=u64} cycles={=u64}",
                        s.name(),
                        c.ticks,
                        c.cycles
                    );
                }
            });
        }
        defmt::println!("scenarios done");
        board::exit(ok);
    }
}
