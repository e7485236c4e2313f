//! Slices built by hand for the core's tests.
#![allow(dead_code)]

pub mod board;
pub mod motion;

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

use hollowpath::toolpath::Vertex;

/// Extrusion starts of a path: depositing moves that follow a travel move (or the start).
pub fn starts(path: &[Vertex]) -> usize {
    (1..path.len())
        .filter(|&i| path[i].deposit && (i == 1 || !path[i - 1].deposit))
        .count()
}

/// Checks what every layer must satisfy; returns the first failure.
pub fn check_layer(slice: &Slice, path: &[Vertex]) -> Result<(), String> {
    check_layer_with(slice, path, true)
}

/// [`check_layer`], optionally without the feature-composition check: where features are
/// closer than a road width an MCL can run along another feature's keep-out curve, carrying
/// its own blend there.
pub fn check_layer_with(
    slice: &Slice,
    path: &[Vertex],
    feature_composition: bool,
) -> Result<(), String> {
    let w = slice.settings().road_width;
    let half = 0.5 * w;
    if path.is_empty() {
        return Err("empty layer".into());
    }
    if path[0].deposit {
        return Err("the first vertex is reached by depositing".into());
    }
    let settings = slice.settings();
    for (i, v) in path.iter().enumerate() {
        if !v.at.is_finite() {
            return Err(format!("vertex {i} not finite"));
        }
        // Within the slice's width limits (roads along a keep-out curve keep 3 microns off its
        // edge each side).
        if !(v.width >= settings.min_width - 6.1e-3 && v.width <= settings.max_width + 1e-6) {
            return Err(format!("vertex {i}: width {}", v.width));
        }
        let sum: f32 = v.material.iter().sum();
        if v.material
            .iter()
            .any(|&x| !(-1e-6..=1.0 + 1e-6).contains(&x))
            || (sum - 1.0).abs() > 1e-4
        {
            return Err(format!("vertex {i}: composition {:?}", v.material));
        }
        // On a feature's keep-out curve the composition is the feature's material (to 1 %: a
        // spiral turn that grazes the curve carries the blend of where it is, a hair away).
        for (k, h) in slice.holes().iter().enumerate() {
            let off = v
                .material
                .iter()
                .zip(h.material())
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f32::max);
            if feature_composition && (h.signed_distance(v.at) - half).abs() < 1e-4 && off > 1e-2 {
                return Err(format!(
                    "vertex {i} on hole {k}: {:?} is not {:?}",
                    v.material,
                    h.material()
                ));
            }
        }
        if i > 0 && v.deposit {
            // Every road stays in the material, half its width from every feature: nothing
            // inside a feature or the wall.
            let (a, wa) = (path[i - 1].at, path[i - 1].width);
            let n = (a.dist(v.at) / (0.25 * half)).ceil().max(1.0) as usize;
            for t in 0..=n {
                let f = t as f32 / n as f32;
                let p = a.lerp(v.at, f);
                if !slice.fits(p, wa + (v.width - wa) * f, 2e-3) {
                    return Err(format!("road {i} leaves the printable region at {p:?}"));
                }
            }
        }
    }
    Ok(())
}
