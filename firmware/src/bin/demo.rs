//! The demo firmware: an RTIC 2 app that runs the built-in demo job through the same planner,
//! preparer and DDA as the host model, and prints position snapshots and the end-of-job report
//! over defmt (`cargo xtask demo` decodes them and compares them with the host model). With the
//! test-only `tamper` feature the tick path is perturbed once, so the golden comparison in
//! `cargo xtask test` can prove it detects a divergence.
//!
//! Priorities: `tick` (TIM2, 3) steps the DDA and drives the step port; `feeder` (2) prepares
//! queued segments (the divisions live here, never in the tick) and pushes them into the DDA;
//! `job` (1) plans segments into the queue, prints snapshots and finally the report.
#![no_std]
#![no_main]

// The streamed step output changes what the board's tick timer is (the fill interrupt): only
// the link firmware has the fill.
#[cfg(feature = "step-stream")]
compile_error!("step-stream is the link firmware's: build this firmware without it");

use core::sync::atomic::AtomicBool;
use motion_firmware::board;

/// The job has handed its last segment to the queue.
static JOB_DONE: AtomicBool = AtomicBool::new(false);
/// Every segment is in the DDA: the first idle tick from now on ends the run.
static ALL_FED: AtomicBool = AtomicBool::new(false);
/// The feeder stopped because the DDA was full; the tick wakes it when a slot frees up.
static FEEDER_BLOCKED: AtomicBool = AtomicBool::new(false);
/// The tick stopped at the end of the job; the job task prints the report.
static FINISHED: AtomicBool = AtomicBool::new(false);

#[rtic::app(device = stm32f4::stm32f405, dispatchers = [SPI2, SPI3])]
mod app {
    use super::{board, ALL_FED, FEEDER_BLOCKED, FINISHED, JOB_DONE};
    use board_contract::{EStopLine as _, TickTimer as _};
    use core::sync::atomic::Ordering::{Acquire, Relaxed, Release};
    use heapless::spsc::Producer;
    use heapless::spsc::{Consumer, Queue};
    use motion::dda::{Prepared, Preparer};
    use motion::demo_job;
    use motion::demo_job::DemoJob;
    use motion::demo_job::SNAPSHOT_PERIOD_TICKS;
    use motion::report::{Report, Snapshot};
    use motion::segment::SegmentError;
    use motion::{Dda, Segment};
    use motion_firmware::step::RecordedPort;
    use rtic::mutex_prelude::*;
    use rtic_sync::make_signal;
    use rtic_sync::signal::{SignalReader, SignalWriter};

    /// Planned segments waiting to be prepared (demo job).
    const QUEUE: usize = 16;
    type Wake = SignalWriter<'static, ()>;
    type Waiter = SignalReader<'static, ()>;

    /// Where the feeder takes its segments from: the demo job's queue, or the host's.
    type Feed = DemoFeed;

    /// The demo job's side of the queue, with the preparer.
    pub struct DemoFeed {
        consumer: Consumer<'static, Segment>,
        preparer: Preparer,
    }

    impl DemoFeed {
        fn next_prepared(&mut self) -> Option<Result<Prepared, (u32, SegmentError)>> {
            let seg = self.consumer.dequeue()?;
            Some(self.preparer.prepare(&seg).map_err(|e| (seg.id, e)))
        }

        fn is_empty(&self) -> bool {
            self.consumer.is_empty()
        }
    }

    #[shared]
    struct Shared {
        dda: Dda,
        step_port: RecordedPort,
        feed: Feed,
    }

    #[local]
    struct Local {
        tick_timer: board::TickTimer,
        tick_wakes_feeder: Wake,
        tick_wakes_job: Wake,
        estop: board::EStop,
        feeder_waits: Waiter,
        feeder_wakes_job: Wake,
        producer: Producer<'static, Segment>,
        demo: DemoJob,
        job_waits: Waiter,
        job_wakes_feeder: Wake,
    }

