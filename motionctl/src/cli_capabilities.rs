//! The thesis capabilities' subcommands: `motionctl fourier ...` (Douglass coefficient tables)
//! and `motionctl wire ...` (Bhatti continuous jobs). `motionctl polar ...` lives in
//! [`crate::polar::cli`].

use crate::fourier::firmware_table::{self, DOUGLASS_DX_IN};
use crate::fourier::forex4::{self, Forex4Params};
use crate::wire::continuous::{self, ContinuousParams};
use anyhow::{Context, Result};
use clap::{Subcommand, ValueEnum};
use std::path::PathBuf;

#[derive(Subcommand, Debug)]
pub enum FourierCmd {
    /// Print the Z-slide coefficient table C00..C03 over X for the Douglass paraboloid.
    Table {
        /// `thesis`: the FOREX4 listing (reproduces Table 2-2 digit for digit);
        /// `accurate`: exact constants, converged tool-nose geometry, more samples.
        #[arg(long, value_enum, default_value_t = FourierMode::Accurate)]
        mode: FourierMode,
        /// Also write the firmware's fixed-point table (Rust source, accurate mode).
        #[arg(long, value_name = "FILE")]
        firmware_rust: Option<PathBuf>,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FourierMode {
    Thesis,
    Accurate,
}

pub fn run_fourier(cmd: FourierCmd) -> Result<()> {
    match cmd {
        FourierCmd::Table { mode: FourierMode::Thesis, firmware_rust } => {
            let t = forex4::forex4_table(&Forex4Params::listing())?;
            println!("FOREX4 (Appendix B-1), Table 2-2 format: X, C00, C01, C02, C03 (in)");
            for line in forex4::format_for30(&t) {
                println!("{line}");
            }
            if firmware_rust.is_some() {
                anyhow::bail!("--firmware-rust takes the accurate table: use --mode accurate");
            }
            Ok(())
        }
        FourierCmd::Table { mode: FourierMode::Accurate, firmware_rust } => {
            let acc = firmware_table::douglass_accurate()?;
            println!(
                "accurate Douglass table: {} rows, dX = {DOUGLASS_DX_IN} in, largest neglected \
                 harmonic {:.3e} in",
                acc.table.len(),
                acc.max_neglected_in
            );
            println!("{:>6} {:>13} {:>13} {:>13} {:>13}", "X", "C00", "C01", "C02", "C03");
            for (i, r) in acc.table.rows().iter().enumerate() {
                let x = acc.table.x_at(i);
                println!(
                    "{x:6.2} {:13.9} {:13.9} {:13.9} {:13.9}",
                    r.c00_in, r.c01_in, r.c02_in, r.c03_in
                );
            }
            if let Some(path) = firmware_rust {
                let fixed = firmware_table::power_table::<
                    { motion::zslide::douglass_table::DOUGLASS_ROWS },
                >(&acc.table)?;
                std::fs::write(&path, firmware_table::render_power_table(&fixed))
                    .with_context(|| format!("writing {}", path.display()))?;
                println!("wrote {}", path.display());
            }
            Ok(())
        }
    }
}

#[derive(Subcommand, Debug)]
pub enum WireCmd {
    /// Plan the circle -> complex die (Bhatti Table 11) as one continuous 4-axis job and run it
    /// through the host model of the firmware.
    Plan {
        /// Area rate, mm^2/min.
        #[arg(long, default_value_t = 800.0)]
        fr: f64,
        /// Largest horizontal distance of the wire from the designed ruling line, mm.
        #[arg(long, default_value_t = 0.01)]
        tolerance: f64,
    },
}

pub fn run_wire(cmd: WireCmd) -> Result<()> {
    let WireCmd::Plan { fr, tolerance } = cmd;
    let path = continuous::circle_complex_path()?;
    let cfg = motion::wire::machine::config();
    let prm = ContinuousParams { tol_mm: tolerance, fr_mm2_per_min: fr, ..Default::default() };
    let job = continuous::plan(&path, &cfg, &prm)?;
    println!("circle -> complex die, ZT 39 mm, FR {fr} mm^2/min, tolerance {tolerance} mm");
    println!("  segments            {}", job.segments.len());
    println!(
        "  ruled area          {:.3} mm^2 (thesis trapezoids {:.3})",
        job.area_ruled_mm2, job.area_trapezoid_mm2
    );
    println!("  60 A / FR           {:.3} s", job.time_ruled_s);
    let mut segs = job.segments.clone().into_iter();
    let report = motion::model::run(&cfg, || segs.next(), &[], u64::MAX, |_, _| {})
        .map_err(|e| anyhow::anyhow!("the model refused a segment: {e:?}"))?;
    let t = report.ticks as f64 / cfg.tick_hz as f64;
    println!(
        "  host model          {t:.3} s ({:+.0} ppm), {} segments, final steps {:?}",
        (t / job.time_ruled_s - 1.0) * 1e6,
        report.segments,
        &report.positions[..4]
    );
    Ok(())
}
