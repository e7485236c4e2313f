//! Scaffold models built in code: a prism (any simple outline) with round channels along Z,
//! straight or bending, each open through the top or bottom face or closed inside the solid.
//! The mesh is closed and consistently oriented (normals out of the solid); the faces with
//! channel openings are triangulated by ear clipping (`earcutr`). `hollowpath demo` slices
//! [`demo`], and the tests build their models here.

use std::f64::consts::TAU;

/// A triangle, corners in mm.
pub type Triangle = [[f64; 3]; 3];

/// A round channel: rings of `radius` at heights `rings[k].0` around centres `rings[k].1`,
/// joined ring to ring. A channel whose first ring is at the bottom (0) opens there, one whose
/// last ring is at the top opens there; any other end is closed by a flat disc.
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    /// (height, centre) of each ring, from the bottom up.
    pub rings: Vec<(f64, [f64; 2])>,
    /// Radius, mm.
    pub radius: f64,
    /// Sides of each ring's polygon.
    pub segments: usize,
}

impl Channel {
    /// A straight channel around `centre` from `z0` to `z1`.
    pub fn straight(centre: [f64; 2], radius: f64, z0: f64, z1: f64, segments: usize) -> Channel {
        Channel {
            rings: vec![(z0, centre), (z1, centre)],
            radius,
            segments,
        }
    }

    /// A channel whose centre moves smoothly (smoothstep) from `from` at `z0` to `to` at
    /// `z1`, in `steps` rings.
    pub fn bending(
        from: [f64; 2],
        to: [f64; 2],
        radius: f64,
        z0: f64,
        z1: f64,
        steps: usize,
    ) -> Channel {
        let rings = (0..=steps)
            .map(|k| {
                let t = k as f64 / steps as f64;
                let s = t * t * (3.0 - 2.0 * t);
                let z = if k == steps { z1 } else { z0 + t * (z1 - z0) };
                (
                    z,
                    [
                        from[0] + s * (to[0] - from[0]),
                        from[1] + s * (to[1] - from[1]),
                    ],
                )
            })
            .collect();
        Channel {
            rings,
            radius,
            segments: 32,
        }
    }

    /// Ring `k`'s polygon, counter-clockwise.
    pub fn ring(&self, k: usize) -> Vec<[f64; 2]> {
        let (_, c) = self.rings[k];
        (0..self.segments)
            .map(|j| {
                let a = TAU * j as f64 / self.segments as f64;
                [c[0] + self.radius * a.cos(), c[1] + self.radius * a.sin()]
            })
            .collect()
    }

    /// The area of its cross-section polygon, mm^2.
    pub fn section_area(&self) -> f64 {
        let n = self.segments as f64;
        0.5 * n * self.radius * self.radius * (TAU / n).sin()
    }
}

/// A prism of `outline` (counter-clockwise, mm) from 0 to `height`, with channels inside.
#[derive(Clone, Debug, PartialEq)]
pub struct Scaffold {
    /// The outline, counter-clockwise.
    pub outline: Vec<[f64; 2]>,
    /// Height, mm.
    pub height: f64,
    /// The channels.
    pub channels: Vec<Channel>,
}

/// A circle of `n` points, counter-clockwise.
pub fn circle(c: [f64; 2], r: f64, n: usize) -> Vec<[f64; 2]> {
    (0..n)
        .map(|k| {
            let a = TAU * k as f64 / n as f64;
            [c[0] + r * a.cos(), c[1] + r * a.sin()]
        })
        .collect()
}

/// A `w` x `d` rectangle from the origin, counter-clockwise.
pub fn rectangle(w: f64, d: f64) -> Vec<[f64; 2]> {
    vec![[0.0, 0.0], [w, 0.0], [w, d], [0.0, d]]
}

fn at(p: [f64; 2], z: f64) -> [f64; 3] {
    [p[0], p[1], z]
}

/// Triangulates `outer` with `holes` (counter-clockwise and any orientation) at height `z`,
/// facing up (`up`) or down.
fn face(outer: &[[f64; 2]], holes: &[Vec<[f64; 2]>], z: f64, up: bool, out: &mut Vec<Triangle>) {
    let mut coords: Vec<f64> = outer.iter().flatten().copied().collect();
    let mut starts = Vec::new();
    let mut all: Vec<[f64; 2]> = outer.to_vec();
    for h in holes {
        starts.push(all.len());
        coords.extend(h.iter().flatten());
        all.extend_from_slice(h);
    }
    // earcutr fails only on malformed input (odd coordinate counts), which this never builds.
    let idx = earcutr::earcut(&coords, &starts, 2).unwrap_or_default();
    for t in idx.chunks_exact(3) {
        let [a, b, c] = [all[t[0]], all[t[1]], all[t[2]]];
        let ccw = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]) > 0.0;
        if ccw == up {
            out.push([at(a, z), at(b, z), at(c, z)]);
        } else {
            out.push([at(a, z), at(c, z), at(b, z)]);
        }
    }
}

impl Scaffold {
    /// The closed mesh, normals out of the solid.
    pub fn triangles(&self) -> Vec<Triangle> {
        let mut out = Vec::new();
        let (h, n) = (self.height, self.outline.len());
        for i in 0..n {
            let (p, q) = (self.outline[i], self.outline[(i + 1) % n]);
            out.push([at(p, 0.0), at(q, 0.0), at(q, h)]);
            out.push([at(p, 0.0), at(q, h), at(p, h)]);
        }
        let mut bottom = Vec::new();
        let mut top = Vec::new();
        for c in &self.channels {
            let last = c.rings.len() - 1;
            for k in 0..last {
                let (za, zb) = (c.rings[k].0, c.rings[k + 1].0);
                let (ra, rb) = (c.ring(k), c.ring(k + 1));
                let m = c.segments;
                for j in 0..m {
                    let (a0, a1, b0, b1) = (ra[j], ra[(j + 1) % m], rb[j], rb[(j + 1) % m]);
                    // Facing the channel's axis: into the void.
                    out.push([at(a0, za), at(b1, zb), at(a1, za)]);
                    out.push([at(a0, za), at(b0, zb), at(b1, zb)]);
                }
            }
            let (z0, c0) = c.rings[0];
            if z0 <= 0.0 {
                bottom.push(c.ring(0));
            } else {
                let r = c.ring(0);
                for j in 0..c.segments {
                    out.push([at(c0, z0), at(r[j], z0), at(r[(j + 1) % c.segments], z0)]);
                }
            }
            let (z1, c1) = c.rings[last];
            if z1 >= h {
                top.push(c.ring(last));
            } else {
                let r = c.ring(last);
                for j in 0..c.segments {
                    out.push([at(c1, z1), at(r[(j + 1) % c.segments], z1), at(r[j], z1)]);
                }
            }
        }
        face(&self.outline, &bottom, 0.0, false, &mut out);
        face(&self.outline, &top, h, true, &mut out);
        out
    }
}

/// The built-in scaffold: a 6 x 6 mm block `height` mm tall (3 by default) on a solid base of
/// a fifth of its height, with two straight channels 0.8 mm across and one that bends 2.5 mm
/// sideways on its way up, all three open at the top.
pub fn demo(height: f64) -> Scaffold {
    let base = 0.2 * height;
    Scaffold {
        outline: rectangle(6.0, 6.0),
        height,
        channels: vec![
            Channel::straight([1.5, 1.5], 0.4, base, height, 32),
            Channel::straight([4.5, 1.5], 0.4, base, height, 32),
            Channel::bending([1.5, 4.5], [4.0, 4.5], 0.4, base + 0.1 * height, height, 40),
        ],
    }
}
