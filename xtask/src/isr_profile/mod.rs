//! `cargo xtask isr-profile`: the whole tick interrupt of the shipped link firmware, entry to
//! exception return with every callee, on every tick of real jobs streamed to it in QEMU.
//!
//! Each job runs `motionctl ... --qemu` against the link ELF with a `qemu-system-arm` wrapper
//! first on PATH that adds `-singlestep -d exec,nochain -D FIFO` (one trace line per executed
//! instruction); [`trace::Analyzer`] reads the FIFO as QEMU writes it and cuts it into handler
//! instances. The jobs: a 4-axis TOML job streamed as segments, and one job of each capability
//! (force, Z slide, polar playback, wire). Ticks are told apart by the functions that ran in
//! them (see [`SITUATIONS`]); the cycle model is [`disasm`]'s.

mod disasm;
mod trace;

pub mod cycles;
use crate::e2e::build_motionctl;
use crate::firmware::{self, Board};
use anyhow::{bail, Context, Result};
use std::fmt::Write as _;
use std::io::BufReader;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// TIM2's interrupt number (vector 16 + 28): the DDA tick.
const TICK_IRQ: usize = 28;
/// DMA2 stream 0's interrupt number (vector 16 + 56): the force interrupt, the real board's
/// ADC DMA and the simulator board's plant sample, pended by the tick on the ticks a sample is
/// due and run right after it.
const FORCE_IRQ: usize = 56;
/// The default configuration's tick and the F405's core clock.
const DEFAULT_TICK_HZ: f64 = 100_000.0;
const CORE_HZ: f64 = 168_000_000.0;
/// The DDA steps an axis at most every other tick: a STEP pulse is high for at least one tick
/// and the rate cap keeps an axis's pulses at least twice that apart.
const STEPS_PER_TICK_PER_AXIS: f64 = 0.5;
/// Axes stepping together in the 4-axis job, the largest case profiled.
const PROFILED_AXES: f64 = 4.0;
/// How much longer than for a real board motionctl waits on the traced QEMU: single-stepping
/// with a trace of every instruction makes it hundreds of times slower than real time, more on a
/// loaded machine. The whole job still has [`JOB_TIMEOUT`].
const TRACED_PATIENCE: u32 = 100;
/// The streamed step output's job ([`stream_job_toml`]).
const STREAM_JOB: &str = "4 axes at 250 kHz, streamed";
/// Slots per fill interrupt of the streamed output.
const STREAM_SLOTS: f64 = board_contract::STREAM_SLOTS as f64;
/// A traced job that takes longer than this has hung.
const JOB_TIMEOUT: Duration = Duration::from_secs(20 * 60);

/// How a tick is classified: the first situation whose functions ran in it (in this order);
/// a tick where none ran is "idle". A function counts when its name, or the name of a function
/// inlined into the instruction, contains one of the patterns.
const SITUATIONS: [(&str, &[&str]); 6] = [
    // The machine's homing watch runs on full ticks only, and a homing machine takes no
    // step-only ones: its ticks are the supervision's, whatever the DDA did in them.
    (HOMING, &["::watch_homing"]),
    ("segment change", &["Dda::load_next", "Dda::finish_segment"]),
    ("command", &["Dda::run_due_commands"]),
    (
        "capability update",
        &[
            "milling::control::",
            "milling::chain::",
            "ForceJob::sample_due",
            "turning::command::",
            "turning::table::",
            "polar::playback::Playback::tick",
            "polar::copy::",
            "wire::controller::",
            "wire::link_job::",
        ],
    ),
    // The fast runs live in `motion::dda::fast` (a tick at a time) and `motion::dda::fill` (a
    // run at a time), whose symbols name the impl, not `Dda::`.
    ("ramp", &["Dda::full_tick", "::accelerate_", "::track_"]),
    ("cruise", &["::cruise_tick", "::cruise_run"]),
];
const IDLE: &str = "idle";
const HOMING: &str = "homing";
/// The machine's full tick, out of line in the stream build: its entries per fill tell a fill
/// the machine supervised slot by slot from one of job motion.
const FULL_TICK_FN: &str = "Machine::tick_with";
/// More full machine ticks than this in a fill: the machine supervised its slots (a quiet one
/// takes one per `supervise_ticks`, 2 per fill at 500 kHz, plus one per host command).
const SUPERVISED_FULL_TICKS: u32 = board_contract::STREAM_SLOTS as u32 / 4;

