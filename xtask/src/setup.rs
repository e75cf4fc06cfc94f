//! Makes the machine ready: the pinned toolchain with the thumb target and `llvm-tools`, and QEMU.

use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::firmware::TARGET;

pub fn ensure(root: &Path) -> Result<()> {
    ensure_toolchain(root)?;
    ensure_qemu()?;
    ensure_python_venv()
}

/// python3 with `venv` and `pip`: the grbl bridge's test installs a third-party sender from PyPI
/// into a venv.
fn ensure_python_venv() -> Result<()> {
    let ready = || {
        Command::new("python3")
            .args(["-c", "import venv, ensurepip"])
            .stderr(std::process::Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    if ready() {
        return Ok(());
    }
    const PACKAGES: [&str; 2] = ["python3", "python3-venv"];
    if !is_root() {
        bail!(
            "python3 with venv is missing; install it as root with:\n    sudo apt-get install -y {}",
            PACKAGES.join(" ")
        );
    }
    println!("xtask: installing {}", PACKAGES.join(" "));
    crate::run_status("apt-get update", Command::new("apt-get").arg("update"))?;
    crate::run_status(
        "apt-get install python3-venv",
        Command::new("apt-get")
            .args(["install", "-y", "--no-install-recommends"])
            .args(PACKAGES)
            .env("DEBIAN_FRONTEND", "noninteractive"),
    )?;
    if !ready() {
        bail!("python3 venv is still missing after apt-get install");
    }
    Ok(())
}

fn stdout_of(cmd: &mut Command) -> Result<String> {
    let out = cmd.output().with_context(|| format!("could not start {cmd:?}"))?;
    if !out.status.success() {
        bail!("{cmd:?} failed: {}", String::from_utf8_lossy(&out.stderr).trim());
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// `rustup toolchain install` in the workspace installs what rust-toolchain.toml lists.
fn ensure_toolchain(root: &Path) -> Result<()> {
    let targets = stdout_of(
        Command::new("rustup").args(["target", "list", "--installed"]).current_dir(root),
    )?;
    let components = stdout_of(
        Command::new("rustup").args(["component", "list", "--installed"]).current_dir(root),
    )?;
    let has_target = targets.lines().any(|l| l.trim() == TARGET);
    let has_llvm_tools = components.lines().any(|l| l.trim().starts_with("llvm-tools"));
    if has_target && has_llvm_tools {
        return Ok(());
    }
    println!(
        "xtask: installing the pinned toolchain's missing parts (thumb target: {}, llvm-tools: {})",
        if has_target { "present" } else { "missing" },
        if has_llvm_tools { "present" } else { "missing" },
    );
    crate::run_status(
        "rustup toolchain install",
        Command::new("rustup").args(["toolchain", "install"]).current_dir(root),
    )?;
    // Older rustup versions do not add components to an already installed toolchain.
    if !has_target {
        crate::run_status(
            "rustup target add",
            Command::new("rustup").args(["target", "add", TARGET]).current_dir(root),
        )?;
    }
    if !has_llvm_tools {
        crate::run_status(
            "rustup component add",
            Command::new("rustup").args(["component", "add", "llvm-tools"]).current_dir(root),
        )?;
    }
    Ok(())
}

fn ensure_qemu() -> Result<()> {
    if which("qemu-system-arm").is_some() {
        return Ok(());
    }
    const INSTALL: &str =
        "apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y qemu-system-arm";
    if !is_root() {
        bail!("qemu-system-arm is not installed; install it as root with:\n    sudo sh -c '{INSTALL}'");
    }
    println!("xtask: installing qemu-system-arm: {INSTALL}");
    crate::run_status("apt-get update", Command::new("apt-get").arg("update"))?;
    crate::run_status(
        "apt-get install qemu-system-arm",
        Command::new("apt-get")
            .args(["install", "-y", "--no-install-recommends", "qemu-system-arm"])
            .env("DEBIAN_FRONTEND", "noninteractive"),
    )?;
    if which("qemu-system-arm").is_none() {
        bail!("qemu-system-arm is still missing after apt-get install");
    }
    Ok(())
}

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
        .unwrap_or(false)
}

/// The first `name` on PATH.
pub fn which(name: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path).map(|d| d.join(name)).find(|p| p.is_file())
}

/// llvm-objdump from the toolchain's llvm-tools component.
pub fn llvm_tool(root: &Path, tool: &str) -> Result<PathBuf> {
    let sysroot = stdout_of(Command::new("rustc").args(["--print", "sysroot"]).current_dir(root))?;
    let host = stdout_of(Command::new("rustc").arg("-vV").current_dir(root))?
        .lines()
        .find_map(|l| l.strip_prefix("host: ").map(str::to_owned))
        .context("rustc -vV printed no host")?;
    let p = Path::new(sysroot.trim()).join("lib/rustlib").join(host).join("bin").join(tool);
    if !p.is_file() {
        bail!("{} not found: is the llvm-tools component installed?", p.display());
    }
    Ok(p)
}
