//! Cutting a closed mesh with a horizontal plane and chaining the cut segments into closed
//! contours.
//!
//! A vertex exactly on the plane is taken as lying above it (a symbolic perturbation of the
//! plane by an infinitesimal downwards), so every triangle is either not cut or cut across
//! exactly two of its edges, and every cut point lies on an edge strictly crossing the plane.
//! The chaining is topological: a cut edge belongs to exactly two faces (the mesh is closed),
//! so each contour is walked from face to face across shared edges, never by matching
//! coordinates. The crossing point of an edge is computed from its two vertices in a fixed
//! order, so both faces of an edge agree on it bit for bit.

use std::collections::HashMap;

use super::error::ModelError;
use super::mesh::{edge_key, Mesh};

/// Consecutive contour points closer than this are one point, mm.
pub const MERGE_MM: f64 = 1e-6;

/// The faces of every edge, and the triangles by their lowest corner, for repeated cuts.
pub struct Cutter<'m> {
    mesh: &'m Mesh,
    faces: HashMap<(u32, u32), [u32; 2]>,
    /// Triangle indices sorted by lowest z, with those z.
    by_low: Vec<(f64, u32)>,
}

impl<'m> Cutter<'m> {
    /// Indexes `mesh` (closed: every edge in exactly two faces, as [`super::mesh::build`]
    /// checks).
    pub fn new(mesh: &'m Mesh) -> Cutter<'m> {
        let mut faces: HashMap<(u32, u32), [u32; 2]> = HashMap::new();
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for k in 0..3 {
                let e = edge_key(tri[k], tri[(k + 1) % 3]);
                faces
                    .entry(e)
                    .and_modify(|f| f[1] = t as u32)
                    .or_insert([t as u32, u32::MAX]);
            }
        }
        let mut by_low: Vec<(f64, u32)> = mesh
            .triangles
            .iter()
            .enumerate()
            .map(|(t, tri)| {
                let z = tri
                    .iter()
                    .map(|&i| mesh.vertices[i as usize][2])
                    .fold(f64::INFINITY, f64::min);
                (z, t as u32)
            })
            .collect();
        by_low.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        Cutter {
            mesh,
            faces,
            by_low,
        }
    }

    fn above(&self, v: u32, z: f64) -> bool {
        self.mesh.vertices[v as usize][2] >= z
    }

    /// The two edges of triangle `t` the plane `z` crosses, if it is cut.
    fn cut_edges(&self, t: u32, z: f64) -> Option<[(u32, u32); 2]> {
        let tri = self.mesh.triangles[t as usize];
        let mut edges = [(0, 0); 2];
        let mut n = 0;
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            if self.above(a, z) != self.above(b, z) {
                if n < 2 {
                    edges[n] = edge_key(a, b);
                }
                n += 1;
            }
        }
        (n == 2).then_some(edges)
    }

    /// Where the plane `z` crosses edge `e` (one end below, one at or above).
    fn point(&self, e: (u32, u32), z: f64) -> [f64; 2] {
        let (a, b) = (
            self.mesh.vertices[e.0 as usize],
            self.mesh.vertices[e.1 as usize],
        );
        let (lo, hi) = if a[2] < b[2] { (a, b) } else { (b, a) };
        if hi[2] == z {
            return [hi[0], hi[1]];
        }
        let t = (z - lo[2]) / (hi[2] - lo[2]);
        [lo[0] + t * (hi[0] - lo[0]), lo[1] + t * (hi[1] - lo[1])]
    }

    /// The closed contours of the cut at `z` (layer `layer`, for messages), each at least
    /// three points with an area, in a repeatable order (by the lowest-numbered face they
    /// cross).
    pub fn contours(&self, z: f64, layer: usize) -> Result<Vec<Vec<[f64; 2]>>, ModelError> {
        let end = self.by_low.partition_point(|&(lo, _)| lo < z);
        let mut cut: Vec<u32> = self.by_low[..end]
            .iter()
            .map(|&(_, t)| t)
            .filter(|&t| self.cut_edges(t, z).is_some())
            .collect();
        cut.sort_unstable();
        let mut visited: HashMap<u32, ()> = HashMap::with_capacity(cut.len());
        let mut out = Vec::new();
        for &t0 in &cut {
            if visited.contains_key(&t0) {
                continue;
            }
            visited.insert(t0, ());
            let Some([first, mut edge]) = self.cut_edges(t0, z) else {
                continue;
            };
            let mut pts = vec![self.point(first, z)];
            let mut t = t0;
            loop {
                pts.push(self.point(edge, z));
                let f = self.faces[&edge];
                let next = if f[0] == t { f[1] } else { f[0] };
                let open = || ModelError::ChainOpen {
                    layer,
                    z,
                    at: self.point(edge, z),
                };
                if next == u32::MAX {
                    return Err(open());
                }
                if next == t0 {
                    break;
                }
                if visited.insert(next, ()).is_some() {
                    return Err(open());
                }
                let Some(es) = self.cut_edges(next, z) else {
                    return Err(open());
                };
                edge = if es[0] == edge { es[1] } else { es[0] };
                t = next;
            }
            // The walk ends back on the first edge: its point is the first point again.
            pts.pop();
            let pts = merged(pts);
            if pts.len() >= 3 && area(&pts).abs() > 1e-9 {
                out.push(pts);
            }
        }
        Ok(out)
    }
}

/// `pts` with consecutive points (and the last and first) closer than [`MERGE_MM`] merged.
fn merged(pts: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    let close = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]) < MERGE_MM;
    let mut out: Vec<[f64; 2]> = Vec::with_capacity(pts.len());
    for p in pts {
        if out.last().is_none_or(|&q| !close(p, q)) {
            out.push(p);
        }
    }
    while out.len() > 1 && close(out[0], out[out.len() - 1]) {
        out.pop();
    }
    // Points on the straight line between their neighbours (where a cut crosses the diagonal
    // of a flat quad) carry no shape: drop them, so that a prism cuts to the same contour at
    // every height.
    let mut k = 0;
    while out.len() > 3 && k < out.len() {
        let n = out.len();
        let (a, p, b) = (out[(k + n - 1) % n], out[k], out[(k + 1) % n]);
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let l = dx.hypot(dy);
        let off = ((p[0] - a[0]) * dy - (p[1] - a[1]) * dx).abs() / l.max(1e-300);
        let between = (p[0] - a[0]) * dx + (p[1] - a[1]) * dy > 0.0
            && (p[0] - b[0]) * dx + (p[1] - b[1]) * dy < 0.0;
        if l > 0.0 && off < MERGE_MM && between {
            out.remove(k);
        } else {
            k += 1;
        }
    }
    out
}

/// Signed area of a closed polygon (positive counter-clockwise), mm^2.
pub fn area(pts: &[[f64; 2]]) -> f64 {
    let n = pts.len();
    (0..n)
        .map(|k| {
            let (a, b) = (pts[k], pts[(k + 1) % n]);
            a[0] * b[1] - a[1] * b[0]
        })
        .sum::<f64>()
        * 0.5
}

/// Whether `p` lies inside the closed polygon `poly` (even-odd rule).
pub fn contains(poly: &[[f64; 2]], p: [f64; 2]) -> bool {
    let mut inside = false;
    let n = poly.len();
    let mut j = n - 1;
    for i in 0..n {
        let (a, b) = (poly[i], poly[j]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                inside = !inside;
            }
        }
        j = i;
    }
    inside
}
