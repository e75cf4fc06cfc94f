//! The host tool's capability registry: each capability's subcommand, one line to declare it and
//! one to run it. `motionctl`'s command line flattens [`CapabilityCmd`] into its own, so a new
//! capability's subcommand is one variant here and its module's `cli`, nothing in `cli.rs`.

use anyhow::Result;
use clap::Subcommand;

#[derive(Subcommand, Debug)]
// Parsed once per process: boxing the link arguments would buy nothing.
#[allow(clippy::large_enum_variant)]
pub enum CapabilityCmd {
    /// Polar contouring (Fahim): digitize contours into step-event streams, dump streams,
    /// place the machine pole.
    #[command(subcommand)]
    Polar(crate::polar::cli::PolarCmd),
    /// Non-axisymmetric turning (Douglass): Z-slide coefficient tables and turning jobs
    /// (also `fourier`, its older name).
    #[command(subcommand, visible_alias = "fourier")]
    Turning(crate::turning::cli::TurningCmd),
    /// Constant-force milling (Elbestawi): simulate a milling job's force loop, plot it.
    #[command(subcommand)]
    Milling(crate::milling::cli::MillingCmd),
    /// 4-axis wire manipulator (Bhatti): continuous constant area-rate jobs.
    #[command(subcommand)]
    Wire(crate::wire::cli::WireCmd),
}

/// Runs a capability's subcommand.
pub fn run(cmd: CapabilityCmd) -> Result<()> {
    match cmd {
        CapabilityCmd::Polar(cmd) => crate::polar::cli::run(cmd),
        CapabilityCmd::Turning(cmd) => crate::turning::cli::run_turning(cmd),
        CapabilityCmd::Milling(cmd) => crate::milling::cli::run_milling(cmd),
        CapabilityCmd::Wire(cmd) => crate::wire::cli::run_wire(cmd),
    }
}
