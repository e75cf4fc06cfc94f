//! Bad inputs to the real `motionctl`: every bad-input class (a closed pipe, unbounded sizes from
//! flags, NaN and degenerate geometry, table files with a bad row, stream files with a block
//! dropped, repeated or cut off, NaN in a job) as commands, and generated garbage from fixed
//! seeds (random and mutated job files, truncated stream files, oversized flags). A refused input
//! must exit non-zero with a message naming it; a closed pipe ends quietly with exit 0; nothing
//! panics. A mutated file may still be valid: then it must plan (exit 0).

use super::Tally;
use anyhow::{bail, Context, Result};
use motionctl::noise::XorShift;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// What a case must end with.
enum Expect {
    /// Exit non-zero, stderr containing this (the input named).
    Refused(String),
    /// Exit 0 (a reader that went away).
    Quiet,
    /// Exit 0, or non-zero with stderr containing this (a mutated input that may be valid).
    Either(String),
}

struct Case {
    class: &'static str,
    args: Vec<String>,
    expect: Expect,
    /// stdout to a pipe whose reader is gone.
    closed_pipe: bool,
}

fn case(class: &'static str, args: &[&str], expect: Expect) -> Case {
    Case { class, args: args.iter().map(|s| s.to_string()).collect(), expect, closed_pipe: false }
}

fn refused(s: &str) -> Expect {
    Expect::Refused(s.to_string())
}

/// A machine pole from which the limacon and the circle fit the work area.
const POLE: [&str; 4] = ["--pole-c", "5.1223", "--pole-beta", "4.0326"];
/// Seeds of the generated files (one file per seed and kind).
const SEEDS: std::ops::Range<u64> = 1..17;
/// Bytes of a random job file.
const GARBAGE_BYTES: usize = 600;
/// Bytes flipped in a mutated job file.
const MUTATIONS: usize = 6;

fn write(dir: &Path, name: &str, bytes: &[u8]) -> Result<String> {
    let p = dir.join(name);
    std::fs::write(&p, bytes).with_context(|| format!("writing {}", p.display()))?;
    Ok(p.display().to_string())
}

/// Printable garbage with G-code's and TOML's punctuation, so it reaches the parsers.
fn garbage(rng: &mut XorShift, n: usize) -> Vec<u8> {
    const ALPHABET: &[u8] = b"GMXYZFIJKRSTPNgxyz0123456789.-+ =[]\"#;()%\n\n\n";
    (0..n).map(|_| ALPHABET[(rng.next_u64() % ALPHABET.len() as u64) as usize]).collect()
}

fn mutate(rng: &mut XorShift, src: &[u8]) -> Vec<u8> {
    let mut b = src.to_vec();
    for _ in 0..MUTATIONS {
        let at = (rng.next_u64() % b.len() as u64) as usize;
        b[at] = b"0-9.e+nNaX[]=\n \""[(rng.next_u64() % 16) as usize];
    }
    b
}

/// The stream file every stream case starts from: the limacon of the polar e2e.
fn stream_file(root: &Path, bin: &Path, dir: &Path) -> Result<PathBuf> {
    let out = dir.join("limacon.stream");
    let status = Command::new(bin)
        .args(["polar", "digitize", "limacon:3,2"])
        .args(POLE)
        .args(["--vt", "0.5", "-o"])
        .arg(&out)
        .current_dir(root)
        .stdout(Stdio::null())
        .status()?;
    if !status.success() {
        bail!("could not digitize the limacon stream");
    }
    Ok(out)
}

