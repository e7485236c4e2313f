//! hollowpath on the PC: reads slice files, runs the same `no_std` core the printer runs, and
//! writes what a user looks at (MCL JSON and SVG pictures).
//!
//! The command-line tool `hollowpath` (see `main.rs`) is a thin layer over this library, which
//! the tests and benchmarks use directly.

pub mod gcode;
pub mod json_file;
pub mod layers;
pub mod link_client;
pub mod metrics;
pub mod model;
pub mod output;
pub mod preview;
pub mod print;
pub mod printer_file;
pub mod random_slice;
pub mod raster;
pub mod render;
pub mod simulate;
pub mod slice_file;
pub mod staged;
pub mod svg_file;
pub mod virtual_printer;
pub mod virtual_rebuild;

/// The built-in default slice (the four-hole reference slice, after the paper's Fig. 8).
pub const DEFAULT_SLICE: &str = REFERENCE_SLICES[0].1;

/// The stack a thread that reads, plans or draws a slice needs: with the core's `large`
/// capacities a [`Slice`](hollowpath::Slice) is about 2.3 MiB and the zigzag's keep-out curves
/// 3 MiB, all built on the stack and moved (virtual memory; only what is touched is mapped).
/// `.cargo/config.toml` gives the test threads as much through `RUST_MIN_STACK`.
pub const STACK_BYTES: usize = 256 << 20;

/// Runs `f` on a new thread with a [`STACK_BYTES`] stack and returns its result (a panic in
/// `f` is resumed here).
pub fn run_on_large_stack<T: Send>(f: impl FnOnce() -> T + Send) -> T {
    std::thread::scope(|s| {
        let handle = std::thread::Builder::new()
            .stack_size(STACK_BYTES)
            .spawn_scoped(s, f)
            .expect("cannot start the planning thread");
        handle
            .join()
            .unwrap_or_else(|e| std::panic::resume_unwind(e))
    })
}

/// Plans `slice` with a fresh planner on the heap (the planner is ~290 KiB, ~4.9 MiB with the
/// `large` capacities: call it on a [`run_on_large_stack`] thread).
pub fn plan(slice: &hollowpath::Slice) -> Result<Box<hollowpath::Planner>, hollowpath::Error> {
    let mut planner = Box::new(hollowpath::Planner::new());
    planner.plan(slice)?;
    Ok(planner)
}

/// The reference slices shipped with the tool (copies of `../shared/slices/`), by name.
pub const REFERENCE_SLICES: [(&str, &str); 4] = [
    ("four_holes", include_str!("../data/four_holes.json")),
    ("three_holes", include_str!("../data/three_holes.json")),
    ("two_holes", include_str!("../data/two_holes.json")),
    ("vessel_ring", include_str!("../data/vessel_ring.json")),
];