/// One profiled job.
struct Job {
    name: &'static str,
    /// Run on the link firmware built with `step-stream`: each handler run fills a half buffer
    /// of [`STREAM_SLOTS`] slots.
    stream: bool,
    args: Vec<String>,
    /// Trace only the first this many ticks, then stop the job: for a job whose whole length
    /// would take an hour of single-stepped QEMU.
    max_ticks: Option<usize>,
}

/// What one job's handler did, per situation.
pub struct JobProfile {
    pub name: &'static str,
    pub stream: bool,
    pub instances: Vec<trace::Instance>,
    /// Runs of the force interrupt (the force chain, after the tick on the ticks it pends it).
    pub force: Vec<trace::Instance>,
    pub wall: Duration,
    /// Function name -> instructions inside the handler, largest first.
    pub top: Vec<(String, u64)>,
    pub unknown_pcs: u64,
    pub nested: u64,
}

impl JobProfile {
    fn situation(i: &trace::Instance) -> &'static str {
        (0..SITUATIONS.len()).find(|&k| i.marks & (1 << k) != 0).map_or(IDLE, |k| SITUATIONS[k].0)
    }

    fn select(&self, situation: Option<&str>) -> Vec<&trace::Instance> {
        self.instances
            .iter()
            .filter(|i| situation.is_none_or(|s| Self::situation(i) == s))
            .collect()
    }
}

/// Distribution of one quantity.
#[derive(Clone, Copy, Debug, Default)]
pub struct Stats {
    pub n: usize,
    pub min: u32,
    pub median: u32,
    pub p99: u32,
    pub max: u32,
    pub mean: f64,
}

impl Stats {
    fn of(mut v: Vec<u32>) -> Stats {
        if v.is_empty() {
            return Stats::default();
        }
        v.sort_unstable();
        let at = |p: f64| v[((p * (v.len() - 1) as f64).round() as usize).min(v.len() - 1)];
        Stats {
            n: v.len(),
            min: v[0],
            median: at(0.5),
            p99: at(0.99),
            max: v[v.len() - 1],
            mean: v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64,
        }
    }
}

