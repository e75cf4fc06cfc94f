//! `cargo xtask bench`: DDA micro-benchmarks in QEMU, firmware sizes, and the derived figures,
//! written to `target/bench.json` (one flat object, merged with what is there) and to the
//! generated section of BENCHMARKS.md.

use crate::firmware::{self, Board};
use crate::{divcheck, golden};
use anyhow::{bail, Context, Result};
use object::{Object, ObjectSection};
use std::collections::BTreeMap;
use std::path::Path;

const BEGIN: &str = "<!-- bench:begin -->";
const END: &str = "<!-- bench:end -->";
/// 10 % of a 168 MHz Cortex-M4 core, in cycles per second.
const BUDGET_CYCLES_PER_S: f64 = 16_800_000.0;

enum Target {
    AtMost(f64),
    AtLeast(f64),
    /// |value| at most this.
    Within(f64),
}

const TARGETS: [(&str, Target); 13] = [
    // The whole tick handler of the link firmware, modelled cycles (cargo xtask isr-profile).
    ("isr_cycles_cruise_4axes", Target::AtMost(168.0)),
    ("isr_instr_idle", Target::AtMost(40.0)),
    ("isr_cycles_max", Target::AtMost(840.0)),
    // grblHAL reaches ~400 kHz per axis on an F446.
    ("step_rate_max_hz_per_axis", Target::AtLeast(250_000.0)),
    ("step_rate_max_hz_aggregate", Target::AtLeast(1_000_000.0)),
    ("flash_bytes_link", Target::AtMost(96.0 * 1024.0)),
    ("ram_bytes_link", Target::AtMost(48.0 * 1024.0)),
    // Douglass: the Z command at >= 20 kHz; here within 10 % of the core.
    ("zslide_update_hz_at_10pct", Target::AtLeast(20_000.0)),
    // Elbestawi: force sample to the override reaching the DDA.
    ("force_sample_to_dda_us", Target::AtMost(200.0)),
    // Fahim: the limacon at 16000 steps/rev digitized on the host.
    ("polar_digitize_limacon_ms", Target::AtMost(50.0)),
    // Bhatti: the continuous circle -> complex job's time against 60 A / FR, within 1 %.
    ("wire_job_time_vs_60a_fr_ppm", Target::Within(10_000.0)),
    // G-code streamed: a 1 000 000-line surfacing file read, checked and planned (bench_gcode.rs).
    ("gcode_plan_segments_per_s", Target::AtLeast(1_000_000.0)),
    ("gcode_plan_peak_rss_mb", Target::AtMost(64.0)),
];

/// DDA tick rate of the milling scenario, whose tick applies the override (src/milling/scenario.rs).
const MILLING_TICK_HZ: f64 = motion::milling::scenario::TICK_HZ as f64;

/// Capability figures derived from the kernel counts (`kernel_*`): rates at 10 % of the core,
/// and the force path's latency from an ADC sample to the DDA acting on the new override.
fn derive_capability_figures(f: &mut BTreeMap<String, f64>) {
    let get = |f: &BTreeMap<String, f64>, k: &str| f.get(k).copied();
    if let Some(z) = get(f, "kernel_zslide_update_power_cubic_instr") {
        f.insert("zslide_update_hz_at_10pct".into(), (BUDGET_CYCLES_PER_S / z.max(1.0)).floor());
    }
    if let Some(z) = get(f, "kernel_zslide_update_harmonic8_cubic_instr") {
        f.insert(
            "zslide_update_harmonic8_hz_at_10pct".into(),
            (BUDGET_CYCLES_PER_S / z.max(1.0)).floor(),
        );
    }
    // The streamed step output's fill, per slot (a half buffer is 64 slots).
    if let Some(fill) = get(f, "kernel_stream_fill_64_slots_4axes_instr_mean") {
        f.insert("kernel_stream_instr_per_slot_4axes".into(), (fill / 64.0 * 10.0).round() / 10.0);
    }
    if let (Some(s), Some(c)) =
        (get(f, "kernel_force_chain_sample_instr"), get(f, "kernel_force_control_update_instr"))
    {
        // The decimating sample and the control update run in the same tick (one cycle per
        // instruction at 168 MHz); the DDA uses the override from the next tick on.
        let work_us = (s + c) / 168.0;
        let us = work_us + 1e6 / MILLING_TICK_HZ;
        f.insert("force_sample_to_dda_us".into(), (us * 10.0).round() / 10.0);
    }
}

