//! The link firmware (the product): an RTIC 2 app that serves the host link on USART1
//! (`src/protocol/PROTOCOL.md`) and runs what the host sends through `motion::machine::Machine`,
//! the one state machine and fault model (`src/machine/MACHINE.md`).
//!
//! Priorities: `tick` (TIM2, 3) runs `Machine::tick` (inputs, DDA, counters, soft limits,
//! homing, job end) -- `Machine::tick_with` the event playback during an event job, the Z-slide
//! job (after reading the spindle) during a Z job -- and drives the step port and outputs; while
//! the machine grants it (a quiet plain or force job or none, an event or wire job, or a Z job
//! with step outputs), 7 ticks in 8 are `Machine::fast_tick` (the job's stepping, counters,
//! soft limits) and read no inputs but a wire job's stall switch; `estop` (EXTI, 3) cuts the
//! drivers on the e-stop edge; `usart1` (USART1, 2) turns bytes into frames and frames into
//! machine commands; `feeder` (2) runs the machine's background work and prepares queued
//! segments into the DDA (the divisions live here, never in the tick); `link_status` (1) judges
//! the link, announces faults, sends the periodic Status, feeds the watchdog and persists an
//! accepted config once the machine is at rest, woken by the tick every millisecond.

#![no_std]
#![no_main]

use core::sync::atomic::AtomicBool;
use motion_firmware as _;

/// The feeder stopped because the DDA was full; the tick wakes it when a slot frees up.
static FEEDER_BLOCKED: AtomicBool = AtomicBool::new(false);

#[rtic::app(device = stm32f4::stm32f405, dispatchers = [SPI2, SPI3])]
mod app {
    use super::FEEDER_BLOCKED;
    use board_contract::{
        ConfigStorage as _, CopyEncoders as _, SpindleEncoder as _, TickRate as _,
    };
    use board_contract::{
        EStopLine as _, ForceAdc as _, HostSerial as _, MachineIo as _, StepPort as _,
        TickTimer as _, Watchdog as _,
    };
    use core::sync::atomic::Ordering::Relaxed;
    #[cfg(not(feature = "step-stream"))]
    use motion::machine::DdaSource;
    use motion::machine::{BoardConfig, BootConfig, Inputs, OverrunDetector};
    use motion::polar::PLAYBACK_JOB;
    use motion::protocol::{FaultCode, FrameDecoder, MAX_FRAME, MAX_FRAME_LINK};
    use motion_firmware::board;
    use motion_firmware::link::capabilities::{Capabilities, TickChain as _};
    use motion_firmware::link::link_job::{Readings, StepReadings};
    use motion_firmware::link::{
        self, Link, Motion, ESTOP_EDGE, EVENTS_WAITING, EVENT_REFILL, LINK_OK, SAVING_CONFIG,
        WAKE_TICKS, WATCHDOG,
    };
    use rtic_sync::make_signal;
    use rtic_sync::signal::{SignalReader, SignalWriter};

    type Wake = SignalWriter<'static, ()>;
    type Waiter = SignalReader<'static, ()>;

    #[shared]
    struct Shared {
        motion: Motion,
        // Only the priority-3 tasks (tick, e-stop) touch the port: they never preempt each other,
        // so the tick writes it without a lock.
        #[lock_free]
        step_port: board::StepPort,
        // The tick's alone (the stream's fill interrupt); `()` without the stream.
        #[lock_free]
        step_stream: board::StepStream,
        link: Link,
        host_port: link::HostPort,
    }

    #[local]
    struct Local {
        tick_timer: board::TickTimer,
        io: board::MachineIo,
        copy_encoders: board::CopyEncoders,
        spindle: board::Spindle,
        tick_wakes_feeder: Wake,
        tick_wakes_status: Wake,
        estop: board::EStop,
        feeder_waits: Waiter,
        usart_wakes_feeder: Wake,
        status_waits: Waiter,
        watchdog: board::Watchdog,
        config: board::ConfigStorage,
        force_adc: Option<board::ForceAdc>,
        cycles: board::CycleCounter,
    }

