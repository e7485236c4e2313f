//! Links with cortex-m-rt's `link.x`, the board's `memory.x` (the repository's top-level one:
//! the STM32F407VG behind the SKR 2's 32 KiB bootloader) and defmt's `defmt.x`.

use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap());
    let memory = manifest.join("../../memory.x");
    std::fs::copy(&memory, out.join("memory.x")).unwrap();
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={}", memory.display());
    if std::env::var("TARGET").unwrap().starts_with("thumb") {
        println!("cargo:rustc-link-arg=-Tlink.x");
        println!("cargo:rustc-link-arg=-Tdefmt.x");
        // No ELF headers in a loadable segment: lld would put them in front of the image, at
        // 0x0800_0000, in the bootloader's sector, where a probe flashing the ELF would write.
        println!("cargo:rustc-link-arg=--nmagic");
    }
}