/// Ticks and per-tick cost of the closed-loop scenarios in QEMU (`scenario_cost` lines).
fn scenario_costs(root: &Path) -> Result<Vec<(String, f64)>> {
    let elf = firmware::build_bin(root, "scenarios", Board::Netduinoplus2, &[])?;
    let run = firmware::run_qemu_for(&elf, std::time::Duration::from_secs(300))?;
    let mut out = Vec::new();
    for line in run.texts() {
        let Some(rest) = line.strip_prefix("scenario_cost ") else { continue };
        let kv: BTreeMap<&str, &str> =
            rest.split_whitespace().filter_map(|w| w.split_once('=')).collect();
        let (Some(name), Some(ticks), Some(cycles)) =
            (kv.get("name"), kv.get("ticks"), kv.get("cycles"))
        else {
            bail!("bad scenario_cost line: {line}");
        };
        let (ticks, cycles): (f64, f64) = (ticks.parse()?, cycles.parse()?);
        if ticks > 0.0 {
            out.push((
                format!("scenario_{name}_instr_per_tick"),
                (cycles / ticks * 10.0).round() / 10.0,
            ));
        }
    }
    // The wire job's machine time against 60 A / FR, from the host model (same as QEMU: the
    // scenario comparison in `cargo xtask test` proves it).
    let mut s = motion::wire::scenario::WireJobScenario::new()
        .map_err(|e| anyhow::anyhow!("wire job: {e:?}"))?;
    let r = motion::scenario::run_to_end(&mut s, motion::scenarios::HOST_MAX_TICKS);
    let ppm = r.figure("time_vs_ref_ppm").context("wire job time figure")? as f64;
    out.push(("wire_job_time_vs_60a_fr_ppm".into(), ppm));
    Ok(out)
}

