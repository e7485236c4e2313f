//! Walls and holes by nesting: a contour inside an even number of others (0, 2, ...) is the
//! outer wall of an island, one inside an odd number is a hole of the contour immediately
//! around it. The contours of a cut through a closed solid never cross, so one point of each
//! decides.

use super::cut::{area, contains};

/// One island of a layer: an outer wall and the holes inside it, mm.
#[derive(Clone, Debug, PartialEq)]
pub struct Island {
    /// The outer wall.
    pub outer: Vec<[f64; 2]>,
    /// The hollow features inside it.
    pub holes: Vec<Vec<[f64; 2]>>,
}

/// A point inside the polygon near its first vertex (the middle of the first edge, moved a
/// hair inwards), robust to a contour touching another at a vertex.
fn probe(poly: &[[f64; 2]]) -> [f64; 2] {
    let (a, b) = (poly[0], poly[1 % poly.len()]);
    let m = [(a[0] + b[0]) * 0.5, (a[1] + b[1]) * 0.5];
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let l = dx.hypot(dy).max(1e-12);
    let s = if area(poly) >= 0.0 { 1.0 } else { -1.0 };
    // The left normal points inside a counter-clockwise polygon.
    let e = 1e-7;
    [m[0] - s * dy / l * e, m[1] + s * dx / l * e]
}

/// Sorts `contours` into islands, ordered by the lower left corner of their walls (x, then
/// y), their holes likewise.
pub fn islands(contours: Vec<Vec<[f64; 2]>>) -> Vec<Island> {
    nest(&contours)
        .into_iter()
        .map(|(w, holes)| Island {
            outer: contours[w].clone(),
            holes: holes.iter().map(|&h| contours[h].clone()).collect(),
        })
        .collect()
}

/// [`islands`] by index: each island's wall and its holes, as indices into `contours`.
pub fn nest(contours: &[Vec<[f64; 2]>]) -> Vec<(usize, Vec<usize>)> {
    let n = contours.len();
    let probes: Vec<[f64; 2]> = contours.iter().map(|c| probe(c)).collect();
    let areas: Vec<f64> = contours.iter().map(|c| area(c).abs()).collect();
    // containers[i]: the contours that contain contour i.
    let containers: Vec<Vec<usize>> = (0..n)
        .map(|i| {
            (0..n)
                .filter(|&j| j != i && areas[j] > areas[i] && contains(&contours[j], probes[i]))
                .collect()
        })
        .collect();
    let depth: Vec<usize> = containers.iter().map(Vec::len).collect();
    let corner = |c: &[[f64; 2]]| {
        c.iter()
            .fold([f64::INFINITY; 2], |a, p| [a[0].min(p[0]), a[1].min(p[1])])
    };
    let mut walls: Vec<usize> = (0..n).filter(|&i| depth[i] % 2 == 0).collect();
    let key = |i: &usize| {
        let c = corner(&contours[*i]);
        (c[0], c[1])
    };
    walls.sort_by(|a, b| {
        key(a)
            .partial_cmp(&key(b))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    walls
        .iter()
        .map(|&w| {
            let mut holes: Vec<usize> = (0..n)
                .filter(|&h| depth[h] == depth[w] + 1 && containers[h].contains(&w))
                .collect();
            holes.sort_by(|a, b| {
                key(a)
                    .partial_cmp(&key(b))
                    .unwrap_or(std::cmp::Ordering::Equal)
            });
            (w, holes)
        })
        .collect()
}
