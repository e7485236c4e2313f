//! From raw triangles to a closed, indexed mesh: corners within [`WELD_MM`] welded into one
//! vertex, degenerate triangles (two corners welded together, or no area) and repeated faces
//! dropped, then every edge checked to belong to exactly two faces, so that every cut through
//! the mesh is a set of closed contours.

use std::collections::HashMap;

use super::error::ModelError;
use super::stl::RawTriangle;

/// Corners closer than this are one vertex, mm (1 µm).
pub const WELD_MM: f64 = 1e-3;

/// A closed triangle mesh.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// The welded vertices, mm.
    pub vertices: Vec<[f64; 3]>,
    /// The triangles, as vertex indices.
    pub triangles: Vec<[u32; 3]>,
}

/// What cleaning the triangles did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct MeshReport {
    /// Triangles in the file.
    pub read: usize,
    /// Dropped: two corners within [`WELD_MM`], or no area.
    pub degenerate: usize,
    /// Dropped: the same three vertices as an earlier triangle.
    pub duplicates: usize,
    /// Vertices after welding.
    pub vertices: usize,
}

impl Mesh {
    /// The lowest and highest corner, mm.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for v in &self.vertices {
            for a in 0..3 {
                lo[a] = lo[a].min(v[a]);
                hi[a] = hi[a].max(v[a]);
            }
        }
        (lo, hi)
    }
}

/// Welds, cleans and checks `raw` (see the module doc).
pub fn build(raw: &[RawTriangle]) -> Result<(Mesh, MeshReport), ModelError> {
    let mut report = MeshReport {
        read: raw.len(),
        ..MeshReport::default()
    };
    let mut mesh = Mesh::default();
    // Vertices hashed by their micrometre cell; a corner looks in the 27 cells around its own.
    let mut cells: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    let mut weld = |p: [f64; 3], mesh: &mut Mesh| -> u32 {
        let key = p.map(|c| (c / WELD_MM).round() as i64);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(list) = cells.get(&[key[0] + dx, key[1] + dy, key[2] + dz]) {
                        for &i in list {
                            let q = mesh.vertices[i as usize];
                            let d2 = (p[0] - q[0]).powi(2)
                                + (p[1] - q[1]).powi(2)
                                + (p[2] - q[2]).powi(2);
                            if d2 <= WELD_MM * WELD_MM {
                                return i;
                            }
                        }
                    }
                }
            }
        }
        let i = mesh.vertices.len() as u32;
        mesh.vertices.push(p);
        cells.entry(key).or_default().push(i);
        i
    };
    let mut seen: HashMap<[u32; 3], ()> = HashMap::new();
    for t in raw {
        let idx = t.map(|c| weld(c.map(f64::from), &mut mesh));
        if idx[0] == idx[1] || idx[1] == idx[2] || idx[0] == idx[2] || area2(&mesh, idx) <= 1e-18 {
            report.degenerate += 1;
            continue;
        }
        let mut key = idx;
        key.sort_unstable();
        if seen.insert(key, ()).is_some() {
            report.duplicates += 1;
            continue;
        }
        mesh.triangles.push(idx);
    }
    report.vertices = mesh.vertices.len();
    if mesh.triangles.is_empty() {
        return Err(ModelError::Empty);
    }
    check_closed(&mesh)?;
    Ok((mesh, report))
}

/// Twice the area of triangle `t`, squared (mm^4).
fn area2(mesh: &Mesh, t: [u32; 3]) -> f64 {
    let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    n[0] * n[0] + n[1] * n[1] + n[2] * n[2]
}

/// The undirected edge `a-b` as a key.
pub fn edge_key(a: u32, b: u32) -> (u32, u32) {
    if a < b {
        (a, b)
    } else {
        (b, a)
    }
}

/// Every edge must belong to exactly two faces; the first that does not (in the order of the
/// faces, so the report is repeatable) is named.
fn check_closed(mesh: &Mesh) -> Result<(), ModelError> {
    let mut uses: HashMap<(u32, u32), u32> = HashMap::with_capacity(mesh.triangles.len() * 2);
    for t in &mesh.triangles {
        for k in 0..3 {
            *uses.entry(edge_key(t[k], t[(k + 1) % 3])).or_default() += 1;
        }
    }
    for t in &mesh.triangles {
        for k in 0..3 {
            let e = edge_key(t[k], t[(k + 1) % 3]);
            let n = uses[&e];
            let (from, to) = (mesh.vertices[e.0 as usize], mesh.vertices[e.1 as usize]);
            match n {
                2 => {}
                1 => return Err(ModelError::OpenEdge { from, to }),
                n => {
                    return Err(ModelError::NonManifoldEdge {
                        from,
                        to,
                        faces: n as usize,
                    })
                }
            }
        }
    }
    Ok(())
}