/// `quick`: only the DDA figures, printed, nothing written (for working on the tick).
pub fn run(root: &Path, quick: bool) -> Result<()> {
    let bench_elf = firmware::build(root, Board::Netduinoplus2, &["bench"])?;
    let demo_elf = firmware::build(root, Board::Netduinoplus2, &[])?;
    divcheck::check_elf(&demo_elf)?;

    println!("running the benchmarks in QEMU ({})", bench_elf.display());
    let run = firmware::run_qemu(&bench_elf)?;
    run.print("  fw| ");
    let mut figures = kernel_names(parse_bench_lines(run.texts())?);
    for key in [
        "kernel_dda_tick_instr_idle",
        "kernel_dda_tick_instr_moving",
        "kernel_dda_tick_instr_1axis",
        "kernel_dda_tick_instr_4axes",
    ] {
        if !figures.contains_key(key) {
            bail!("the benchmark firmware did not report `{key}`");
        }
    }
    derive_capability_figures(&mut figures);
    if quick {
        for (k, v) in &figures {
            println!("{k:<40} {v}");
        }
        return Ok(());
    }

    let (flash, ram) = sizes(&demo_elf)?;
    figures.insert("flash_bytes".into(), flash as f64);
    figures.insert("ram_bytes".into(), ram as f64);

    println!("timing the demo run in QEMU");
    let demo = firmware::run_qemu(&demo_elf)?;
    golden::parse(&demo)?;
    figures.insert("demo_qemu_seconds".into(), (demo.wall.as_secs_f64() * 100.0).round() / 100.0);

    println!("streaming the end-to-end job to the link firmware in QEMU (motionctl, no noise)");
    for (k, v) in crate::e2e::bench(root)? {
        figures.insert(k.into(), v);
    }

    println!("per-tick cost of the closed-loop scenarios in QEMU");
    for (k, v) in scenario_costs(root)? {
        figures.insert(k, v);
    }
    println!("digitizing the limacon (Fahim) on the host");
    let (ms, events) = motionctl::polar::bench::bench_limacon();
    if events == 0 {
        bail!("the limacon benchmark produced no events");
    }
    figures.insert("polar_digitize_limacon_ms".into(), (ms * 100.0).round() / 100.0);
    figures.insert("polar_digitize_limacon_events".into(), events as f64);

    println!("planning a 1 000 000-line G-code surfacing file (motionctl plan, streamed)");
    figures.extend(crate::bench_gcode::bench(root)?.into_iter().map(|(k, v)| (k.into(), v)));

    println!("fuzzing the board's receive path with 10 million hostile inputs");
    for (k, v) in fuzz_decoder(root, 10_000_000)? {
        figures.insert(k.into(), v);
    }

    println!("the fault-injection suite (cargo xtask faults)");
    figures.extend(faults_section(root)?.into_iter().map(|(k, v)| (k.into(), v)));

    println!("profiling the link firmware's whole tick handler on each capability's job");
    let isr = crate::isr_profile::run(root, &[])?;
    for (k, v) in &isr.keys {
        figures.insert((*k).into(), *v);
    }
    // The image a user flashes (the real board, no simulator hooks) carries the targets; the
    // QEMU board's (with the test hooks the simulator needs) is reported beside it.
    for (board, suffix) in [(Board::F405Motion, ""), (Board::Netduinoplus2, "_qemu")] {
        let link_elf = firmware::build(root, board, &["link"])?;
        let (flash, ram) = sizes(&link_elf)?;
        figures.insert(format!("flash_bytes_link{suffix}"), flash as f64);
        figures.insert(format!("ram_bytes_link{suffix}"), ram as f64);
    }

    let json_path = root.join("target/bench.json");
    write_json(&json_path, &figures)?;
    let md_path = root.join("BENCHMARKS.md");
    let notes = format!(
        "{NOTES}
### The tick handler, job by job

{}",
        isr.markdown
    );
    write_markdown(&md_path, &figures, &notes)?;
    // The README carries the same table (its notes point to BENCHMARKS.md).
    let readme = root.join("README.md");
    write_markdown(&readme, &figures, "")?;
    println!();
    print!("{}", table(&figures));
    println!("\nwrote {}, {} and {}", json_path.display(), md_path.display(), readme.display());
    Ok(())
}

/// The protocol fuzz test (host-tests/tests/protocol_fuzz.rs) at `inputs` inputs: frame decoder,
/// message decoder and board session on random, mutated and spliced frames. Any panic fails it.
fn fuzz_decoder(root: &Path, inputs: u64) -> Result<Vec<(&'static str, f64)>> {
    let out = crate::cargo(root)
        .args(["test", "-p", "host-tests", "--profile", "test-fast", "--test", "protocol_fuzz"])
        .args(["board_survives_a_million_hostile_inputs", "--", "--nocapture"])
        .env("FUZZ_INPUTS", inputs.to_string())
        .output()?;
    let text = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        anyhow::bail!("the fuzz run failed:\n{text}\n{}", String::from_utf8_lossy(&out.stderr));
    }
    // "fuzz: N inputs in 11.2s: ..."
    let line = text.lines().find(|l| l.starts_with("fuzz: ")).context("no fuzz summary line")?;
    let mut words = line.split_whitespace().skip(1);
    let n: f64 = words.next().context("fuzz count")?.parse()?;
    let secs = words.nth(2).context("fuzz time")?.trim_end_matches(':');
    let secs: f64 = secs.trim_end_matches('s').parse().context("fuzz time")?;
    Ok(vec![
        ("fuzz_decoder_inputs", n),
        ("fuzz_decoder_panics", 0.0),
        ("fuzz_decoder_seconds", (secs * 10.0).round() / 10.0),
    ])
}