/// The figures `cargo xtask bench` records.
pub struct Figures {
    pub keys: Vec<(&'static str, f64)>,
    pub markdown: String,
}

/// Profiles every job (or those whose name contains one of `only`) and prints the report.
pub fn run(root: &Path, only: &[String]) -> Result<Figures> {
    let elf = firmware::build(root, Board::Netduinoplus2, &["link"])?;
    let stream_elf = crate::e2e::stream_firmware(root)?;
    let bin = build_motionctl(root)?;
    let load = |elf: &Path| -> Result<(disasm::Program, [u32; 2])> {
        let prog = disasm::Program::load(root, elf)?;
        let entries = [prog.irq_handler(TICK_IRQ)?, prog.irq_handler(FORCE_IRQ)?];
        Ok((prog, entries))
    };
    let (tick_prog, tick_entries) = load(&elf)?;
    let (stream_prog, stream_entries) = load(&stream_elf)?;
    let work = root.join("target/isr-profile");
    std::fs::create_dir_all(&work)?;
    let wrapper_dir = write_wrapper(&work)?;
    let mut profiles = Vec::new();
    for job in jobs(root, &work, &elf, &stream_elf)? {
        if !only.is_empty() && !only.iter().any(|o| job.name.contains(o.as_str())) {
            continue;
        }
        println!("\n== {}: motionctl {}", job.name, job.args.join(" "));
        let (prog, entries) =
            if job.stream { (&stream_prog, stream_entries) } else { (&tick_prog, tick_entries) };
        let p = profile_job(root, prog, entries, &bin, &job, &work, &wrapper_dir)?;
        println!("{}", job_table(&p));
        profiles.push(p);
    }
    if profiles.is_empty() {
        bail!("no job matched {only:?}");
    }
    let figures = figures(&profiles)?;
    println!("\n{}", figures.markdown);
    Ok(figures)
}

/// A `qemu-system-arm` first on PATH that traces every instruction into `work/trace.fifo`.
fn write_wrapper(work: &Path) -> Result<PathBuf> {
    let real =
        crate::setup::which("qemu-system-arm").context("qemu-system-arm is not installed")?;
    // QEMU >= 8.1 spells one instruction per block `-accel tcg,one-insn-per-tb=on`; 7.2 has
    // only `-singlestep`.
    let probe = Command::new(&real)
        .args(["-M", "none", "-display", "none", "-accel", "tcg,one-insn-per-tb=on", "-S"])
        .args(["-monitor", "none"])
        .stdin(Stdio::null())
        .output();
    let one_insn = match probe {
        Ok(o) if String::from_utf8_lossy(&o.stderr).contains("one-insn-per-tb") => "-singlestep",
        _ => "-accel tcg,one-insn-per-tb=on",
    };
    let dir = work.join("bin");
    std::fs::create_dir_all(&dir)?;
    let fifo = work.join("trace.fifo");
    let script = format!(
        "#!/bin/sh\n# QEMU with one trace line per executed instruction (cargo xtask isr-profile)\n\
         exec \"{}\" \"$@\" {one_insn} -d exec,nochain -D \"{}\"\n",
        real.display(),
        fifo.display()
    );
    let path = dir.join("qemu-system-arm");
    std::fs::write(&path, script)?;
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755))?;
    Ok(dir)
}

fn profile_job(
    root: &Path,
    prog: &disasm::Program,
    [entry, force_entry]: [u32; 2],
    bin: &Path,
    job: &Job,
    work: &Path,
    wrapper_dir: &Path,
) -> Result<JobProfile> {
    let fifo = work.join("trace.fifo");
    let _ = std::fs::remove_file(&fifo);
    crate::run_status("mkfifo", Command::new("mkfifo").arg(&fifo))?;
    let markers: Vec<&[&str]> = SITUATIONS.iter().map(|s| s.1).collect();
    let path = format!("{}:{}", wrapper_dir.display(), std::env::var("PATH").unwrap_or_default());
    let start = Instant::now();
    let capped = AtomicBool::new(false);
    type Pair<'a> = (trace::Analyzer<'a>, trace::Analyzer<'a>);
    let ((analyzer, force), ok) = std::thread::scope(|scope| -> Result<(Pair<'_>, bool)> {
        let reader = scope.spawn(|| -> Result<Pair<'_>> {
            let keep = std::env::var_os(PCS_ENV).is_some();
            let mut a = trace::Analyzer::new(prog, entry, &markers).keep_pcs(keep);
            if job.stream && !a.count_entries(FULL_TICK_FN) {
                println!("  note: no `{FULL_TICK_FN}` in the ELF: fills are not told apart by it");
            }
            let mut force = trace::Analyzer::new(prog, force_entry, &[]);
            let f = std::fs::File::open(&fifo).context("opening the trace FIFO")?;
            a.read(BufReader::with_capacity(1 << 20, f), job.max_ticks, &capped, &mut force)?;
            Ok((a, force))
        });
        let mut child = Command::new(bin)
            .args(&job.args)
            .current_dir(root)
            .env("PATH", &path)
            .env(motionctl::link::PATIENCE_ENV, TRACED_PATIENCE.to_string())
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .with_context(|| format!("could not start {}", bin.display()))?;
        let status = loop {
            if let Some(s) = child.try_wait()? {
                break s;
            }
            if capped.load(Ordering::Relaxed) {
                // Enough ticks: stop motionctl and the QEMU it started (the one writing this
                // FIFO).
                let _ = child.kill();
                let _ = Command::new("pkill").arg("-f").arg(&fifo).status();
                break child.wait()?;
            }
            if start.elapsed() > JOB_TIMEOUT {
                let _ = child.kill();
                break child.wait()?;
            }
            std::thread::sleep(Duration::from_millis(200));
        };
        let out = child.wait_with_output()?;
        let capped = capped.load(Ordering::Relaxed);
        if capped {
            println!(
                "  traced the first {} ticks, then stopped the job",
                job.max_ticks.unwrap_or(0)
            );
        } else if !status.success() {
            println!("{}", String::from_utf8_lossy(&out.stdout));
            println!("{}", String::from_utf8_lossy(&out.stderr));
        }
        // QEMU never opened the FIFO if motionctl failed early: unblock the reader.
        if !reader.is_finished() {
            let _ = std::fs::OpenOptions::new().write(true).open(&fifo);
        }
        let a = reader.join().map_err(|_| anyhow::anyhow!("trace reader panicked"))??;
        Ok((a, capped || status.success()))
    })?;
    let _ = std::fs::remove_file(&fifo);
    if !ok {
        bail!("{}: motionctl failed (output above)", job.name);
    }
    for (k, (name, _)) in SITUATIONS.iter().enumerate() {
        if !analyzer.marker_found(k as u32) {
            println!("  note: no function of situation `{name}` is in the ELF");
        }
    }
    if analyzer.instances.is_empty() {
        bail!("{}: no tick interrupt in {} trace lines", job.name, analyzer.lines);
    }
    if let Some(dir) = std::env::var_os(PCS_ENV) {
        write_pcs(Path::new(&dir), job.name, &analyzer)?;
    }
    let mut top: Vec<(String, u64)> = analyzer
        .per_function
        .iter()
        .map(|(&a, &n)| {
            (prog.symbol_at(a).map_or_else(|| format!("{a:#010x}"), |s| s.name.clone()), n)
        })
        .collect();
    top.sort_by_key(|b| std::cmp::Reverse(b.1));
    top.truncate(12);
    Ok(JobProfile {
        name: job.name,
        stream: job.stream,
        instances: analyzer.instances,
        force: force.instances,
        wall: start.elapsed(),
        top,
        unknown_pcs: analyzer.unknown,
        nested: analyzer.nested,
    })
}

