//! Project automation: `cargo xtask <command>`.
//!
//! | command | what it does |
//! | --- | --- |
//! | `build [--board B] [--bench] [--link]` | a release firmware binary of `firmware/` (`demo`; `--link`: the host-link firmware; `--bench`) for a board (`netduinoplus2` default, `f405-motion`), copied to `target/fw-<board>[-link|-bench]/firmware` |
//! | `demo` | runs the demo firmware in QEMU, decodes its log, summarises the report, compares with the host model |
//! | `test` | everything CI checks, in order, failing fast |
//! | `polar-e2e` | `motionctl polar run` plays the limacon event stream on the link firmware in QEMU (speed 2, size 3:2) and checks it against the host model |
//! | `copy-e2e` | `motionctl polar copy --qemu` copies a limacon template at 3:2 with teach on the link firmware in QEMU (simulated encoders), checks it against the host model, and replays the taught stream with `polar run` at speed 2 |
//! | `wire-e2e` | `motionctl wire run --qemu` runs 4 segments of the circle -> complex die as a wire job on the link firmware in QEMU with one injected wire stall, and checks the stall, retrace, return and exact final position |
//! | `turning-e2e` | `motionctl turning run --qemu` runs the Douglass table as a Z-slide job on the link firmware in QEMU (360 rpm; steps, then DAC with a +20 % speed step) and checks it against the host model |
//! | `grbl-e2e` | `motionctl grbl --qemu --pty` with the link firmware in QEMU behind it: a third-party sender (grbl-streamer) streams a corpus file with a hold, a resume, a feed override, a jog and its cancel, ending at its programmed end; then `$MILL=`, `$TURN=` and `$WIRE=` from the same port, each ending as the host model |
//! | `milling-e2e` | `motionctl milling run --qemu` runs Case A and a 1500 N job of other numbers as force jobs on the link firmware in QEMU (simulated plant), then Case A with a stuck force channel, and checks settling to each job's Fnom, final position and the fault hold |
//! | `faults` | the fault-injection suite: board faults on the host model, reset, power cut, link drop and USART overrun bursts on the link firmware in QEMU, the config record, every bad-input class of `motionctl`; writes `target/faults.json` |
//! | `bench` | DDA micro-benchmarks in QEMU, sizes; writes `target/bench.json` and `BENCHMARKS.md` |
//! | `bench-faults` | only the fault suite's figures of `bench`: runs `faults`, rewrites the reliability section of BENCHMARKS.md, merges `faults_injected` / `faults_survived` into `target/bench.json` |
//! | `bench-gcode` | only the G-code planning figures of `bench`: `motionctl plan` (release) of a generated 1 000 000-line surfacing file, segments/s and peak RSS, merged into `target/bench.json` |
//! | `isr-profile [JOB]...` | the whole TIM2 handler of the link firmware, every tick of real jobs in QEMU (instruction trace), instructions and modelled cycles by situation |
//! | `isr-cycles [JOB]...` | the isr-profile jobs on the link firmware built with `isr-cycles`: the board's own count of its tick handler (instructions under QEMU, DWT cycles on an F405) |
//! | `flash <board>` | builds and runs the firmware on a real board with `probe-rs run` (`f405-motion`: the `link` firmware) |
//! | `decode-log ELF LOG` | prints the defmt log a firmware wrote (a QEMU log of `faults` or `motionctl --qemu`) as text |
//!
//! Every command first makes sure the pinned toolchain, the thumb target, `llvm-tools` and
//! `qemu-system-arm` are installed.

mod bench;
mod bench_gcode;
mod copy_e2e;
mod divcheck;
mod e2e;
mod faults;
mod firmware;
mod gcode_corpus;
mod gcode_e2e;
mod golden;
mod grbl_e2e;
mod isr_profile;
mod milling_e2e;
mod modcycles;
mod polar_e2e;
mod rs274;
mod scenarios;
mod setup;
mod turning_e2e;
mod wire_e2e;

use anyhow::{bail, Context, Result};
use firmware::Board;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

const USAGE: &str = "usage: cargo xtask <command>