/// The bench firmware's one-function tick counts under a `kernel_` prefix, so nobody reads
/// one function in a loop as the whole interrupt handler (`isr_*` are the handler's).
fn kernel_names(figures: BTreeMap<String, f64>) -> BTreeMap<String, f64> {
    figures
        .into_iter()
        .map(|(k, v)| {
            let part = k.starts_with("dda_tick_") || k.starts_with("tick_apply_");
            (if part { format!("kernel_{k}") } else { k }, v)
        })
        .collect()
}

/// Keys earlier versions wrote that would now mislead (one function read as the handler).
fn retired(key: &str) -> bool {
    key.starts_with("dda_tick_") || key.starts_with("tick_apply_") || key == "max_tick_hz_at_10pct"
}

/// `bench key=value` lines -> figures.
pub fn parse_bench_lines<'a>(
    lines: impl Iterator<Item = &'a str>,
) -> Result<BTreeMap<String, f64>> {
    let mut m = BTreeMap::new();
    let mut done = false;
    for line in lines {
        let Some(rest) = line.trim().strip_prefix("bench ") else {
            continue;
        };
        if rest == "done" {
            done = true;
            continue;
        }
        let (k, v) = rest.split_once('=').with_context(|| format!("bad bench line: {line}"))?;
        let v: f64 = v.parse().with_context(|| format!("bad bench value: {line}"))?;
        m.insert(k.to_string(), v);
    }
    if !done {
        bail!("the benchmark firmware did not finish (no `bench done` line)");
    }
    Ok(m)
}

/// Flash: every section loaded into flash (.vector_table, .text, .rodata and the .data image).
/// RAM: statically allocated RAM (.data, .bss, .uninit); the stack takes the rest of the 128 KiB.
fn sizes(elf: &Path) -> Result<(u64, u64)> {
    let bytes = std::fs::read(elf)?;
    let file = object::File::parse(&*bytes)?;
    let size = |name: &str| file.section_by_name(name).map(|s| s.size()).unwrap_or(0);
    let flash = size(".vector_table") + size(".text") + size(".rodata") + size(".data");
    let ram = size(".data") + size(".bss") + size(".uninit");
    Ok((flash, ram))
}

/// `cargo xtask bench-gcode`: the G-code figures alone ([`crate::bench_gcode::bench`]), merged
/// into `target/bench.json`.
pub fn gcode_only(root: &Path) -> Result<()> {
    let mut map = BTreeMap::new();
    for (k, v) in crate::bench_gcode::bench(root)? {
        println!("{k:<32} {v}");
        map.insert(k.to_string(), v);
    }
    let json = root.join("target/bench.json");
    write_json(&json, &map)?;
    println!("wrote {}", json.display());
    Ok(())
}

pub(crate) fn write_json(path: &Path, figures: &BTreeMap<String, f64>) -> Result<()> {
    let mut obj = match std::fs::read_to_string(path) {
        Ok(s) => match serde_json::from_str::<serde_json::Value>(&s) {
            Ok(serde_json::Value::Object(o)) => o,
            _ => {
                println!("note: {} was not a JSON object; rewriting it", path.display());
                serde_json::Map::new()
            }
        },
        Err(_) => serde_json::Map::new(),
    };
    obj.retain(|k, _| !retired(k));
    for (k, &v) in figures {
        let n = if v.fract() == 0.0 && v.abs() < 9e15 {
            serde_json::Value::from(v as i64)
        } else {
            serde_json::Value::from(v)
        };
        obj.insert(k.clone(), n);
    }
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)?;
    }
    std::fs::write(path, serde_json::to_string_pretty(&serde_json::Value::Object(obj))? + "\n")?;
    Ok(())
}

fn fmt_num(v: f64) -> String {
    if v.fract() == 0.0 {
        format!("{}", v as i64)
    } else {
        format!("{v:.2}")
    }
}

