//! The firmware's checked-in circle -> complex job table is exactly what the planner produces
//! today. `REGENERATE=1 cargo test -p motionctl --test wire_job_file` rewrites it.

use motion::wire::{circle_complex_job as table, job, machine};
use motionctl::wire::continuous::{circle_complex_path, plan, ContinuousParams};
use motionctl::wire::job_file::render;
use std::path::PathBuf;

const GENERATOR: &str = "motionctl/tests/wire_job_file.rs";

#[test]
fn checked_in_job_matches_the_planner() {
    let prm = ContinuousParams::default();
    let cfg = machine::config();
    let j = plan(&circle_complex_path().unwrap(), &cfg, &prm).unwrap();
    let text = render(&j, &cfg, prm.fr_mm2_per_min, GENERATOR);
    let file = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../src/wire/circle_complex_job.rs");
    if std::env::var_os("REGENERATE").is_some() {
        std::fs::write(&file, &text).unwrap();
    }
    let on_disk = std::fs::read_to_string(&file).unwrap_or_default();
    assert!(on_disk == text, "{} is stale: run with REGENERATE=1", file.display());
    // The compiled table (from the last build) carries the same segments.
    assert_eq!(table::SEGMENTS.len(), j.segments.len());
    for (k, (a, b)) in table::SEGMENTS.iter().zip(&j.segments).enumerate() {
        assert_eq!(a.segment(k as u32), *b, "segment {k}");
    }
    assert_eq!(job::total_steps(&table::SEGMENTS), table::TOTAL_STEPS);
    assert_eq!(table::TICK_HZ, machine::TICK_HZ);
    let bytes = std::mem::size_of_val(&table::SEGMENTS);
    eprintln!("{} segments, {bytes} bytes of flash", table::SEGMENTS.len());
    assert!(bytes < 100_000);
}