/// Set to a directory: each job also writes `<job>-idle.pcs` and `<job>-busy.pcs` (`PC COUNT`
/// per line, hex PC) for `llvm-symbolizer` to map onto source lines, and `<job>-longest.pcs`
/// (the longest tick's PCs in execution order, of the ticks in which a situation's function ran).
const PCS_ENV: &str = "ISR_PROFILE_PCS";

fn write_pcs(dir: &Path, job: &str, a: &trace::Analyzer<'_>) -> Result<()> {
    std::fs::create_dir_all(dir)?;
    let stem: String =
        job.chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '_' }).collect();
    for (kind, pcs) in [("idle", &a.pcs_idle), ("busy", &a.pcs_busy)] {
        let mut v: Vec<_> = pcs.iter().collect();
        v.sort();
        let text: String = v.iter().map(|(pc, n)| format!("{pc:#x} {n}\n")).collect();
        std::fs::write(dir.join(format!("{stem}-{kind}.pcs")), text)?;
    }
    // The longest tick, one PC per executed instruction in order.
    let text: String = a.pcs_longest.iter().map(|pc| format!("{pc:#x} 1\n")).collect();
    std::fs::write(dir.join(format!("{stem}-longest.pcs")), text)?;
    Ok(())
}

fn situations() -> impl Iterator<Item = &'static str> {
    SITUATIONS.iter().map(|s| s.0).chain([IDLE])
}

