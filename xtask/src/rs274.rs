//! `cargo xtask rs274-oracle`: motion-gcode against LinuxCNC's own interpreter. Every file of
//! the real-world corpus (host/gcode/tests/corpus, sources in its SOURCES.md) and every project
//! test program (host/gcode/tests/programs) goes through `rs274` (LinuxCNC's rs274ngc, from
//! Debian's linuxcnc-uspace, installed under target/rs274 on first use) and through
//! motion-gcode; the canonical calls must be the same, line for line, to rs274's four decimals,
//! and a file rs274 refuses must be refused too. The one allowed difference is a grbl habit
//! rs274 refuses and motion-gcode accepts with a warning (a sender `$` line, `K0` on a G17 arc,
//! no program end): then every call rs274 made before it stopped must be motion-gcode's first.

use anyhow::{bail, Context, Result};
use motion_gcode::{render, Canon, Event, Interpreter, Kind, Options};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// Tools T1..T20 in rs274's tool table: what the corpus's tool changes ask for.
const TOOLS: u32 = 20;
/// The parameter that selects the active coordinate system (1 = G54) in rs274's var file.
const PARAM_COORD_SYSTEM: &str = "5220";

struct Rs274 {
    bin: PathBuf,
    lib: PathBuf,
    /// A var file with every offset zero (as motion-gcode starts): copied fresh for each run,
    /// since rs274 writes the parameters back when a program ends.
    var_zero: String,
    tools: PathBuf,
    work: PathBuf,
}

/// rs274 the way ../shared/tools/rs274 installs it: `apt-get download linuxcnc-uspace`,
/// unpacked (not installed: it would pull in a desktop), plus the one runtime library.
fn install(root: &Path) -> Result<Rs274> {
    let dir = root.join("target/rs274");
    let unpacked = dir.join("root");
    let bin = unpacked.join("usr/bin/rs274");
    if !bin.exists() {
        std::fs::create_dir_all(&dir)?;
        println!(
            "installing LinuxCNC's rs274 (apt-get download linuxcnc-uspace) into {}",
            dir.display()
        );
        let ok = Command::new("apt-get")
            .args(["download", "linuxcnc-uspace"])
            .current_dir(&dir)
            .status()
            .map(|s| s.success())
            .unwrap_or(false);
        if !ok {
            // A fresh machine may not have the package lists yet.
            crate::run_status("apt-get update", Command::new("apt-get").arg("update"))?;
            crate::run_status(
                "apt-get download linuxcnc-uspace",
                Command::new("apt-get").args(["download", "linuxcnc-uspace"]).current_dir(&dir),
            )?;
        }
        let deb = std::fs::read_dir(&dir)?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .find(|p| p.extension().is_some_and(|e| e == "deb"))
            .context("apt-get download left no .deb")?;
        crate::run_status("dpkg -x", Command::new("dpkg").arg("-x").arg(&deb).arg(&unpacked))?;
    }
    let lib = unpacked.join("usr/lib");
    let ldd = Command::new("ldd").arg(&bin).env("LD_LIBRARY_PATH", &lib).output()?;
    if String::from_utf8_lossy(&ldd.stdout).contains("not found") {
        crate::run_status(
            "apt-get install libboost-python1.74.0",
            Command::new("apt-get")
                .args(["install", "-y", "--no-install-recommends", "libboost-python1.74.0"])
                .env("DEBIAN_FRONTEND", "noninteractive"),
        )?;
    }
    let sample = unpacked
        .join("usr/share/doc/linuxcnc/examples/sample-configs/sim/qtvcp_screens/sim-9axis.var");
    let var = std::fs::read_to_string(&sample)
        .with_context(|| format!("reading rs274's sample var file {}", sample.display()))?;
    let var_zero: String = var
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .map(|p| {
            let v = if p == PARAM_COORD_SYSTEM { "1.000000" } else { "0.000000" };
            format!("{p}\t{v}\n")
        })
        .collect();
    let work = dir.join("work");
    std::fs::create_dir_all(&work)?;
    let tools = work.join("tools.tbl");
    let table: String = (1..=TOOLS).map(|t| format!("T{t} P{t} D0 Z0 ;\n")).collect();
    std::fs::write(&tools, table)?;
    Ok(Rs274 { bin, lib, var_zero, tools, work })
}

/// What one interpreter made of a file.
struct Outcome {
    calls: Vec<String>,
    /// Messages of the errors (rs274: its stderr; ours: error diagnostics).
    errors: Vec<String>,
    /// Ours only: grbl habits accepted with a warning.
    grbl_habits: Vec<String>,
}

