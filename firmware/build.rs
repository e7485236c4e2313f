//! Links with `link-mps2.x` (cortex-m-rt's `link.x`, vendored, including `memory-mps2.x`, a
//! copy of `firmware/memory.x`, or of `firmware/memory-compact.x` with the feature `compact`:
//! the top-level memory.x is the SKR 2 board's, and the linker
//! would find it first) (thumb targets only), and turns the four reference slices
//! (host-sim/data/*.json) into Rust constants.

use std::fmt::Write;
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap()).join("..");
    // `memory-mps2.x` is `firmware/memory.x` as it is (640 KiB of RAM, the controller part's):
    // the firmware's statics and its stack fit there, so an overflow fails to link or fails
    // the stack check, as it would on the part. (Until issue 12's first steps both binaries
    // linked in 1 MiB of QEMU's 4 MiB: the link firmware's application alone had 552 KiB of
    // statics.)
    let mem_dir = out.join("memory");
    std::fs::create_dir_all(&mem_dir).unwrap();
    // With the board capacities (`compact`), `firmware/memory-compact.x`: the SKR 2's budget.
    let memory_file = if std::env::var_os("CARGO_FEATURE_COMPACT").is_some() {
        "firmware/memory-compact.x"
    } else {
        "firmware/memory.x"
    };
    let memory = std::fs::read_to_string(root.join(memory_file)).unwrap();
    std::fs::write(mem_dir.join("memory-mps2.x"), memory).unwrap();
    println!("cargo:rustc-link-search={}", mem_dir.display());
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=memory-compact.x");
    println!("cargo:rerun-if-changed=link-mps2.x");
    // Our own copy of cortex-m-rt's link.x, including `memory-mps2.x`: the linker runs in
    // the workspace root, whose memory.x (the SKR 2 board) it would find before any -L path.
    // The copy is of cortex-m-rt 0.7.7's: another version may expect other sections.
    let lock = std::fs::read_to_string(root.join("Cargo.lock")).unwrap();
    assert!(
        lock.contains("name = \"cortex-m-rt\"\nversion = \"0.7.7\""),
        "cortex-m-rt is no longer 0.7.7: vendor its link.x.in again as firmware/link-mps2.x"
    );
    println!("cargo:rerun-if-changed=../Cargo.lock");
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap());
    std::fs::copy(manifest.join("link-mps2.x"), out.join("link-mps2.x")).unwrap();
    println!("cargo:rustc-link-search={}", out.display());
    if std::env::var("TARGET").unwrap().starts_with("thumb") {
        println!("cargo:rustc-link-arg=-Tlink-mps2.x");
    }

    // The four reference slices (host_sim::REFERENCE_SLICES; tests/mcu.rs fails on one
    // missing), in the order the benchmark lines print them.
    let points = |f: &serde_json::Value| -> String {
        let pts: Vec<String> = f["points"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| {
                format!(
                    "Point::new({:?}f32, {:?}f32)",
                    p[0].as_f64().unwrap(),
                    p[1].as_f64().unwrap()
                )
            })
            .collect();
        format!("&[{}]", pts.join(", "))
    };
    let material = |f: &serde_json::Value| -> String {
        let m: Vec<String> = f["material"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| format!("{:?}f32", x.as_f64().unwrap()))
            .collect();
        format!("[{}]", m.join(", "))
    };
    // The board capacities (`compact`) hold the reference slices at 2.5 times their road
    // width (1.0 mm: the same shapes as slices 0.4 of their size at 0.4 mm), not at their own.
    let road_scale = if std::env::var_os("CARGO_FEATURE_COMPACT").is_some() {
        2.5
    } else {
        1.0
    };
    let mut s = String::new();
    let mut entries = Vec::new();
    for name in ["four_holes", "three_holes", "two_holes", "vessel_ring"] {
        let slice_path = root.join(format!("host-sim/data/{name}.json"));
        println!("cargo:rerun-if-changed={}", slice_path.display());
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&slice_path).unwrap()).unwrap();
        let outer = &v["outer"];
        let holes: Vec<String> = v["holes"]
            .as_array()
            .unwrap()
            .iter()
            .map(|h| format!("({}, {})", points(h), material(h)))
            .collect();
        entries.push(format!(
            "RefSlice {{ name: {name:?}, wall: ({}, {}), holes: &[{}], road_width: {} }}",
            points(outer),
            material(outer),
            holes.join(", "),
            f32_bits(&(v["settings"]["road_width"].as_f64().unwrap() * road_scale).into())
        ));
    }
    writeln!(
        s,
        "pub const SLICES: &[RefSlice] = &[{}];",
        entries.join(",\n")
    )
    .unwrap();
    std::fs::write(out.join("slice_data.rs"), s).unwrap();
}

/// A JSON number as the host reads it (decimal -> f64 -> f32), written as exact bits so the
/// firmware's constant is the same f32, not a second rounding of the decimal.
fn f32_bits(v: &serde_json::Value) -> String {
    format!(
        "f32::from_bits(0x{:08x})",
        (v.as_f64().unwrap() as f32).to_bits()
    )
}
