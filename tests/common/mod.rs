//! Slices built by hand for the core's tests.
#![allow(dead_code)]

use hollowpath::geometry::Point;
use hollowpath::{Feature, FeatureId, Material, Settings, Slice};

pub const WALL: Material = [1.0, 0.0, 0.0, 0.0];
pub const A: Material = [0.0, 1.0, 0.0, 0.0];
pub const B: Material = [0.0, 0.0, 1.0, 0.0];

/// A regular polygon approximating a circle; vertex 0 at angle `phase`.
pub fn circle(cx: f32, cy: f32, r: f32, n: usize, phase: f32) -> Vec<Point> {
    (0..n)
        .map(|k| {
            let a = phase + k as f32 / n as f32 * std::f32::consts::TAU;
            Point::new(cx + r * a.cos(), cy + r * a.sin())
        })
        .collect()
}

pub fn feature(id: FeatureId, pts: &[Point], m: Material) -> Feature {
    Feature::new(id, pts, m).unwrap()
}

/// Two equal circles side by side at (-5, 0) and (5, 0), each with vertex 0 facing the other,
/// inside a circular wall: symmetric about both axes.
pub fn two_circles(settings: Settings) -> Slice {
    let wall = feature(FeatureId::Wall, &circle(0.0, 0.0, 12.0, 128, 0.0), WALL);
    let h0 = feature(FeatureId::Hole(0), &circle(-5.0, 0.0, 2.0, 48, 0.0), A);
    let h1 = feature(
        FeatureId::Hole(1),
        &circle(5.0, 0.0, 2.0, 48, std::f32::consts::PI),
        B,
    );
    Slice::new(wall, &[h0, h1], settings).unwrap()
}