commands:
  build [--board netduinoplus2|f405-motion] [--bench] [--link]
                                                        build a release firmware (demo; --link: the host-link
                                                        firmware, ELF in target/fw-<board>-link/firmware)
  demo                                                  run the demo job in QEMU and compare with the host model
  test [--skip WORD]...                                 run every CI check (skip steps whose name contains WORD)
  scenarios                                             run the closed-loop scenarios in QEMU, compare with the host model, print the reports
  polar-e2e                                             play the limacon event stream on the link firmware in QEMU, check it
  copy-e2e                                              copy a template in QEMU with teach, check it, replay the taught stream
  wire-e2e                                              run a wire job with an injected stall on the link firmware in QEMU, check it
  turning-e2e                                            run Z-slide jobs (steps; DAC + 20 % speed step) on the link firmware in QEMU, check them
  milling-e2e                                           run Case A as a force job on the link firmware in QEMU (+ a stuck channel), check it
  faults [--only scenarios|tests|inputs|qemu]...        the fault-injection suite (host model, simulated board, QEMU,
                                                        motionctl's bad inputs); counts in target/faults.json
  grbl-e2e                                              a grbl sender streams a corpus file through motionctl grbl to QEMU (hold, jog),
                                                        then $MILL=, $TURN= and $WIRE= run from the same port
  bench [--quick]                                       run the DDA benchmarks in QEMU, write target/bench.json and BENCHMARKS.md
                                                        (--quick: DDA tick figures only, printed)
  bench-faults                                          only the fault suite's figures of bench: the reliability section
                                                        of BENCHMARKS.md, faults_* in target/bench.json
  bench-gcode                                           only the G-code planning figures: motionctl plan of a generated
                                                        1 000 000-line surfacing file (segments/s, peak RSS), merged
                                                        into target/bench.json
  isr-profile [JOB]...                                   trace every instruction of the link firmware's tick
                                                        interrupt on real jobs in QEMU; per-tick instructions
                                                        and modelled cycles by situation (ISR_PROFILE_PCS=DIR:
                                                        also executions per PC, for llvm-symbolizer)
  isr-cycles [JOB]...                                    the same jobs on the link firmware built with isr-cycles:
                                                        the board times its own tick handler (instructions
                                                        under QEMU, DWT cycles on an F405) and logs it
  gcode-e2e                                             run real G-code files on the simulated board and in QEMU
  gcode-corpus [--all] [FILE]...                        run the corpus files (planned <= 30 s; --all: every one) in
                                                        QEMU: hash, end position and path checked; target/gcode-corpus.json
  rs274-oracle                                          compare motion-gcode with LinuxCNC's rs274, call for call,
                                                        on the G-code corpus and test programs
  qemu ELF SECONDS                                       run a firmware ELF in QEMU for at most SECONDS, print its
                                                        decoded defmt log
  flash <netduinoplus2|f405-motion>                     build and run on a board with probe-rs
                                                        (f405-motion: the host-link firmware)";

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(cmd) = args.first() else {
        println!("{USAGE}");
        return Ok(());
    };
    let rest = &args[1..];
    if matches!(cmd.as_str(), "help" | "-h" | "--help") {
        println!("{USAGE}");
        return Ok(());
    }
    let root = root();
    match cmd.as_str() {
        "build" => {
            let (board, extra) = parse_build_args(rest)?;
            setup::ensure(&root)?;
            let elf = firmware::build(&root, board, &extra)?;
            println!("built {}", elf.display());
            Ok(())
        }
        "demo" => {
            no_args(cmd, rest)?;
            setup::ensure(&root)?;
            golden::demo(&root)
        }
        "test" => {
            // `--skip WORD` (repeatable): skip steps whose name contains WORD, for local use.
            let mut skip = Vec::new();
            let mut it = rest.iter();
            while let Some(a) = it.next() {
                match a.as_str() {
                    "--skip" => skip.push(it.next().context("--skip needs a value")?.clone()),
                    other => bail!("unknown test option `{other}`"),
                }
            }
            setup::ensure(&root)?;
            test(&root, &skip)
        }
        "polar-e2e" => {
            no_args(cmd, rest)?;
            setup::ensure(&root)?;
            polar_e2e::test(&root)
        }
        "copy-e2e" => {
            no_args(cmd, rest)?;
            setup::ensure(&root)?;
            copy_e2e::test(&root)
        }
        "wire-e2e" => {
            no_args(cmd, rest)?;
            setup::ensure(&root)?;
            wire_e2e::test(&root)
        }
        "turning-e2e" => {
            no_args(cmd, rest)?;
            setup::ensure(&root)?;
            turning_e2e::test(&root)
        }
        "milling-e2e" => {
            no_args(cmd, rest)?;
            setup::ensure(&root)?;
            milling_e2e::test(&root)
        }
        "grbl-e2e" => {
            no_args(cmd, rest)?;
            setup::ensure(&root)?;
            grbl_e2e::test(&root)
        }
        "scenarios" => {
            no_args(cmd, rest)?;
            setup::ensure(&root)?;
            scenarios::show(&root)
        }
        "bench" => {
            let quick = match rest {
                [] => false,
                [q] if q == "--quick" => true,
                _ => bail!("usage: cargo xtask bench [--quick]"),
            };
            setup::ensure(&root)?;
            bench::run(&root, quick)
        }
        "faults" => {
            // `--only PART` (repeatable): run only these parts of the suite, for local use.
            let mut only = Vec::new();
            let mut it = rest.iter();
            while let Some(a) = it.next() {
                match (a.as_str(), it.next()) {
                    ("--only", Some(p)) if faults::PARTS.contains(&p.as_str()) => {
                        only.push(p.clone())
                    }
                    _ => bail!("usage: cargo xtask faults [--only {}]...", faults::PARTS.join("|")),
                }
            }
            setup::ensure(&root)?;
            faults::run(&root, &only)
        }
        "bench-faults" => {
            no_args(cmd, rest)?;
            setup::ensure(&root)?;
            bench::bench_faults(&root)
        }
        "bench-gcode" => {
            no_args(cmd, rest)?;
            bench::gcode_only(&root)
        }
        "isr-profile" => {
            setup::ensure(&root)?;
            let figures = isr_profile::run(&root, rest)?;
            for (key, value) in &figures.keys {
                println!("{key:<36} {value}");
            }
            Ok(())
        }
        "isr-cycles" => {
            setup::ensure(&root)?;
            isr_profile::cycles::run(&root, rest).map(drop)
        }
        "rs274-oracle" => rs274::check(&root),
        "gcode-e2e" => gcode_e2e::test(&root),
        "gcode-corpus" => gcode_corpus::command(&root, rest),
        "qemu" => {
            let [elf, secs] = rest else { bail!("usage: cargo xtask qemu ELF SECONDS") };
            let run = firmware::run_qemu_for(
                std::path::Path::new(elf),
                std::time::Duration::from_secs(secs.parse()?),
            )?;
            run.print("  fw| ");
            Ok(())
        }
        "decode-log" => {
            let [elf, log] = rest else { bail!("usage: cargo xtask decode-log ELF LOG") };
            let bytes = std::fs::read(log).with_context(|| format!("reading {log}"))?;
            // A QEMU log starts with QEMU's own text lines; defmt resynchronises after them.
            for line in firmware::decode_text(std::path::Path::new(elf), &bytes)? {
                println!("{line}");
            }
            Ok(())
        }
        "flash" => {
            let [board] = rest else {
                bail!("usage: cargo xtask flash <netduinoplus2|f405-motion>")
            };
            let board = Board::parse(board)?;
            setup::ensure(&root)?;
            flash(&root, board)
        }
        other => bail!("unknown command `{other}`\n\n{USAGE}"),
    }
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask lives in the workspace root")
        .to_path_buf()
}