fn table(figures: &BTreeMap<String, f64>) -> String {
    let mut t =
        String::from("| figure | value | target | met? (margin) |\n| --- | ---: | --- | --- |\n");
    let mut rows: Vec<(&str, String, String, String)> = Vec::new();
    for (k, target) in &TARGETS {
        let Some(&v) = figures.get(*k) else { continue };
        let (goal, met) = match target {
            Target::AtMost(g) => (format!("<= {}", fmt_num(*g)), v <= *g),
            Target::AtLeast(g) => (format!(">= {}", fmt_num(*g)), v >= *g),
            Target::Within(g) => (format!("within +-{}", fmt_num(*g)), v.abs() <= *g),
        };
        let g = match target {
            Target::AtMost(g) | Target::AtLeast(g) | Target::Within(g) => *g,
        };
        let margin = match target {
            Target::AtMost(_) => (g - v) / g * 100.0,
            Target::AtLeast(_) => (v - g) / g * 100.0,
            Target::Within(_) => (g - v.abs()) / g * 100.0,
        };
        let verdict = format!("{} ({margin:+.0} %)", if met { "yes" } else { "NO" });
        rows.push((k, fmt_num(v), goal, verdict));
    }
    for (k, &v) in figures {
        if TARGETS.iter().any(|(t, _)| t == k) {
            continue;
        }
        rows.push((k, fmt_num(v), "-".into(), "-".into()));
    }
    for (k, v, g, m) in rows {
        t.push_str(&format!("| `{k}` | {v} | {g} | {m} |\n"));
    }
    t
}

const INTRO: &str = "# Benchmarks

Generated by `cargo xtask bench`; the section between the markers is rewritten on every run, and
the same figures (plus any other capability's) are in `target/bench.json`.

";

const NOTES: &str = "
How these are measured:

- `kernel_*_instr`: one call of a capability's interrupt-rate function in the bench firmware,
  counted like the tick (max over the calls; `_mean` the mean), with the state advancing between
  calls: `zslide_update_power_cubic` / `zslide_update_harmonic8_cubic` (the Z command, power form
  on the Douglass table and the harmonic form at K = 8, cubic in X), `spindle_encoder_update`,
  `spindle_resolver_update`, `force_chain_sample` (the max is the sample that completes a
  decimation), `force_control_update`, `polar_playback_tick`.
- `zslide_update_hz_at_10pct` (and `_harmonic8_`): 16 800 000 / the update's max count.
- `force_sample_to_dda_us`: the decimating ADC sample and the control update (max counts, one
  cycle per instruction at 168 MHz) plus one tick of the force scenario's 50 kHz DDA, which acts
  on the new override from its next tick. Samples that do not complete a decimation only feed the
  anti-alias filter (its group delay, about 0.45 ms, is filtering, not processing latency).
- `scenario_*_instr_per_tick`: instructions per scenario tick in the QEMU scenario firmware, sim
  board included (a plant model, sim sensors and the trace hash run in every tick).
- `polar_digitize_limacon_ms`: median of 5 runs of the Fahim digitizer on the limacon
  3 + 2 cos at 16 000 steps/rev (19 036 events), in xtask's own build (opt-level s, overflow
  checks on), so a release build is faster.
- `wire_job_time_vs_60a_fr_ppm`: the continuous circle -> complex job's machine time against
  60 A / FR for the exact ruled area (host model; the QEMU run is bit-identical).

