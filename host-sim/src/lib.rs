//! hollowpath on the PC: reads slice files, runs the same `no_std` core the printer runs, and
//! writes what a user looks at (MCL JSON and SVG pictures).
//!
//! The command-line tool `hollowpath` (see `main.rs`) is a thin layer over this library, which
//! the tests and benchmarks use directly.

pub mod gcode;
pub mod layers;
pub mod metrics;
pub mod output;
pub mod preview;
pub mod random_slice;
pub mod raster;
pub mod render;
pub mod slice_file;

/// The built-in default slice (the four-hole reference slice, after the paper's Fig. 8).
pub const DEFAULT_SLICE: &str = REFERENCE_SLICES[0].1;

/// Plans `slice` with a fresh planner on the heap (the planner is ~290 KiB).
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