fn no_args(cmd: &str, rest: &[String]) -> Result<()> {
    if !rest.is_empty() {
        bail!("`{cmd}` takes no arguments (got {rest:?})");
    }
    Ok(())
}

/// The board and the extra firmware features (`bench`, `link`) of `cargo xtask build`.
fn parse_build_args(rest: &[String]) -> Result<(Board, Vec<&'static str>)> {
    let mut board = Board::Netduinoplus2;
    let mut bench = false;
    let mut link = false;
    let mut it = rest.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--board" => {
                board = Board::parse(it.next().context("--board needs a value")?)?;
            }
            "--bench" => bench = true,
            "--link" => link = true,
            other => match other.strip_prefix("--board=") {
                Some(b) => board = Board::parse(b)?,
                None => bail!("unknown build option `{other}`"),
            },
        }
    }
    if bench && link {
        bail!("--bench and --link both replace the demo job: pick one");
    }
    let mut extra = Vec::new();
    if bench {
        extra.push("bench");
    }
    if link {
        extra.push("link");
    }
    Ok((board, extra))
}

/// The firmware and board crates build for the thumb target only: host steps leave them out.
pub(crate) const HOST_EXCLUDES: [&str; 8] = [
    "--exclude",
    "motion-firmware",
    "--exclude",
    "board-netduinoplus2",
    "--exclude",
    "board-f405-motion",
    "--exclude",
    "board-stm32f405",
];

/// `cargo` as the one running xtask, with the workspace as working directory.
pub fn cargo(root: &Path) -> Command {
    let mut c = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
    c.current_dir(root);
    c
}