- `isr_*`, `step_rate_*`: the whole TIM2 handler of the link firmware (the one people flash),
  entry to exception return with every callee, on every tick of real jobs streamed to it in QEMU
  (`cargo xtask isr-profile`: a 4-axis TOML job at the default 100 kHz tick, Case A milling, a
  Z-slide turning job, a polar playback, 30 000 ticks of a wire job). QEMU single-steps with an
  execution trace; each executed instruction is costed with the Cortex-M4 Technical Reference
  Manual's timings (table in xtask/src/isr_profile/disasm.rs: 1 cycle for data processing, MUL
  and UMULL-class, 2 for MLA, 12 for a divide (the worst case), 2 for a single load (1 when
  pipelined behind another), 1 for a store, 1 + N for LDM/STM/PUSH/POP, + 2 for a taken branch's
  pipeline refill) plus 12 cycles of exception entry and 10 of return; code runs from flash
  behind the ART accelerator, assumed to hit (the `ART misses` columns below charge the F405's 5
  wait states at 168 MHz on every taken branch into flash). While a job is quiet, 7 ticks in 8
  are step-only (`Machine::fast_tick`: the DDA, a force, event or wire job or a Z job with step
  outputs, the step counters and soft limits) and the 8th is
  a full tick (inputs, debounce, faults, holds, job bookkeeping, outputs, wakes): medians are
  step-only ticks, p99 and max full ones, and the CPU figure is the mean over both. The traced
  QEMU runs hundreds of times slower than the board, so the profiler gives motionctl's link and
  job watchdogs a patience factor (`MOTIONCTL_PATIENCE`, here 100) instead of wall-clock limits
  meant for a real board.
  `isr_cycles_cruise_4axes`: median over ticks where four axes cruise; `isr_cycles_p99`/`_max`: over every tick of every job; `isr_instr_idle`: median
  instructions of a tick with nothing to do. The force chain runs in its own interrupt on both
  boards (DMA2 stream 0, the tick's priority: the real board's ADC DMA; on the QEMU board the
  tick pends it on each plant sample and it runs right after the tick), traced the same way:
  `isr_force_cycles_max` is its longest run. `isr_cpu_percent_default_tick`: the largest job's
  mean cycles per tick, the tick handler's plus the force interrupt's spread over the ticks,
  x 100 kHz / 168 MHz. `tick_irq_step_rate_max_hz_per_axis`: with a tick interrupt, the DDA
  steps an axis at most every other tick, at the fastest tick the worst case fits in (168 MHz /
  the largest job's longest tick plus its longest force interrupt, as if both fell on one tick;
  at most the default 100 kHz).
  `step_rate_max_hz_per_axis`, `_aggregate` and `stream_*`: the link firmware built with the
  streamed step output (`--features step-stream`, QEMU board: TIM2 at the fill rate stands in
  for the DMA's half interrupt), traced the same way on a job of four axes at 250 kHz each from
  a 500 kHz slot clock with 1-tick (1 us) pulses (`cargo xtask isr-profile streamed`). Each
  handler run fills a half buffer of 40 slots, one machine tick per slot (the step-only ticks
  the machine grants in one call, `Machine::fast_fill`, the DDA running them a fast run at a
  time), and must end before the DMA has played the other half: 40 slots = 13 440 cycles at
  500 kHz. Over the fills of
  job motion (the DDA ran, the machine quiet: not homing, at most 10 full machine ticks in
  the fill): `stream_fill_cycles_max` the longest, `step_rate_max_hz_per_axis` half the slot clock
  it holds (168 MHz x 40 / that, at most 500 kHz), `_aggregate` four axes at that rate,
  `stream_cycles_per_slot_mean` and `stream_cpu_percent_500khz` the mean fill per slot and its
  share of the core at 500 kHz. `stream_fill_cycles_max_full_ticks`: the longest of the other
  fills, while the machine homes, is not quiet or nothing moves (the boot's: the machine in
  Fault until the host sends a config; the homing before the job and its end): the machine then
  runs a full tick on at most every 5th slot (`Machine::held_tick` between), 8 per fill, which
  must fit the half as well (on a board a late fill lets the DMA play the last half's words
  again). The board can time its own handler: the link firmware built with the
  `isr-cycles` feature reads its cycle counter on entry and before return and logs a histogram
  every 100 ms over defmt (`firmware/src/isr_cycles.rs`). On an F405 that is DWT CYCCNT, the
  check of this cycle model: `cargo run --release -p motion-firmware --bin link
  --no-default-features --features board-f405-motion,isr-cycles` (probe-rs runner, the lines
  `isr-cycles since boot: N runs, mean, p50, p99, max, cpu per mille`). Under QEMU the same build
  counts instructions (TIM5 under `-icount shift=0`): `cargo xtask isr-cycles` runs these jobs
  with it, a cross-check of the trace by other means (separate runs; the maxima agree within 2 %, the
  counter reading the handler from inside: 4-axis job 1236 vs 1244 traced, turning 1729 vs 1738).
- `kernel_dda_tick_instr_*`: instructions for one `Dda::tick()` in the QEMU netduinoplus2 firmware,
  counted with TIM5 at QEMU's 1 GHz timer clock under `-icount shift=0` (one instruction = 1 ns),
  minus the cost of an empty measurement. Classes: `idle` (no segment), `moving` (in a segment,
  no step this tick), `1axis` / `4axes` / `6axes` (that many rising edges), `segment_change`
  (the tick that finishes or starts a segment), `first_tick` (a fresh DDA's first tick). Plain
  keys are the maximum over all samples of the class, `_mean` keys the mean.
  `kernel_tick_apply_instr_*` adds the board's step-port `apply` (on QEMU: the `StepRecorder`
  that stands in for the GPIO pins). One function in a loop: a part of the handler, not the
  handler (see `isr_*`).
- `kernel_stream_*`: the step output past the tick interrupt's ceiling (in the link firmware
  for the QEMU board: `stream_*` above). One interrupt per tick pays its entry, exit and bookkeeping every tick, so the step
  rate ends where the handler fills the core (`step_rate_max_hz_per_axis`). The chosen design, as
  the fastest grblHAL and Klipper drivers do: a timer at the slot rate requests DMA of one word
  per slot from a circular buffer into the step port's set/reset register (the F405's GPIOC
  `BSRR`; TIM1's update on DMA2 stream 5, TIM8 being the force ADC's), and the half-transfer interrupt runs the DDA for the half just
  played, one tick per slot (`motion::dda::edge_stream`: `PortWords::fill`). It keeps the DDA
  as it is (the step generator proven equal to the host model, exact counts and the half-step
  line by construction) and costs per slot whatever number of axes step. Output compare per
  axis (an interrupt per step, as Klipper schedules them: 46 cycles per step on an F407) needs
  each step's time computed ahead, a different step generator, and two timers for six axes; it
  was not built to compare. QEMU models
  neither the DMA nor TIM1, so the counts and timing are proven on the host model
  (host-tests/tests/edge_stream.rs: random jobs, overrides and holds at a 500 kHz slot clock
  replayed through a model of `BSRR`: the pins rise on exactly the DDA's slots and axes, every
  step within half a step of the line, pulse, setup and hold met, and four axes at 250 kHz each,
  1 MHz together). `kernel_stream_fill_64_slots_4axes_instr`: the bench firmware filling a
  64-slot half buffer with four axes stepping at 250 kHz each (max and `_mean`);
  `kernel_stream_instr_per_slot_4axes`: the mean per slot. A part, not the whole: the machine's
  step counters and supervision and the interrupt's entry and exit are not in it.
