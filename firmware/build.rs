//! Puts the workspace's top-level `memory.x` on the linker's search path (cortex-m-rt's
//! `link.x` includes it), whatever directory cargo runs the linker from.

fn main() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    println!("cargo:rustc-link-search={}", root.display());
    println!("cargo:rerun-if-changed=../memory.x");
    println!("cargo:rerun-if-changed=build.rs");
}