fn job_table(p: &JobProfile) -> String {
    let mut s = format!(
        "{}: {} ticks traced in {:.0} s wall ({} unknown PCs, {} nested entries)\n\n\
         | situation | ticks | instr min / median / p99 / max | cycles min / median / p99 / max | cycles, ART misses (median / max) |\n|---|---|---|---|---|\n",
        p.name,
        p.instances.len(),
        p.wall.as_secs_f64(),
        p.unknown_pcs,
        p.nested
    );
    let rows = situations().map(Some).chain([None]);
    for sit in rows {
        let sel = p.select(sit);
        if sel.is_empty() {
            continue;
        }
        let i = Stats::of(sel.iter().map(|x| x.instructions).collect());
        let c = Stats::of(sel.iter().map(|x| x.cycles).collect());
        let w = Stats::of(sel.iter().map(|x| x.cycles_pessimistic).collect());
        let _ = writeln!(
            s,
            "| {} | {} | {} / {} / {} / {} | {} / {} / {} / {} | {} / {} |",
            sit.unwrap_or("all"),
            i.n,
            i.min,
            i.median,
            i.p99,
            i.max,
            c.min,
            c.median,
            c.p99,
            c.max,
            w.median,
            w.max
        );
    }
    if !p.force.is_empty() {
        let i = Stats::of(p.force.iter().map(|x| x.instructions).collect());
        let c = Stats::of(p.force.iter().map(|x| x.cycles).collect());
        let _ = writeln!(
            s,
            "| force interrupt (after the tick) | {} | {} / {} / {} / {} | {} / {} / {} / {} | |",
            i.n, i.min, i.median, i.p99, i.max, c.min, c.median, c.p99, c.max
        );
    }
    let total: u64 = p.instances.iter().map(|i| i.instructions as u64).sum();
    s.push_str("\nwhere the instructions go:\n");
    for (name, n) in &p.top {
        let _ = writeln!(s, "  {:5.1} %  {name}", 100.0 * *n as f64 / total.max(1) as f64);
    }
    if p.instances.iter().any(|i| i.fp) {
        s.push_str("  note: the handler ran VFP instructions (lazy FP stacking not modelled)\n");
    }
    s
}

fn figures(all_profiles: &[JobProfile]) -> Result<Figures> {
    let (streamed, profiles): (Vec<&JobProfile>, Vec<&JobProfile>) =
        all_profiles.iter().partition(|p| p.stream);
    let all = || profiles.iter().flat_map(|p| p.instances.iter());
    let cycles = Stats::of(all().map(|i| i.cycles).collect());
    let idle = Stats::of(
        all().filter(|i| JobProfile::situation(i) == IDLE).map(|i| i.instructions).collect(),
    );
    let four = profiles.iter().find(|p| p.name.starts_with("4-axis"));
    let cruise4 = four
        .map(|p| Stats::of(p.select(Some("cruise")).iter().map(|i| i.cycles).collect()))
        .unwrap_or_default();
    // The force interrupt runs after the tick on the ticks it pends it: its cycles count in
    // the CPU load (spread over the job's ticks) and in the longest tick-to-tick work.
    let force = Stats::of(profiles.iter().flat_map(|p| p.force.iter()).map(|i| i.cycles).collect());
    let cpu = profiles
        .iter()
        .map(|p| {
            let tick: f64 = p.instances.iter().map(|i| i.cycles as f64).sum();
            let force: f64 = p.force.iter().map(|i| i.cycles as f64).sum();
            let mean = (tick + force) / p.instances.len().max(1) as f64;
            100.0 * mean * DEFAULT_TICK_HZ / CORE_HZ
        })
        .fold(0.0, f64::max);
    // The fastest tick the worst case allows on a 168 MHz core (per job, the longest tick
    // handler plus the longest force interrupt, as if they fell on the same tick), capped by the
    // default tick; the step rates follow from the DDA's one step per two ticks per axis.
    let worst = profiles
        .iter()
        .map(|p| {
            let tick = p.instances.iter().map(|i| i.cycles).max().unwrap_or(0);
            let force = p.force.iter().map(|i| i.cycles).max().unwrap_or(0);
            tick as f64 + force as f64
        })
        .fold(0.0, f64::max);
    let tick_hz = DEFAULT_TICK_HZ.min(CORE_HZ / worst.max(1.0));
    let per_axis = (tick_hz * STEPS_PER_TICK_PER_AXIS).floor();
    let mut keys = vec![
        ("isr_cycles_cruise_4axes", cruise4.median as f64),
        ("tick_irq_step_rate_max_hz_per_axis", per_axis),
        ("isr_cycles_p99", cycles.p99 as f64),
        ("isr_cycles_max", cycles.max as f64),
        ("isr_instr_idle", idle.median as f64),
        ("isr_cpu_percent_default_tick", (cpu * 100.0).round() / 100.0),
        ("isr_force_cycles_max", force.max as f64),
    ];
    let mut md = String::from(
        "| job | ticks | cycles median | cycles p99 | cycles max | force interrupt max | mean CPU at 100 kHz |\n|---|---|---|---|---|---|---|\n",
    );
    for p in &profiles {
        let c = Stats::of(p.instances.iter().map(|i| i.cycles).collect());
        let f = Stats::of(p.force.iter().map(|i| i.cycles).collect());
        let force: f64 = p.force.iter().map(|i| i.cycles as f64).sum();
        let mean = c.mean + force / c.n.max(1) as f64;
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {:.1} % |",
            p.name,
            c.n,
            c.median,
            c.p99,
            c.max,
            if f.n == 0 { "-".to_string() } else { f.max.to_string() },
            100.0 * mean * DEFAULT_TICK_HZ / CORE_HZ
        );
    }
    md.push('\n');
    for p in &streamed {
        let (stream_keys, table) = stream_figures(p);
        keys.extend(stream_keys);
        md.push_str(&table);
    }
    for p in all_profiles {
        md.push_str(&job_table(p));
        md.push('\n');
    }
    Ok(Figures { keys, markdown: md })
}