fn cases(root: &Path, bin: &Path, dir: &Path) -> Result<Vec<Case>> {
    let stream = stream_file(root, bin, dir)?;
    let stream_s = stream.display().to_string();
    let digitize = |contour: &str, extra: &[&str]| -> Vec<String> {
        let mut v: Vec<String> = ["polar", "digitize", contour]
            .iter()
            .chain(&POLE)
            .chain(&["--vt", "0.5", "-o"])
            .map(|s| s.to_string())
            .collect();
        v.push(dir.join("out.stream").display().to_string());
        v.extend(extra.iter().map(|s| s.to_string()));
        v
    };
    let mut v = vec![
        Case { closed_pipe: true, ..case("broken pipe", &["turning", "table"], Expect::Quiet) },
        Case {
            closed_pipe: true,
            ..case("broken pipe", &["polar", "dump", &stream_s], Expect::Quiet)
        },
        Case {
            class: "unbounded sizes",
            args: digitize("limacon:3,2", &["--dr", "1e-12"]),
            expect: refused("events"),
            closed_pipe: false,
        },
        Case {
            class: "NaN / degenerate geometry",
            args: digitize("circle:0", &[]),
            expect: refused("degenerate"),
            closed_pipe: false,
        },
        Case {
            class: "NaN / degenerate geometry",
            args: digitize("witch:1,0,0", &[]),
            expect: refused("degenerate"),
            closed_pipe: false,
        },
        Case {
            class: "NaN / degenerate geometry",
            args: digitize("witch:1,2,nan", &[]),
            expect: refused("nan"),
            closed_pipe: false,
        },
        case(
            "NaN / degenerate geometry",
            &[
                "polar",
                "digitize",
                "limacon:3,2",
                "--pole-c",
                "nan",
                "--pole-beta",
                "0.4",
                "--vt",
                "0.5",
                "-o",
                "/dev/null",
            ],
            refused("the pole"),
        ),
    ];
    let die = write(dir, "degenerate.mdi", b"10\n4\n0,0,0,0\n0,0,0,0\n0,0,0,0\n0,0,0,0\n")?;
    v.push(case(
        "NaN / degenerate geometry",
        &["wire", "plan", "--mdi", &die],
        refused("cuts nothing"),
    ));
    let table =
        write(dir, "bad-last-row.txt", b"0 0 0 0 0\n0.1 0 0 0 0\n0.2 0 0 0 0\n0.3 0 0.001x 0 0\n")?;
    v.push(case(
        "file parsers dropping rows",
        &["turning", "run", "--sim", "--table", &table],
        refused(&format!("{table}:4:7")),
    ));
    let short = write(dir, "short-last-row.txt", b"0 0 0 0 0\n0.1 0 0 0 0\n0.2 0 0 0\n")?;
    v.push(case(
        "file parsers dropping rows",
        &["turning", "run", "--sim", "--table", &short],
        refused(&format!("{short}:3")),
    ));
    // A stream with a block dropped, one repeated, and cut at seeded points.
    let bytes = std::fs::read(&stream)?;
    let blocks = split_blocks(&bytes)?;
    if blocks.len() < 3 {
        bail!("the limacon stream has {} blocks, the cases need 3", blocks.len());
    }
    let end_mark = &bytes[bytes.len() - motion::polar::stream::END_BLOCK_LEN..];
    let dropped = [blocks[0], &blocks[2..].concat(), end_mark].concat();
    let repeated = [blocks[0], blocks[1], blocks[1], &blocks[2..].concat(), end_mark].concat();
    for (name, file) in [("dropped-block.stream", dropped), ("repeated-block.stream", repeated)] {
        let p = write(dir, name, &file)?;
        v.push(case("stream file blocks", &["polar", "dump", &p], refused("a block was dropped")));
    }
    let tail_lost = write(dir, "cut-at-a-block-boundary.stream", &blocks[..3].concat())?;
    // Refused by the dump and before a run touches the board, naming the file and the block.
    let why = format!("{tail_lost}: no end mark: the stream is cut after block 2");
    v.push(case("stream file blocks", &["polar", "dump", &tail_lost], refused(&why)));
    v.push(case("stream file blocks", &["polar", "run", &tail_lost, "--sim"], refused(&why)));
    let mut rng = XorShift::new(0x5eed);
    for seed in SEEDS {
        let cut = 1 + (rng.next_u64() % (bytes.len() as u64 - 1)) as usize;
        let p = write(dir, &format!("truncated-{seed}.stream"), &bytes[..cut])?;
        v.push(case("stream file blocks (generated)", &["polar", "dump", &p], refused("error")));
    }
    // Jobs: NaN, random and mutated.
    let square = std::fs::read_to_string(root.join("motionctl/examples/square.toml"))?;
    let nan = write(
        dir,
        "nan.toml",
        square.replacen("steps_per_mm = 80.0", "steps_per_mm = nan", 1).as_bytes(),
    )?;
    v.push(case("NaN in a job (generated)", &["plan", &nan], refused(&nan)));
    let machine = root.join("motionctl/examples/machine.toml").display().to_string();
    let part = std::fs::read(root.join("motionctl/examples/part.gcode"))?;
    for seed in SEEDS {
        let mut rng = XorShift::new(seed);
        let t = write(dir, &format!("garbage-{seed}.toml"), &garbage(&mut rng, GARBAGE_BYTES))?;
        v.push(case("garbage job files (generated)", &["plan", &t], refused(&t)));
        let g = write(dir, &format!("garbage-{seed}.gcode"), &garbage(&mut rng, GARBAGE_BYTES))?;
        v.push(case(
            "garbage job files (generated)",
            &["plan", &g, "--machine", &machine],
            Expect::Either(g.clone()),
        ));
        let m = write(dir, &format!("mutated-{seed}.toml"), &mutate(&mut rng, square.as_bytes()))?;
        v.push(case("mutated job files (generated)", &["plan", &m], Expect::Either(m.clone())));
        let m = write(dir, &format!("mutated-{seed}.gcode"), &mutate(&mut rng, &part))?;
        v.push(case(
            "mutated job files (generated)",
            &["plan", &m, "--machine", &machine],
            Expect::Either(m.clone()),
        ));
    }
    // Oversized flags.
    v.push(Case {
        class: "oversized flags (generated)",
        args: digitize("limacon:3,2", &["--dr", "1e-300"]),
        expect: refused("events"),
        closed_pipe: false,
    });
    for (args, names) in [
        (&["turning", "table", "--x-step", "1e-12"][..], "--x-step"),
        (&["turning", "table", "--x-max", "1e300"][..], "--x-max"),
        (&["turning", "table", "--harmonics", "4294967295"][..], "--harmonics"),
        (&["wire", "plan", "--fr", "1e308"][..], "(FR)"),
        (&["wire", "plan", "--fr", "1e9"][..], "(FR)"),
        (
            &["run", "motionctl/examples/square.toml", "--sim", "--status-ms", "99999999"][..],
            "--status-ms",
        ),
    ] {
        v.push(case("oversized flags (generated)", args, refused(names)));
    }
    Ok(v)
}

