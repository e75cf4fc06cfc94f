//! The checked-in firmware table `src/turning/douglass_table.rs` is exactly what the generator
//! gives today. On a difference the test fails and says how to regenerate.

use motionctl::turning::firmware_table::{
    douglass_accurate, power_table, render_power_table, DOUGLASS_ROWS,
};

#[test]
fn checked_in_douglass_table_is_current() {
    let acc = douglass_accurate().unwrap();
    let fixed = power_table::<DOUGLASS_ROWS>(&acc.table).unwrap();
    let text = render_power_table(&fixed);
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../src/turning/douglass_table.rs");
    if std::env::var_os("REGENERATE").is_some() {
        std::fs::write(path, &text).unwrap();
        eprintln!("rewrote {path}");
    }
    let on_disk = std::fs::read_to_string(path).unwrap_or_default();
    assert!(
        on_disk == text,
        "{path} is out of date; regenerate with\n  REGENERATE=1 cargo test -p motionctl --profile test-fast --test turning_firmware_table\n"
    );
    // The const table the firmware links is the same table.
    assert_eq!(&motion::turning::douglass_table::DOUGLASS_POWER, &fixed);
}