/// The streamed output's figures from its job's fills: each handler run ticks
/// [`STREAM_SLOTS`] slots, and the DMA plays the other half meanwhile, so a fill must end
/// within [`STREAM_SLOTS`] slot periods. Over the fills of job motion (a DDA function ran, the
/// machine not homing): the slot clock the longest holds (at most
/// [`motion::config::MAX_STREAM_TICK_HZ`]) gives the step rate, one step per axis every other
/// slot, and the mean fill's share of the core at the stream's fastest clock the CPU figure.
/// The fills in which the machine supervises its slots are reported apart: homing (the run
/// homes first), more than [`SUPERVISED_FULL_TICKS`] full machine ticks (the machine not quiet:
/// a freeze at the end of homing, an input changing) and no motion, which includes the boot's
/// at the safe default's 50 kHz, where the machine (in Fault until the host sends a config) runs
/// a full tick on every slot.
fn stream_figures(p: &JobProfile) -> (Vec<(&'static str, f64)>, String) {
    let supervised = |i: &&trace::Instance| {
        matches!(JobProfile::situation(i), IDLE | HOMING) || i.entries > SUPERVISED_FULL_TICKS
    };
    let moving: Vec<u32> =
        p.instances.iter().filter(|i| !supervised(i)).map(|i| i.cycles).collect();
    let c = Stats::of(moving);
    let still = Stats::of(p.instances.iter().filter(supervised).map(|i| i.cycles).collect());
    let max_slot_hz = motion::config::MAX_STREAM_TICK_HZ as f64;
    let held_hz = max_slot_hz.min(STREAM_SLOTS * CORE_HZ / (c.max.max(1) as f64));
    let per_axis = (held_hz * STEPS_PER_TICK_PER_AXIS).floor();
    let fills_per_s = max_slot_hz / STREAM_SLOTS;
    let cpu = 100.0 * c.mean * fills_per_s / CORE_HZ;
    let keys = vec![
        ("step_rate_max_hz_per_axis", per_axis),
        ("step_rate_max_hz_aggregate", per_axis * PROFILED_AXES),
        ("stream_fill_cycles_max", c.max as f64),
        ("stream_cycles_per_slot_mean", (c.mean / STREAM_SLOTS * 10.0).round() / 10.0),
        ("stream_cpu_percent_500khz", (cpu * 100.0).round() / 100.0),
        ("stream_fill_cycles_max_full_ticks", still.max as f64),
    ];
    let budget = STREAM_SLOTS * CORE_HZ / max_slot_hz;
    let table = format!(
        "Streamed step output ({}): {} fills of {} slots that moved, at {} kHz; cycles per fill \
         min / median / p99 / max {} / {} / {} / {} (a fill's budget at {} kHz: {:.0} cycles); \
         mean {:.1} cycles per slot, {:.1} % of the core; the longest holds a {:.0} kHz slot \
         clock. {} fills homing, with the machine not quiet or with no motion: median {}, max {} \
         cycles (the max: {:.1} per slot).\n\n",
        p.name,
        c.n,
        STREAM_SLOTS,
        max_slot_hz / 1e3,
        c.min,
        c.median,
        c.p99,
        c.max,
        max_slot_hz / 1e3,
        budget,
        c.mean / STREAM_SLOTS,
        cpu,
        held_hz / 1e3,
        still.n,
        still.median,
        still.max,
        still.max as f64 / STREAM_SLOTS
    );
    (keys, table)
}

/// A wire segment of the thesis die takes ~6 s at its area rate; 0.3 s of it is the same
/// handler, tick after tick.
const WIRE_TICKS: usize = 30_000;

/// The jobs: what a user runs, short enough to trace every instruction (~0.2-0.5 s of
/// machine time each).
fn jobs(root: &Path, work: &Path, elf: &Path, stream_elf: &Path) -> Result<Vec<Job>> {
    let s = |x: &str| x.to_string();
    let fw = [s("--qemu"), s("--firmware"), elf.display().to_string()];
    let job4 = work.join("job4.toml");
    std::fs::write(&job4, FOUR_AXIS_JOB)?;
    let job4_stream = work.join("job4-stream.toml");
    std::fs::write(&job4_stream, stream_job_toml())?;
    let stream = work.join("limacon-arc.bin");
    std::fs::write(
        &stream,
        motionctl::polar::run::first_blocks(motion::polar::limacon_stream::BYTES, 6)?,
    )?;
    let with_fw = |mut a: Vec<String>, extra: &[&str]| {
        a.extend(fw.iter().cloned());
        a.extend(extra.iter().map(|x| x.to_string()));
        a
    };
    Ok(vec![
        Job {
            name: "4-axis segments",
            stream: false,
            args: with_fw(vec![s("run"), job4.display().to_string()], &["--yes"]),
            max_ticks: None,
        },
        Job {
            name: STREAM_JOB,
            stream: true,
            args: vec![
                s("run"),
                job4_stream.display().to_string(),
                s("--yes"),
                s("--qemu"),
                s("--firmware"),
                stream_elf.display().to_string(),
            ],
            max_ticks: None,
        },
        Job {
            name: "milling (force loop)",
            stream: false,
            args: with_fw(
                vec![
                    s("milling"),
                    s("run"),
                    root.join("motionctl/examples/case_a_milling.toml").display().to_string(),
                ],
                &[],
            ),
            max_ticks: None,
        },
        Job {
            name: "turning (Z slide)",
            stream: false,
            args: with_fw(
                vec![s("turning"), s("run")],
                &[
                    "--rpm",
                    "360",
                    "--x-end",
                    "0.02",
                    "--feed",
                    "0.1",
                    "--blend",
                    "0.005",
                    "--output",
                    "steps",
                    "--tick-hz",
                    "100000",
                ],
            ),
            max_ticks: None,
        },
        Job {
            name: "polar playback",
            stream: false,
            args: with_fw(
                vec![s("polar"), s("run"), stream.display().to_string()],
                &["--speed", "2"],
            ),
            max_ticks: None,
        },
        Job {
            name: "wire",
            stream: false,
            args: with_fw(vec![s("wire"), s("run")], &["--segments", "1..3"]),
            max_ticks: Some(WIRE_TICKS),
        },
    ])
}

/// Four axes moving in every move: long moves cruise, short ones change segments, and the
/// direction reverses on every axis.
const FOUR_AXIS_JOB: &str = r#"# cargo xtask isr-profile: X, Y, Z, A all moving, 100 kHz tick
format = "motion-job"
version = 1

[machine]
tick_hz = 100_000

[machine.timing]
pulse_ns = 2_500
dir_setup_ns = 5_000
dir_hold_ns = 5_000

[[machine.axes]]
name = "X"
steps_per_mm = 100.0
max_rate_mm_s = 200.0
accel_mm_s2 = 3_000.0
junction_jerk_mm_s = 8.0
min_mm = -200.0
max_mm = 200.0

[[machine.axes]]
name = "Y"
steps_per_mm = 100.0
max_rate_mm_s = 200.0
accel_mm_s2 = 3_000.0
junction_jerk_mm_s = 8.0
min_mm = -200.0
max_mm = 200.0

[[machine.axes]]
name = "Z"
steps_per_mm = 320.0
max_rate_mm_s = 40.0
accel_mm_s2 = 800.0
junction_jerk_mm_s = 2.0
min_mm = -40.0
max_mm = 40.0

[[machine.axes]]
name = "A"
steps_per_mm = 80.0
max_rate_mm_s = 150.0
accel_mm_s2 = 2_000.0
junction_jerk_mm_s = 5.0
min_mm = -720.0
max_mm = 720.0

[[moves]]
to = { X = 8.0, Y = 5.0, Z = -1.0, A = 4.0 }
feed_mm_min = 5_400.0

[[moves]]
to = { X = 12.0, Y = 10.0, Z = -1.5, A = 8.0 }

[[moves]]
to = { X = 12.3, Y = 10.2, Z = -1.55, A = 8.2 }

[[moves]]
to = { X = 12.5, Y = 10.5, Z = -1.6, A = 8.4 }

[[moves]]
to = { X = 6.0, Y = 7.0, Z = -0.8, A = 3.0 }

[[moves]]
to = { X = 1.0, Y = 1.5, Z = -0.1, A = 0.5 }
"#;

/// The streamed output's job: its fastest slot clock (500 kHz, 1-tick pulses: drivers that take
/// 1 us pulses, as fast steppers' do), four axes at 250 kHz each (1000 steps/mm at 250 mm/s)
/// in the first move, and back at 250 kHz on the longest axis in the second (the others in
/// proportion), each move ramping up from and down to a stop.
fn stream_job_toml() -> String {
    let mut toml = String::from(
        "# cargo xtask isr-profile: four axes stepping at 250 kHz each from a 500 kHz slot clock\n\
         format = \"motion-job\"\nversion = 1\n\n[machine]\ntick_hz = 500_000\n\n\
         [machine.timing]\npulse_ns = 1_000\ndir_setup_ns = 1_000\ndir_hold_ns = 1_000\n",
    );
    for axis in ["X", "Y", "Z", "A"] {
        let _ = write!(
            toml,
            "\n[[machine.axes]]\nname = \"{axis}\"\nsteps_per_mm = 1_000.0\nmax_rate_mm_s = 250.0\n\
             accel_mm_s2 = 25_000.0\njunction_jerk_mm_s = 5.0\nmin_mm = -100.0\nmax_mm = 100.0\n"
        );
    }
    toml.push_str(
        "\n[[moves]]\nto = { X = 15.0, Y = 15.0, Z = 15.0, A = 15.0 }\nfeed_mm_min = 60_000.0\n\
         \n[[moves]]\nto = { X = 3.0, Y = 5.0, Z = 7.0, A = 9.0 }\n",
    );
    toml
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_streamed_job_is_four_axes_at_250_khz_from_a_500_khz_slot_clock() {
        let job = motionctl::job::parse_toml(&stream_job_toml()).unwrap();
        let m = &job.machine;
        assert_eq!(m.tick_hz, motion::config::MAX_STREAM_TICK_HZ);
        assert_eq!(m.axes.len(), 4);
        for a in &m.axes {
            assert_eq!(a.steps_per_mm * a.max_rate_mm_s, 250_000.0, "{}", a.name);
        }
        assert_eq!(job.items.len(), 2);
    }
}