/// The data blocks of a stream file, as byte slices (its end block left off).
fn split_blocks(bytes: &[u8]) -> Result<Vec<&[u8]>> {
    motionctl::polar::run::blocks(bytes).context("the stream file does not parse")
}

fn check(root: &Path, bin: &Path, c: &Case) -> Result<()> {
    let mut cmd = Command::new(bin);
    cmd.args(&c.args).current_dir(root).stdin(Stdio::null()).stderr(Stdio::piped());
    if c.closed_pipe {
        // The reader is gone before the command writes its first byte.
        let (reader, writer) = std::io::pipe()?;
        drop(reader);
        cmd.stdout(writer);
    } else {
        cmd.stdout(Stdio::null());
    }
    let out = cmd.output().context("running motionctl")?;
    let err = String::from_utf8_lossy(&out.stderr);
    let first = err.lines().next().unwrap_or("").trim();
    if err.contains("panicked") {
        bail!("motionctl {} panicked: {err}", c.args.join(" "));
    }
    let ok = out.status.success();
    let args = c.args.join(" ");
    match &c.expect {
        Expect::Quiet if ok => Ok(()),
        Expect::Refused(name) | Expect::Either(name) if !ok && err.contains(name.as_str()) => {
            Ok(())
        }
        Expect::Either(_) if ok => Ok(()),
        Expect::Quiet => bail!("motionctl {args}: {} on a closed pipe: {first}", out.status),
        Expect::Refused(name) | Expect::Either(name) if !ok => {
            bail!("motionctl {args}: refused without naming `{name}`: {err}")
        }
        Expect::Refused(_) | Expect::Either(_) => {
            bail!("motionctl {args}: accepted (exit 0), should be refused")
        }
    }
}

pub fn run(root: &Path, bin: &Path, tally: &mut Tally) -> Result<()> {
    let dir = root.join("target/faults/inputs");
    std::fs::create_dir_all(&dir)?;
    let cases = cases(root, bin, &dir)?;
    let mut by_class = std::collections::BTreeMap::<&str, (u32, u32)>::new();
    for c in &cases {
        let r = check(root, bin, c);
        let e = by_class.entry(c.class).or_default();
        e.0 += 1;
        e.1 += r.is_ok() as u32;
        tally.record(c.class, 1, 1, r);
    }
    for (class, (n, ok)) in by_class {
        println!("  {class}: {ok} of {n} as documented");
    }
    Ok(())
}