    /// The DDA filled with the start of the demo job, before the first tick.
    #[init]
    fn init(mut cx: init::Context) -> (Shared, Local) {
        let cfg = demo_job::config();
        let board::Parts { mut tick_timer, step_port, estop, .. } =
            board::init(cx.device, &mut cx.core, cfg.tick_hz);
        let mut step_port = RecordedPort::new(step_port);
        defmt::println!(
            "motion-board {=str} board={=str} tick_hz={=u32} axes={=u8}",
            env!("CARGO_PKG_VERSION"),
            board::NAME,
            cfg.tick_hz,
            cfg.axis_count
        );

        let mut dda = defmt::unwrap!(Dda::new(&cfg).ok());
        for &(at, cmd) in demo_job::commands() {
            defmt::unwrap!(dda.schedule(at, cmd).ok());
        }
        // Fill the DDA before the first tick, as the host model does.
        let mut preparer = defmt::unwrap!(Preparer::new(&cfg).ok());
        let mut demo = DemoJob::new();
        while dda.ready_free() > 0 {
            let Some(seg) = demo.next_segment() else {
                break;
            };
            defmt::unwrap!(dda.push(&defmt::unwrap!(preparer.prepare(&seg).ok())).ok());
        }

        let queue = defmt::unwrap!(cortex_m::singleton!(: Queue<Segment, QUEUE> = Queue::new()));
        let (producer, consumer) = queue.split();
        let (feeder_wake, feeder_waits) = make_signal!(());
        let (job_wake, job_waits) = make_signal!(());
        defmt::unwrap!(feeder::spawn().ok());
        defmt::unwrap!(job::spawn().ok());
        step_port.enable();
        tick_timer.start();

        (
            Shared { dda, step_port, feed: DemoFeed { consumer, preparer } },
            Local {
                tick_timer,
                tick_wakes_feeder: feeder_wake.clone(),
                tick_wakes_job: job_wake.clone(),
                estop,
                feeder_waits,
                feeder_wakes_job: job_wake,
                producer,
                demo,
                job_waits,
                job_wakes_feeder: feeder_wake,
            },
        )
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// One DDA tick at `tick_hz`: step, drive the pins, wake whoever has work.
    ///
    /// `wake`: the demo job wakes at tick `wake` (every snapshot period).
    #[task(binds = TIM2, priority = 3, shared = [dda, step_port],
    local = [tick_timer, tick_wakes_feeder, tick_wakes_job, wake: u64 = SNAPSHOT_PERIOD_TICKS])]
    fn tick(cx: tick::Context) {
        let l = cx.local;
        l.tick_timer.clear_update();
        (cx.shared.dda, cx.shared.step_port).lock(|dda, port| {
            #[cfg(feature = "tamper")]
            if dda.now() == 50_000 {
                dda.apply(motion::Command::SetOverride(motion::Rate::lit("0.99")));
            }
            let out = dda.tick();
            let now = dda.now();
            port.apply(now, &out);

            if FEEDER_BLOCKED.load(Relaxed) && dda.ready_free() > 0 {
                FEEDER_BLOCKED.store(false, Relaxed);
                l.tick_wakes_feeder.write(());
            }
            if now >= *l.wake {
                *l.wake = now + SNAPSHOT_PERIOD_TICKS;
                l.tick_wakes_job.write(());
            }
            if ALL_FED.load(Acquire) && dda.is_idle() {
                l.tick_timer.stop();
                FINISHED.store(true, Release);
                l.tick_wakes_job.write(());
            }
        });
    }

    /// E-stop: stop at once, drop the queue, drivers off.
    #[task(binds = EXTI15_10, priority = 3, shared = [dda, step_port], local = [estop])]
    fn estop(cx: estop::Context) {
        if cx.local.estop.clear() {
            (cx.shared.dda, cx.shared.step_port).lock(|dda, port| {
                dda.abort();
                port.disable();
            });
            defmt::error!("e-stop: motion aborted, drivers disabled");
        }
    }

    /// Prepares queued segments and pushes them into the DDA while it has room.
    #[task(priority = 2, shared = [dda, feed], local = [feeder_waits, feeder_wakes_job])]
    async fn feeder(mut cx: feeder::Context) {
        let l = cx.local;
        loop {
            l.feeder_waits.wait().await;
            let mut took = false;
            loop {
                let full = cx.shared.dda.lock(|dda| {
                    let full = dda.ready_free() == 0;
                    FEEDER_BLOCKED.store(full, Relaxed);
                    full
                });
                if full {
                    break;
                }
                let Some(next) = cx.shared.feed.lock(|f| f.next_prepared()) else {
                    break;
                };
                took = true;
                // Segments were checked against this config when queued: a refusal is a bug.
                let prepared = match next {
                    Ok(p) => p,
                    Err((id, e)) => {
                        defmt::panic!("segment {=u32} rejected: {}", id, defmt::Debug2Format(&e))
                    }
                };
                // Only this task pushes, and there was room.
                defmt::unwrap!(cx.shared.dda.lock(|dda| dda.push(&prepared)).ok());
            }
            if JOB_DONE.load(Acquire) && cx.shared.feed.lock(|f| f.is_empty()) {
                ALL_FED.store(true, Release);
            }
            if took {
                l.feeder_wakes_job.write(());
            }
        }
    }

    /// Plans the demo job into the queue, prints snapshots, and the report at the end.
    #[task(priority = 1, shared = [dda, step_port],
    local = [producer, demo, job_waits, job_wakes_feeder])]
    async fn job(cx: job::Context) {
        run_demo(cx).await;
    }

    async fn run_demo(mut cx: job::Context<'_>) -> ! {
        let cfg = demo_job::config();
        let l = cx.local;
        let mut pending: Option<Segment> = None;
        let mut next_snapshot = SNAPSHOT_PERIOD_TICKS;
        loop {
            let mut queued = false;
            while !JOB_DONE.load(Relaxed) {
                let Some(seg) = pending.take().or_else(|| l.demo.next_segment()) else {
                    JOB_DONE.store(true, Release);
                    queued = true;
                    break;
                };
                if let Err(seg) = l.producer.enqueue(seg) {
                    pending = Some(seg);
                    break;
                }
                queued = true;
            }
            if queued {
                l.job_wakes_feeder.write(());
            }

            if FINISHED.load(Acquire) {
                let report = (cx.shared.dda, cx.shared.step_port).lock(|dda, port| {
                    Report::from_run(dda, port.recorder(), cfg.axis_count, cfg.tick_hz)
                });
                report.write_lines(|line: &str| defmt::println!("{=str}", line));
                board::exit(true);
            }
            let snap =
                cx.shared.dda.lock(|dda| Snapshot { tick: dda.now(), positions: dda.positions() });
            if snap.tick >= next_snapshot {
                next_snapshot = snap.tick + SNAPSHOT_PERIOD_TICKS;
                defmt::println!("{=str}", snap.write_line(cfg.axis_count).as_str());
            }
            l.job_waits.wait().await;
        }
    }
}
