//! Plane geometry in `f32` millimetres, with explicit `libm` calls so the host and the MCU
//! compute bit-identical results.

mod grid;
mod point;
pub mod polygon;
pub mod polyline;
pub mod primitives;

pub use grid::Grid;
pub use point::Point;
