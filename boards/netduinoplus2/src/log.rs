//! The defmt global logger: frames go to QEMU's stdout via semihosting (`-semihosting-config
//! enable=on,target=native`), where `cargo xtask demo` decodes them with the ELF's defmt table.

use defmt_semihosting as _;
