//! The defmt global logger: RTT, read by `probe-rs run` (see `cargo xtask flash f405-motion`).

use defmt_rtt as _;