- `flash_bytes`: `.vector_table + .text + .rodata + .data` of the release demo firmware
  (`flash_bytes_link`, `ram_bytes_link`: the same for the link firmware a user flashes, built
  for the real board, f405-motion, without the simulator's test hooks; `_qemu`: the link
  firmware for the QEMU board, netduinoplus2, with the `sim-inputs` hooks the tests drive).
  `ram_bytes`: static RAM, `.data + .bss + .uninit` (the stack uses the rest of the 128 KiB).
- `demo_qemu_seconds`: wall time of one QEMU run of the demo job.
- `link_segments_per_s`: segments acknowledged per wall second while `motionctl run --qemu`
  streams the 2000-segment end-to-end job (xtask/src/e2e.rs) to the link firmware, no noise,
  from the first batch to the last acknowledgement (bounded by the job once the queue is full).
  `link_status_hz`: status reports received per second of board time at the default 40 ms period.
- `fuzz_decoder_*`: the protocol fuzz test (host-tests/tests/protocol_fuzz.rs,
  `board_survives_a_million_hostile_inputs`) run with `FUZZ_INPUTS=10000000`: random bytes,
  valid frames, bit-flipped, truncated and spliced frames through the board's frame decoder,
  message decoder and session; any panic would fail the run. CI runs the same test at 1e6.
