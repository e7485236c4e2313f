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

/// How far, as a fraction of a segment's length, its ends must lie either side of another's
/// line for the two to cross ([`crossing`]): far above the rounding of a cut's coordinates
/// (1e-16 of them), far below any real overlap.
pub const CROSSING_TOLERANCE: f64 = 1e-9;

/// A point where two of `contours` cross, if any do. The contours of a cut through one closed
/// solid never cross (the nesting above rests on it); two that do come from solids that
/// overlap, which would print twice where they overlap. Only a proper crossing counts, each
/// segment's ends clearly on either side of the other's line (farther than
/// [`CROSSING_TOLERANCE`] of its length): contours that touch at a point or run along each
/// other (solids side by side, a shared face cut into slightly different segments) do not. So
/// solids whose cuts overlap only through vertices and shared edges (two boxes flush on three
/// sides) are not caught. Segments are binned on a grid of about one cell per segment, so a
/// layer of many contours costs about as much as reading them.
pub fn crossing(contours: &[Vec<[f64; 2]>]) -> Option<[f64; 2]> {
    if contours.len() < 2 {
        return None;
    }
    // (contour, from, to)
    let segs: Vec<(usize, [f64; 2], [f64; 2])> = contours
        .iter()
        .enumerate()
        .flat_map(|(c, pts)| (0..pts.len()).map(move |k| (c, pts[k], pts[(k + 1) % pts.len()])))
        .collect();
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for &(_, a, _) in &segs {
        for i in 0..2 {
            lo[i] = lo[i].min(a[i]);
            hi[i] = hi[i].max(a[i]);
        }
    }
    let side = ((hi[0] - lo[0]).max(hi[1] - lo[1]) / (segs.len() as f64).sqrt()).max(1e-9);
    let cells = |v: f64, i: usize| (((v - lo[i]) / side) as usize).min(1 << 20);
    let nx = cells(hi[0], 0) + 1;
    let mut grid: std::collections::HashMap<usize, Vec<u32>> = std::collections::HashMap::new();
    for (s, &(_, a, b)) in segs.iter().enumerate() {
        for j in cells(a[1].min(b[1]), 1)..=cells(a[1].max(b[1]), 1) {
            for i in cells(a[0].min(b[0]), 0)..=cells(a[0].max(b[0]), 0) {
                grid.entry(j * nx + i).or_default().push(s as u32);
            }
        }
    }
    let orient = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    };
    let length = |a: [f64; 2], b: [f64; 2]| (b[0] - a[0]).hypot(b[1] - a[1]);
    // Both ends of one segment clearly apart across the other's line: `o` is that line's
    // length times the distance of the end from it.
    let apart = |o1: f64, o2: f64, line: f64, seg: f64| {
        let tol = CROSSING_TOLERANCE * line * seg;
        (o1 > tol && o2 < -tol) || (o1 < -tol && o2 > tol)
    };
    let mut keys: Vec<usize> = grid.keys().copied().collect();
    // The first crossing in a repeatable order, for the message.
    keys.sort_unstable();
    for key in keys {
        let bin = &grid[&key];
        for (x, &s) in bin.iter().enumerate() {
            let (cs, a, b) = segs[s as usize];
            for &t in &bin[x + 1..] {
                let (ct, c, d) = segs[t as usize];
                if cs == ct {
                    continue;
                }
                let (o1, o2) = (orient(a, b, c), orient(a, b, d));
                let (o3, o4) = (orient(c, d, a), orient(c, d, b));
                let (ab, cd) = (length(a, b), length(c, d));
                if apart(o1, o2, ab, cd) && apart(o3, o4, cd, ab) {
                    let t = o3 / (o3 - o4);
                    return Some([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
                }
            }
        }
    }
    None
}
