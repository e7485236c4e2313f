//! Shared helpers of host-sim's tests.
#![allow(dead_code)]

pub mod qemu;

use hollowpath::geometry::Point;
use hollowpath::toolpath::Vertex;
use hollowpath::{Material, Slice};
use host_sim::{slice_file, REFERENCE_SLICES};

pub const A: Material = [1.0, 0.0, 0.0, 0.0];
pub const B: Material = [0.0, 1.0, 0.0, 0.0];
pub const C: Material = [0.0, 0.0, 1.0, 0.0];

/// A reference slice by name.
pub fn reference(name: &str) -> Slice {
    let text = REFERENCE_SLICES.iter().find(|(n, _)| *n == name).unwrap().1;
    slice_file::parse(text).unwrap().slice
}

/// The two-hole reference slice.
pub fn two_holes() -> Slice {
    reference("two_holes")
}

/// A vertex.
pub fn v(x: f32, y: f32, material: Material, deposit: bool) -> Vertex {
    Vertex {
        at: Point::new(x, y),
        material,
        width: 0.4,
        deposit,
    }
}