/// Runs a command to completion with inherited output; an error names `what` failed.
pub fn run_status(what: &str, cmd: &mut Command) -> Result<()> {
    let status = cmd.status().with_context(|| format!("{what}: could not start {cmd:?}"))?;
    if !status.success() {
        bail!("{what} failed ({status})");
    }
    Ok(())
}

fn test(root: &Path, skip: &[String]) -> Result<()> {
    type Step<'a> = (&'a str, Box<dyn Fn() -> Result<()> + 'a>);
    // Every firmware binary of the firmware crate at once, for one board and feature set.
    let clippy_thumb =
        |board: Board, extra: &'static [&'static str]| -> Box<dyn Fn() -> Result<()>> {
            Box::new(move || {
                run_status(
                    "clippy",
                    cargo(root)
                        .args(["clippy", "--release", "--target", firmware::TARGET])
                        .args(["-p", firmware::PACKAGE, "--bins", "--no-default-features"])
                        .args(["--features", &firmware::features(board, extra)])
                        .args(["--target-dir", "target/clippy-thumb", "--", "-D", "warnings"]),
                )
            })
        };
    let build = |board: Board, extra: &'static [&'static str]| -> Box<dyn Fn() -> Result<()>> {
        Box::new(move || firmware::build(root, board, extra).map(drop))
    };
    let steps: Vec<Step> = vec![
        (
            "cargo fmt --check",
            Box::new(|| {
                run_status("cargo fmt", cargo(root).args(["fmt", "--all", "--", "--check"]))
            }),
        ),
        (
            "clippy (host)",
            Box::new(|| {
                run_status(
                    "clippy",
                    cargo(root)
                        .args(["clippy", "--workspace", "--all-targets"])
                        .args(HOST_EXCLUDES)
                        .args(["--", "-D", "warnings"]),
                )
            }),
        ),
        ("no import cycles between modules of any crate", Box::new(|| modcycles::check(root))),
        (
            "G-code: motion-gcode == LinuxCNC's rs274 on the corpus and the test programs",
            Box::new(|| rs274::check(root)),
        ),
        (
            "clippy (firmware: link, demo, bench, scenarios; netduinoplus2)",
            clippy_thumb(Board::Netduinoplus2, &[]),
        ),
        ("clippy (firmware, netduinoplus2 tamper)", clippy_thumb(Board::Netduinoplus2, &["tamper"])),
        (
            "clippy (firmware with isr-cycles, both boards: the DWT handler timing)",
            Box::new(|| {
                clippy_thumb(Board::Netduinoplus2, &["isr-cycles"])()?;
                clippy_thumb(Board::F405Motion, &["isr-cycles"])()
            }),
        ),
        (
            "clippy (firmware: link, demo, bench, scenarios; f405-motion)",
            clippy_thumb(Board::F405Motion, &[]),
        ),
        (
            "clippy (link firmware with the streamed step output, netduinoplus2)",
            Box::new(|| {
                run_status(
                    "clippy",
                    cargo(root)
                        .args(["clippy", "--release", "--target", firmware::TARGET])
                        .args(["-p", firmware::PACKAGE, "--bin", "link"])
                        .args(["--no-default-features", "--features"])
                        .arg(firmware::features(Board::Netduinoplus2, &["step-stream"]))
                        .args(["--target-dir", "target/clippy-thumb", "--", "-D", "warnings"]),
                )
            }),
        ),
        (
            "clippy (firmware, f405-motion with the SPI resolver, then the SPI force ADC)",
            Box::new(|| {
                clippy_thumb(Board::F405Motion, &["board-f405-motion/resolver-spi"])()?;
                clippy_thumb(Board::F405Motion, &["board-f405-motion/force-spi"])()
            }),
        ),
        (
            "host tests",
            // Optimised with overflow checks and debug assertions kept (see Cargo.toml).
            Box::new(|| {
                run_status(
                    "cargo test",
                    cargo(root)
                        .args(["test", "--workspace", "--profile", "test-fast"])
                        .args(HOST_EXCLUDES),
                )
            }),
        ),
        ("firmware build (netduinoplus2)", build(Board::Netduinoplus2, &[])),
        ("firmware build (f405-motion)", build(Board::F405Motion, &[])),
        ("firmware build (f405-motion link)", build(Board::F405Motion, &["link"])),
        (
            "firmware build (scenarios, netduinoplus2)",
            Box::new(|| firmware::build_bin(root, "scenarios", Board::Netduinoplus2, &[]).map(drop)),
        ),
        ("firmware build (netduinoplus2 bench)", build(Board::Netduinoplus2, &["bench"])),
        (
            "no software divide reachable from TIM2 (demo and link on both boards, streamed link, scenarios)",
            Box::new(|| {
                for (board, features) in [
                    (Board::Netduinoplus2, &[][..]),
                    (Board::Netduinoplus2, &["link"][..]),
                    (Board::F405Motion, &[][..]),
                    (Board::F405Motion, &["link"][..]),
                ] {
                    let elf = firmware::build(root, board, features)?;
                    divcheck::check_elf(&elf)?;
                }
                // The streamed output's fill interrupt (the same TIM2 vector).
                divcheck::check_elf(&e2e::stream_firmware(root)?)?;
                // The scenario firmware's tick runs every capability's interrupt-rate code.
                let elf = firmware::build_bin(root, "scenarios", Board::Netduinoplus2, &[])?;
                divcheck::check_elf(&elf)
            }),
        ),
        ("QEMU golden scenario (firmware == host model)", Box::new(|| golden::golden(root))),
        ("tamper build is caught by the golden comparison", Box::new(|| golden::tamper(root))),
        ("QEMU closed-loop scenarios (firmware == host model)", Box::new(|| scenarios::test(root))),
        (
            "end to end: motionctl streams 2000 segments to QEMU through 1 % noise",
            Box::new(|| e2e::test(root)),
        ),
        (
            "end to end: the streamed step output (500 kHz slots) runs the 2000 segments on QEMU",
            Box::new(|| e2e::stream_test(root)),
        ),
        (
            "end to end: motionctl plays the limacon event stream on QEMU (speed 2, size 3:2)",
            Box::new(|| polar_e2e::test(root)),
        ),
        (
            "end to end: motionctl runs a wire job on QEMU with an injected stall",
            Box::new(|| wire_e2e::test(root)),
        ),
        (
            "end to end: motionctl runs Z-slide jobs on QEMU (360 rpm, 20 % speed step)",
            Box::new(|| turning_e2e::test(root)),
        ),
        (
            "end to end: motionctl runs Case A as a force job on QEMU (+ a stuck channel)",
            Box::new(|| milling_e2e::test(root)),
        ),
        (
            "end to end: motionctl copies a template on QEMU with teach (3:2), replays it at speed 2",
            Box::new(|| copy_e2e::test(root)),
        ),
        (
            "end to end: real G-code files on the simulated board and in QEMU",
            Box::new(|| gcode_e2e::test(root)),
        ),
        (
            "end to end: a grbl sender through motionctl grbl to QEMU, then $MILL= $TURN= $WIRE=",
            Box::new(|| grbl_e2e::test(root)),
        ),
        (
            "fault injection: power cut, reset, link drop, overrun, config, bad inputs (faults)",
            Box::new(|| faults::run(root, &[])),
        ),
    ];
    let total = steps.len();
    let mut passed = 0;
    let mut skipped = 0;
    for (i, (name, step)) in steps.iter().enumerate() {
        if skip.iter().any(|w| name.contains(w.as_str())) {
            println!("\n==> [{}/{total}] {name}: SKIPPED", i + 1);
            skipped += 1;
            continue;
        }
        println!("\n==> [{}/{total}] {name}", i + 1);
        let t = std::time::Instant::now();
        if let Err(e) = step() {
            println!("\n{passed} passed, 1 failed");
            bail!("step `{name}` failed: {e:#}");
        }
        println!("==> ok: {name} ({:.1} s)", t.elapsed().as_secs_f64());
        passed += 1;
    }
    if skipped == 0 {
        println!("\n{passed} passed, 0 failed");
    } else {
        println!("\n{passed} passed, 0 failed, {skipped} skipped");
    }
    Ok(())
}

fn flash(root: &Path, board: Board) -> Result<()> {
    if setup::which("probe-rs").is_none() {
        bail!(
            "probe-rs is not on PATH; install it with:\n    cargo install probe-rs-tools --locked"
        );
    }
    // The real board runs what a user wants from it: the host link (the demo job needs no board).
    let extra: &[&str] = match board {
        Board::F405Motion => &["link"],
        Board::Netduinoplus2 => &[],
    };
    let elf = firmware::build(root, board, extra)?;
    let status = Command::new("probe-rs")
        .args(["run", "--chip", "STM32F405RGTx"])
        .arg(&elf)
        .current_dir(root)
        .status()
        .context("could not start probe-rs")?;
    if !status.success() {
        bail!(
            "probe-rs run failed ({status}): no debug probe was found or it could not reach the \
             STM32F405 (check the probe's USB connection and the board's SWD wiring and power)"
        );
    }
    Ok(())
}