    #[init]
    fn init(mut cx: init::Context) -> (Shared, Local) {
        // The timer starts at the safe default's rate and is retimed to the stored config's
        // before it runs.
        let default_hz = BoardConfig::safe_default().link.machine.tick_hz;
        let board::Parts {
            reset,
            mut tick_timer,
            mut step_port,
            estop,
            host,
            io,
            mut watchdog,
            mut config,
            copy_encoders,
            mut force_adc,
            mut spindle,
            cycles,
            ..
        } = board::init(cx.device, &mut cx.core, default_hz);
        // The real board's force ADC runs from boot (force jobs need its rate; see `link::milling`).
        if let Some(hz) = force_adc.as_mut().and_then(|a| a.start(link::milling::ADC_START_HZ).ok())
        {
            link::milling::ADC_SAMPLE_HZ.store(hz, Relaxed);
        }
        let spindle_ok = link::turning::init(&mut spindle);
        // The stored config (the real board's flash); none under QEMU, whose flash is ROM: then
        // the machine boots in Fault with ConfigMissing and safe defaults until the host sends one.
        // After a watchdog reset the machine boots in Fault with WatchdogReset. A stored tick
        // rate this timer cannot make boots on safe defaults with TickRate.
        let mut tick_rate = tick_timer.rate_control();
        let loaded = config.load().and_then(|c| {
            let tick_hz = c.link.machine.tick_hz;
            if tick_rate.set(tick_hz) {
                Ok(c)
            } else {
                defmt::error!("stored tick rate {=u32} Hz not supported by this board", tick_hz);
                Err(BootConfig::UnsupportedTickRate { tick_hz })
            }
        });
        let Some((mut motion, preparer)) = Motion::boot(loaded, reset) else {
            defmt::error!("the safe default config is refused: the firmware is broken");
            board::exit(false)
        };
        // A fill samples the inputs at most every `STREAM_SAMPLE_STRIDE` slots (`fill_slot`).
        #[cfg(feature = "step-stream")]
        motion.machine.set_sample_stride(motion::machine::STREAM_SAMPLE_STRIDE);
        let tick_hz = motion.machine.config().link.machine.tick_hz;
        if !tick_rate.set(tick_hz) {
            defmt::error!("tick rate {=u32} Hz not supported by this board", tick_hz);
            motion.machine.board_fault(FaultCode::BoardSetup);
        }
        if !spindle_ok {
            defmt::error!("the spindle encoder refused its configuration");
            motion.machine.board_fault(FaultCode::BoardSetup);
        }
        let last_panic = motion_firmware::panic::take_recorded();
        if let Some(site) = &last_panic {
            defmt::error!(
                "the firmware panicked before this reset at {=str}:{=u32}:{=u32}",
                site.file.as_str(),
                site.line,
                site.column
            );
            motion.machine.board_fault(FaultCode::Panicked);
        }
        defmt::println!(
            "motion-board {=str} board={=str} tick_hz={=u32} host link on USART1 at {=u32} baud; \
             machine {=u8} (faults {=u32:#x})",
            env!("CARGO_PKG_VERSION"),
            board::NAME,
            tick_hz,
            board::HOST_BAUD,
            motion.machine.state() as u8,
            motion.machine.faults().mask()
        );
        let mut name = heapless::String::<32>::new();
        // Fits: both board names are short (the link cuts it to 24 bytes anyway). Pushed piece
        // by piece: core::fmt::write would link the formatting machinery for this one line.
        for piece in [board::NAME, " ", env!("CARGO_PKG_VERSION")] {
            if name.push_str(piece).is_err() {
                break;
            }
        }
        let mut link = Link::new(&name, preparer, tick_rate);
        if let Some(site) = last_panic {
            link.board.set_last_panic(site);
        }
        watchdog.start(link::WATCHDOG_TIMEOUT_MS);

        let (feeder_wake, feeder_waits) = make_signal!(());
        let (status_wake, status_waits) = make_signal!(());
        defmt::unwrap!(feeder::spawn().ok());
        defmt::unwrap!(link_status::spawn().ok());
        step_port.enable();
        tick_timer.start();

        (
            Shared {
                motion,
                step_port,
                step_stream: board::StepStream::default(),
                link,
                host_port: link::HostPort::new(host),
            },
            Local {
                tick_timer,
                io,
                copy_encoders,
                spindle,
                tick_wakes_feeder: feeder_wake.clone(),
                tick_wakes_status: status_wake,
                estop,
                feeder_waits,
                usart_wakes_feeder: feeder_wake,
                status_waits,
                watchdog,
                config,
                force_adc,
                cycles,
            },
        )
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// One machine tick at `tick_hz`: read the inputs, tick the machine (and through it the
    /// DDA), drive the pins and outputs, wake whoever has work. `wake` counts down to the status
    /// task's next run (`WAKE_TICKS`, 1 ms: a countdown because SetConfig restarts the clock);
    /// step-only ticks count it too, and the full tick that comes next wakes the task (at most
    /// `SUPERVISE_TICKS - 1` ticks late), so the machine alone decides which ticks are full ones
    /// (a Z job keeps them off its generator's updates).
    ///
    /// With the streamed step output (`step-stream`), TIM2's update is the fill interrupt, once
    /// per `STREAM_SLOTS` slots (the real board's TIM2 counts the slot timer's updates; QEMU's
    /// runs at the fill rate): a tick per slot, each a set/reset word into the half buffer the
    /// DMA has just played, and the overrun check once per fill. The step-only ticks the
    /// machine grants go in one call (`Machine::fast_fill`: the DDA runs them a fast run at a
    /// time), the others one at a time (`fill_slot`: full ticks at most every
    /// `STREAM_SAMPLE_STRIDE` slots).
    #[task(binds = TIM2, priority = 3, shared = [motion, step_port, step_stream],
        local = [tick_timer, io, copy_encoders, spindle, tick_wakes_feeder, tick_wakes_status, cycles,
            wake: i32 = 1, overrun: OverrunDetector = OverrunDetector::new(),
            overran: bool = false, drivers_on: bool = true,
            plain: bool = false, capability: u8 = 0, spindle_at_rest: bool = false,
            copy_counts: [i32; 2] = [0; 2], last_full: i32 = i32::MIN / 2])]
    fn tick(mut cx: tick::Context) {
        #[cfg(feature = "isr-cycles")]
        let entry = board_contract::CycleCounter::now(&*cx.local.cycles);
        cx.local.tick_timer.clear_update();
        let port = cx.shared.step_port;
        #[cfg(not(feature = "step-stream"))]
        let full = one_tick(&mut cx.local, &mut cx.shared.motion, port, |p, step| p.write(step));
        // The stream's half buffer: one machine tick per slot, each a set/reset word. The
        // supervision below then runs once per fill, whatever the ticks were.
        // One lock for the whole fill: nothing that shares the motion state can run during a
        // fill anyway (TIM2 has the ceiling's priority), so a lock per slot only costs time.
        #[cfg(feature = "step-stream")]
        let full = {
            use board_contract::StepStream as _;
            let stream = cx.shared.step_stream;
            let mut layout = stream.layout();
            let l = &mut cx.local;
            cx.shared.motion.lock(|m| {
                let mut held = HeldForFill(m);
                // The slot of the last full tick, counted from this fill's first (kept in a
                // register through the fill, carried to the next one below).
                let mut last_full = *l.last_full;
                let words = stream.half();
                let mut slot = 0;
                while slot < words.len() {
                    // As many step-only ticks in a row as the machine grants, in one call (an
                    // e-stop edge cannot arrive during a fill: its interrupt has this one's
                    // priority).
                    if *l.plain && !ESTOP_EDGE.load(Relaxed) {
                        let m = &mut *held.0;
                        let (spindle, at_rest) = (&mut *l.spindle, *l.spindle_at_rest);
                        let sense = || {
                            if !at_rest {
                                spindle.update();
                            }
                        };
                        let n =
                            m.machine.fast_fill(&mut m.dda, &mut words[slot..], sense, &mut layout);
                        if n != 0 {
                            *l.wake -= n as i32;
                            slot += n;
                            continue;
                        }
                    }
                    let Some(w) = words.get_mut(slot) else { break };
                    let emit = |_: &mut board::StepPort, step: &motion::StepOutput| {
                        *w = layout.word(*step)
                    };
                    fill_slot(l, &mut held, port, slot as i32, &mut last_full, emit);
                    slot += 1;
                }
                *l.last_full = last_full.max(-FULL_STRIDE) - board_contract::STREAM_SLOTS as i32;
            });
            true
        };
        let l = cx.local;
        if full {
            // A config save stalls flash fetches, so the tick after it runs late: not an overrun.
            let late = l.tick_timer.update_pending() && !SAVING_CONFIG.load(Relaxed);
            *l.overran = l.overrun.after_tick(late);
        }
        #[cfg(feature = "isr-cycles")]
        motion_firmware::isr_cycles::BINS
            .record(board_contract::CycleCounter::now(&*l.cycles).wrapping_sub(entry));
    }

    /// Slots from one full tick to the next at most, in a fill (`fill_slot`).
    #[cfg(feature = "step-stream")]
    const FULL_STRIDE: i32 = motion::machine::STREAM_SAMPLE_STRIDE as i32;

    /// The motion state locked once for a whole fill of the streamed output: the locks of
    /// `fill_slot`'s ticks are then plain calls.
    #[cfg(feature = "step-stream")]
    struct HeldForFill<'a>(&'a mut Motion);

    #[cfg(feature = "step-stream")]
    impl rtic::Mutex for HeldForFill<'_> {
        type T = Motion;

        #[inline(always)]
        fn lock<R>(&mut self, f: impl FnOnce(&mut Motion) -> R) -> R {
            f(self.0)
        }
    }

    /// One slot of a fill that `Machine::fast_fill` did not take: the capability's step-only
    /// tick when it grants one; else a full tick once `STREAM_SAMPLE_STRIDE` slots have passed
    /// since the last (at once for an e-stop edge or a capability's job), and a held tick
    /// (`Machine::held_tick`: the DDA and the step counters) before that. So a machine that is
    /// not quiet (homing, probing, a fault, a switch being timed) takes 8 full ticks per 40
    /// slots, not 40, and the fill keeps to its half.
    #[cfg(feature = "step-stream")]
    #[inline(always)]
    fn fill_slot(
        l: &mut tick::LocalResources<'_>,
        motion: &mut HeldForFill<'_>,
        port: &mut board::StepPort,
        slot: i32,
        last_full: &mut i32,
        mut emit: impl FnMut(&mut board::StepPort, &motion::StepOutput),
    ) {
        // A plain job's step-only ticks were the fill's own (`Machine::fast_fill`).
        if capability_step_only_tick(l, motion, port, &mut emit) {
            return;
        }
        if slot - *last_full >= FULL_STRIDE || !*l.plain || ESTOP_EDGE.load(Relaxed) {
            *last_full = slot;
            full_tick(l, motion, port, emit);
            return;
        }
        // The spindle is read on every tick, as a step-only tick reads it.
        if !*l.spindle_at_rest {
            l.spindle.update();
        }
        let m = &mut *motion.0;
        let step = m.machine.held_tick(&mut m.dda);
        emit(port, &step);
        *l.wake -= 1;
    }

    /// One machine tick, its step output to `emit` (the port's write); true for a full tick
    /// (inputs read, the machine's `tick`), false for a step-only one.
    #[cfg(not(feature = "step-stream"))]
    #[inline(always)]
    fn one_tick(
        l: &mut tick::LocalResources<'_>,
        motion: &mut impl rtic::Mutex<T = Motion>,
        port: &mut board::StepPort,
        mut emit: impl FnMut(&mut board::StepPort, &motion::StepOutput),
    ) -> bool {
        if step_only_tick(l, motion, port, &mut emit) {
            return false;
        }
        full_tick(l, motion, port, emit);
        true
    }

    /// A step-only tick if the machine grants one (see below); false: none was run.
    #[cfg(not(feature = "step-stream"))]
    #[inline(always)]
    fn step_only_tick(
        l: &mut tick::LocalResources<'_>,
        motion: &mut impl rtic::Mutex<T = Motion>,
        port: &mut board::StepPort,
        emit: &mut impl FnMut(&mut board::StepPort, &motion::StepOutput),
    ) -> bool {
        // A step-only tick (`Machine::fast_tick`) while the last full tick found nothing but
        // the job's stepping with work: a plain segment job (or none) with the copy encoders
        // still, a force, event or wire job, or a Z job with step outputs; no e-stop edge. A
        // turning spindle's decoder still sees every tick.
        // The plain job's own flag and path first, as short as it can be: its step-only tick is
        // the one the budget is for (sharing the capabilities' path below costs it a dispatch
        // and a flag). Then the step-only tick of the capability whose job the last full tick
        // ran (`capability`: its place in `Capabilities`, from 1).
        // The spindle is read once per tick: on a step-only tick only when the machine grants
        // it (`fast_tick_sensing`), else by the full tick below.
        if *l.plain && !ESTOP_EDGE.load(Relaxed) {
            let (spindle, at_rest) = (&mut *l.spindle, *l.spindle_at_rest);
            let step = motion.lock(|m| {
                let sense = || {
                    if !at_rest {
                        spindle.update();
                    }
                };
                m.machine.fast_tick_sensing(&mut m.dda, &mut DdaSource, sense)
            });
            if let Some(step) = step {
                emit(port, &step);
                *l.wake -= 1;
                return true;
            }
        } else {
            return capability_step_only_tick(l, motion, port, emit);
        }
        false
    }

    /// The step-only tick of the capability whose job the last full tick ran, if it grants
    /// one; false: none was run.
    #[inline(always)]
    fn capability_step_only_tick(
        l: &mut tick::LocalResources<'_>,
        motion: &mut impl rtic::Mutex<T = Motion>,
        port: &mut board::StepPort,
        emit: &mut impl FnMut(&mut board::StepPort, &motion::StepOutput),
    ) -> bool {
        if *l.capability != 0 && !ESTOP_EDGE.load(Relaxed) {
            let which = *l.capability;
            let mut b = StepReadings {
                spindle: &mut *l.spindle,
                spindle_at_rest: *l.spindle_at_rest,
                io: &mut *l.io,
            };
            let step = motion.lock(|m| Capabilities::step_only_tick(which, m, &mut b));
            if let Some(step) = step {
                emit(port, &step);
                *l.wake -= 1;
                return true;
            }
        }
        false
    }

    /// A full tick: the inputs read, the machine's `tick` (or the capability's), the outputs
    /// written, whoever has work woken.
    #[inline(always)]
    fn full_tick(
        l: &mut tick::LocalResources<'_>,
        motion: &mut impl rtic::Mutex<T = Motion>,
        port: &mut board::StepPort,
        mut emit: impl FnMut(&mut board::StepPort, &motion::StepOutput),
    ) {
        let raw = l.io.read();
        let copy_counts = l.copy_encoders.read();
        let inputs = Inputs {
            estop: raw.estop || ESTOP_EDGE.swap(false, Relaxed),
            limit_min: raw.limit_min,
            limit_max: raw.limit_max,
            sensor_faults: 0,
            link_ok: LINK_OK.load(Relaxed),
            tick_overrun: *l.overran,
            probe: raw.probe,
        };
        let still = copy_counts == *l.copy_counts;
        *l.copy_counts = copy_counts;
        motion.lock(|m| {
            #[cfg(feature = "sim-inputs")]
            let inputs = link::sim::with_probe(m, &inputs);
            let mut r = Readings {
                inputs: &inputs,
                copy_counts,
                wire_stall: raw.wire_stall,
                spindle: &mut *l.spindle,
            };
            Capabilities::sense(m, &mut r);
            let capability = Capabilities::tick(m, &r);
            *l.spindle_at_rest = l.spindle.at_rest();
            *l.plain = false;
            *l.capability = 0;
            let out = if let Some((out, which)) = capability {
                *l.capability = which;
                out
            } else {
                *l.plain = still;
                m.machine.tick(&mut m.dda, &inputs)
            };
            emit(port, &out.step);
            l.io.write(&out.outputs);
            // The drivers stay off from an e-stop until its fault is cleared.
            let drivers_on = !m.machine.faults().has(FaultCode::EStop);
            if drivers_on != *l.drivers_on {
                *l.drivers_on = drivers_on;
                if drivers_on {
                    port.enable();
                } else {
                    port.disable();
                }
            }
            // Cheapest first: most ticks stop at the first test that says "no work".
            let wake = (FEEDER_BLOCKED.load(Relaxed) && m.dda.ready_free() > 0)
                || m.machine.wants_background()
                || (EVENTS_WAITING.load(Relaxed)
                    && m.machine.runs(PLAYBACK_JOB)
                    && m.playback.free() >= EVENT_REFILL)
                || link::wire::wants_feed(m);
            if wake {
                FEEDER_BLOCKED.store(false, Relaxed);
                l.tick_wakes_feeder.write(());
            }
        });
        if *l.wake <= 1 {
            *l.wake = WAKE_TICKS.load(Relaxed) as i32;
            l.tick_wakes_status.write(());
        } else {
            *l.wake -= 1;
        }
        WATCHDOG.tick_alive();
    }

    /// Force ADC half buffer (real board): the force job's chain per frame, its control law
    /// once per half, the override into the DDA (`link::milling`). On the simulator board, which
    /// has no force ADC, the tick pends it for each plant sample. The tick's priority: they
    /// never preempt each other, and a pended sample runs before the next tick.
    #[task(binds = DMA2_STREAM0, priority = 3, shared = [motion], local = [force_adc])]
    fn force_dma(mut cx: force_dma::Context) {
        let Some(adc) = cx.local.force_adc.as_mut() else {
            cx.shared.motion.lock(link::milling::on_sim_sample);
            return;
        };
        match adc.on_dma_irq() {
            Some(frames) => {
                cx.shared.motion.lock(|m| link::milling::on_adc_frames(m, Some(frames), false))
            }
            None => {
                let overrun = adc.overrun();
                cx.shared.motion.lock(|m| link::milling::on_adc_frames::<4>(m, None, overrun))
            }
        }
    }

    /// E-stop edge: drivers off at once; the tick latches the fault (even if the loop closed
    /// again meanwhile) and stops the machine.
    #[task(binds = EXTI15_10, priority = 3, shared = [step_port], local = [estop])]
    fn estop(cx: estop::Context) {
        if cx.local.estop.clear() {
            ESTOP_EDGE.store(true, Relaxed);
            cx.shared.step_port.disable();
        }
    }

    /// The machine's background work, then queued segments prepared into the DDA while it has
    /// room and the machine lets it feed.
    #[task(priority = 2, shared = [motion, link], local = [feeder_waits])]
    async fn feeder(cx: feeder::Context) {
        let feeder::SharedResources { mut motion, mut link, .. } = cx.shared;
        loop {
            cx.local.feeder_waits.wait().await;
            link.lock(|l| l.feed_events(&mut motion));
            link.lock(|l| l.feed_wire(&mut motion));
            loop {
                let full = motion.lock(|m| {
                    let full = m.machine.feeder_blocked(&m.dda);
                    FEEDER_BLOCKED.store(full, Relaxed);
                    full
                });
                if full {
                    break;
                }
                let Some(next) = link.lock(|l| l.next_prepared(&mut motion)) else {
                    break;
                };
                // Segments were checked against this config when queued, and only this task
                // pushes into a queue that had room: a refusal here is a board bug, and it stops
                // the job with a fault instead of running on without the segment.
                let pushed = match next {
                    Ok(prepared) => motion.lock(|m| m.dda.push(&prepared)).is_ok(),
                    Err((id, e)) => {
                        defmt::error!("segment {=u32} rejected: {}", id, e);
                        false
                    }
                };
                if !pushed {
                    motion.lock(|m| m.machine.board_fault(FaultCode::SegmentRejected));
                    break;
                }
            }
        }
    }

    /// Host link: received bytes into frames, frames through `BoardLink`, answers into the
    /// transmit queue (dropped if it cannot hold them whole: the host retransmits); transmit
    /// bytes out while the USART takes them.
    #[task(binds = USART1, priority = 2, shared = [motion, link, host_port],
        local = [usart_wakes_feeder, decoder: FrameDecoder<MAX_FRAME> = FrameDecoder::new()])]
    fn usart1(cx: usart1::Context) {
        let l = cx.local;
        let usart1::SharedResources { mut motion, link, host_port, .. } = cx.shared;
        (link, host_port).lock(|link, port| {
            while let Some(byte) = port.serial.read_byte() {
                let Some(frame) = l.decoder.push(byte) else {
                    continue;
                };
                let (response, wake_feeder) = link.on_frame(frame, &mut motion);
                if wake_feeder {
                    l.usart_wakes_feeder.write(());
                }
                port.send(&response);
            }
            port.pump();
        });
    }

    /// Every millisecond of machine time: judge the link, announce faults, send the periodic
    /// Status, and feed the watchdog when the tick and this task both ran.
    #[task(priority = 1, shared = [motion, link, host_port],
        local = [status_waits, watchdog, config,
            isr_log: motion_firmware::isr_cycles::Logger = motion_firmware::isr_cycles::Logger::new()])]
    async fn link_status(cx: link_status::Context) {
        let link_status::SharedResources { mut motion, mut link, mut host_port, .. } = cx.shared;
        let mut overruns_seen = 0;
        loop {
            cx.local.status_waits.wait().await;
            let (overruns, dropped) = host_port.lock(|p| (p.serial.overruns(), p.dropped));
            link.lock(|l| l.board.note_port(overruns, dropped));
            if overruns != overruns_seen {
                // Lost bytes fail a frame's CRC; the host retransmits. Worth a line in the log.
                defmt::warn!("USART1 receive overruns: {=u32}", overruns);
                overruns_seen = overruns;
            }
            WATCHDOG.control_alive();
            #[cfg(feature = "isr-cycles")]
            {
                let tick_hz = motion.lock(|m| m.machine.config().link.machine.tick_hz);
                cx.local.isr_log.poll(tick_hz);
            }
            let (responses, feed) = link.lock(|l| l.poll(&mut motion));
            link.lock(|l| l.drain_teach(&mut motion));
            if feed && WATCHDOG.poll() {
                cx.local.watchdog.feed();
            }
            if let Some(cfg) = link.lock(|l| l.take_save(&mut motion)) {
                let (watchdog, config) = (&mut *cx.local.watchdog, &mut *cx.local.config);
                SAVING_CONFIG.store(true, Relaxed);
                let saved = watchdog.stretch(|| config.save(&cfg));
                SAVING_CONFIG.store(false, Relaxed);
                match saved {
                    Ok(()) => defmt::info!("config saved to flash"),
                    Err(e) => defmt::error!("config not saved: {=str}", link::save_error_name(e)),
                }
            }
            for response in responses.iter().flatten() {
                // Encoded outside the locks: the USART task keeps running meanwhile.
                let mut buf = [0u8; MAX_FRAME_LINK];
                if let Some(frame) = link::encode(response, &mut buf) {
                    host_port.lock(|port| port.queue_frame(frame));
                }
            }
        }
    }
}