";

/// Rewrites the marked section of `path` with the figures table followed by `notes`.
fn write_markdown(path: &Path, figures: &BTreeMap<String, f64>, notes: &str) -> Result<()> {
    let section = format!("{}{notes}", table(figures));
    replace_section(path, (BEGIN, END), &section, INTRO)
}

/// Rewrites what lies between the `markers` of `path` with `section` (appended with the markers
/// when they are missing; a missing file starts with `intro`).
/// Runs the fault-injection suite and writes its reliability section into BENCHMARKS.md;
/// returns its bench.json keys.
fn faults_section(root: &Path) -> Result<Vec<(&'static str, f64)>> {
    let (section, keys) = crate::faults::report::bench(root)?;
    replace_section(&root.join("BENCHMARKS.md"), crate::faults::report::MARKERS, &section, "")?;
    Ok(keys)
}

/// `cargo xtask bench-faults`: only the suite's part of `bench`, merged into bench.json.
pub fn bench_faults(root: &Path) -> Result<()> {
    let keys = faults_section(root)?;
    let json = root.join("target/bench.json");
    let map: BTreeMap<String, f64> = keys.into_iter().map(|(k, v)| (k.to_string(), v)).collect();
    write_json(&json, &map)?;
    println!("wrote BENCHMARKS.md (reliability) and {}", json.display());
    Ok(())
}

pub(crate) fn replace_section(
    path: &Path,
    (begin, end): (&str, &str),
    section: &str,
    intro: &str,
) -> Result<()> {
    let section = format!("{begin}\n{section}{end}");
    let text = match std::fs::read_to_string(path) {
        Ok(s) => match (s.find(begin), s.find(end)) {
            (Some(b), Some(e)) if b < e => format!("{}{section}{}", &s[..b], &s[e + end.len()..]),
            _ => format!("{}\n\n{section}\n", s.trim_end()),
        },
        Err(_) => format!("{intro}{section}\n"),
    };
    std::fs::write(path, text)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_bench_lines_and_rewrites_only_the_section() {
        let lines = ["motion-board", "bench a=1", "bench b_mean=2.5", "bench done"];
        let m = parse_bench_lines(lines.into_iter()).unwrap();
        assert_eq!(m["a"], 1.0);
        assert_eq!(m["b_mean"], 2.5);
        assert!(parse_bench_lines(["bench a=1"].into_iter()).is_err());

        let dir = std::env::temp_dir().join(format!("xtask-bench-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let md = dir.join("B.md");
        std::fs::write(&md, format!("# T\nkeep me\n{BEGIN}\nSTALE-SECTION\n{END}\ntail\n"))
            .unwrap();
        write_markdown(&md, &m, NOTES).unwrap();
        let s = std::fs::read_to_string(&md).unwrap();
        assert!(s.starts_with("# T\nkeep me\n<!-- bench:begin -->\n| figure"));
        assert!(s.ends_with("<!-- bench:end -->\ntail\n") && !s.contains("STALE-SECTION"));

        let json = dir.join("bench.json");
        std::fs::write(&json, r#"{"other_capability": 7, "a": 0}"#).unwrap();
        write_json(&json, &m).unwrap();
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        assert_eq!(v["other_capability"], 7);
        assert_eq!(v["a"], 1);
        assert_eq!(v["b_mean"], 2.5);
        std::fs::remove_dir_all(dir).unwrap();
    }
}