impl Rs274 {
    fn run(&self, file: &Path) -> Result<Outcome> {
        let var = self.work.join("rs274ngc.var");
        std::fs::write(&var, &self.var_zero)?;
        let out_file = self.work.join("out.txt");
        let run = Command::new(&self.bin)
            .arg("-g")
            .arg("-v")
            .arg(&var)
            .arg("-t")
            .arg(&self.tools)
            .arg(file)
            .arg(&out_file)
            .env("LD_LIBRARY_PATH", &self.lib)
            .stdin(Stdio::null())
            .output()
            .with_context(|| format!("running {}", self.bin.display()))?;
        let text = std::fs::read_to_string(&out_file).unwrap_or_default();
        // "   12 N..... STRAIGHT_FEED(...)": the call after the counter and the N field.
        let calls = text
            .lines()
            .filter_map(|l| l.split_once('N').map(|(_, rest)| rest))
            .filter_map(|rest| rest.split_once(' ').map(|(_, call)| call.trim().to_string()))
            .filter(|c| c != "ON_RESET()")
            .collect();
        let errors = String::from_utf8_lossy(&run.stderr)
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty() && *l != "executing")
            .map(str::to_string)
            .collect();
        Ok(Outcome { calls, errors, grbl_habits: Vec::new() })
    }
}

fn ours(file: &Path) -> Result<Outcome> {
    let interp = Interpreter::open(file, Options::default())
        .with_context(|| format!("opening {}", file.display()))?;
    let mut o = Outcome { calls: Vec::new(), errors: Vec::new(), grbl_habits: Vec::new() };
    for e in interp {
        match e {
            Event::Call(c) if matches!(c.canon, Canon::OnReset) => {}
            Event::Call(c) => o.calls.push(render(&c.canon)),
            Event::Diagnostic(d) if d.is_error() => o.errors.push(d.message.clone()),
            Event::Diagnostic(d) if matches!(d.kind, Kind::Grbl(_)) => {
                o.grbl_habits.push(format!("line {}: {}", d.line, d.message))
            }
            Event::Diagnostic(_) => {}
        }
    }
    Ok(o)
}

/// Files of `dir` with a G-code extension, sorted.
fn gcode_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("reading {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension().and_then(|e| e.to_str()).is_some_and(|e| {
                matches!(e.to_ascii_lowercase().as_str(), "ngc" | "nc" | "gcode" | "tap")
            })
        })
        .collect();
    v.sort();
    Ok(v)
}

pub fn check(root: &Path) -> Result<()> {
    let rs = install(root)?;
    let gcode = root.join("host/gcode/tests");
    let mut files = gcode_files(&gcode.join("corpus"))?;
    files.extend(gcode_files(&gcode.join("programs"))?);
    let (mut same, mut habits, mut calls_total) = (0, 0, 0);
    let mut failures = Vec::new();
    for f in &files {
        let name = f.strip_prefix(&gcode).unwrap_or(f).display().to_string();
        let (theirs, mine) = (rs.run(f)?, ours(f)?);
        let habit = !theirs.errors.is_empty() && !mine.grbl_habits.is_empty();
        let verdict = if habit && mine.calls.starts_with(&theirs.calls) {
            habits += 1;
            calls_total += theirs.calls.len();
            format!(
                "same up to rs274's stop, then a grbl habit accepted ({}; {} more calls); \
                 rs274: {}",
                mine.grbl_habits[0],
                mine.calls.len() - theirs.calls.len(),
                theirs.errors[0]
            )
        } else if let Some(k) = (0..theirs.calls.len().max(mine.calls.len()))
            .find(|&k| theirs.calls.get(k) != mine.calls.get(k))
        {
            failures.push(format!(
                "{name}: call {} differs: rs274 {:?}, motion-gcode {:?}",
                k + 1,
                theirs.calls.get(k),
                mine.calls.get(k)
            ));
            "DIFFERENT".into()
        } else if theirs.errors.is_empty() != mine.errors.is_empty() {
            failures.push(format!(
                "{name}: rs274 errors {:?}, motion-gcode errors {:?}",
                theirs.errors, mine.errors
            ));
            "DIFFERENT".into()
        } else {
            same += 1;
            calls_total += theirs.calls.len();
            match theirs.errors.first() {
                Some(e) => format!("same, both refuse: {e}"),
                None => "same".into(),
            }
        };
        println!("  {name:<52} {:>6} calls  {verdict}", theirs.calls.len());
    }
    println!(
        "rs274 oracle: {same} of {} files the same call for call, {habits} the same up to a grbl \
         habit rs274 refuses ({calls_total} calls compared), {} different",
        files.len(),
        failures.len()
    );
    if !failures.is_empty() {
        bail!("motion-gcode differs from LinuxCNC's rs274:\n{}", failures.join("\n"));
    }
    Ok(())
}
