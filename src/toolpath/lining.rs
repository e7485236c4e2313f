//! Each feature's own material along its lining.
//!
//! A channel's wall is lined with its feature's material: the layers lay every keep-out curve
//! (half a road from its feature, where a road of one road width touches the feature) in that
//! material. The zigzag's arcs and its MCLs' ends do so by construction, but a road between
//! them can come as near: an MCL that hugs its own hole for a while after it leaves it (the
//! field's gradient there runs almost along the boundary), a chord between two bent points
//! that sags micrometres past the keep-out curve and is laid a little narrower, a vertex pushed
//! out of a keep-out band onto its edge. Such a road carried the blend of its MCL, so where it
//! touched the feature the channel was lined with another material (half-L1 deviations up to
//! 0.5 on random slices of many holes).
//!
//! [`Lining`] sits between a layer and its sink and gives every vertex nearer a feature than
//! the lining's edge ([`LINING_TOL`] past the keep-out curve) that feature's material, and puts
//! a vertex, in that material, where a depositing move crosses the lining's edge to or from
//! such a vertex, or dips past it between two vertices outside: every move that runs within
//! the lining holds the feature's material, and a move that blends toward another material
//! does so outside it. A move from one feature's lining into another's, in another material,
//! where it runs outside both between them and a piece of it would end within either (as for
//! one lining), blends between the two edges only; where the linings meet
//! (features closer than a road), the nearer feature's material is given and no crossing is
//! put in between the two.

use super::moves::pieces;
use super::{PathSink, Vertex};
use crate::geometry::Point;
use crate::{Material, Slice};

/// How far past the keep-out curve the lining reaches, in road widths: beyond the metrics'
/// tolerance for a point on the curve (1 µm), so a move blending toward another material
/// starts clear of it.
pub const LINING_TOL: f32 = 0.01;

/// Room for rounding in a bound of the distance carried from vertex to vertex, road widths
/// (the distances and the way between are each within a few ulps of a coordinate).
const BOUND_SLACK: f32 = 1e-3;

/// Halvings locating where a move crosses the lining's edge: to 1/2^20 of the move.
const CROSSING_STEPS: u32 = 20;
/// Halvings after the distance's linear guess landed beyond the edge.
const GUESS_STEPS: u32 = 4;

/// What [`Lining`] knows of the last vertex it passed on.
#[derive(Clone, Copy)]
enum Known {
    /// Measured: the feature nearest it, its distance from it, and whether it was given that
    /// feature's material here.
    Measured(usize, f32, bool),
    /// Not measured: a lower bound of its distance from every feature, beyond the lining's
    /// edge.
    Beyond(f32),
}

/// A [`PathSink`] that lays each feature's lining in its own material (the module's essay).
pub struct Lining<'a, S: PathSink> {
    inner: &'a mut S,
    slice: &'a Slice,
    /// What is known of the last vertex passed on; `None` before the first.
    last: Option<Known>,
    /// Vertices put in where a move crosses a lining's edge.
    pub crossings: u32,
    /// Vertices given their lining's material.
    pub recoloured: u32,
}

impl<'a, S: PathSink> Lining<'a, S> {
    /// In front of `inner`, for the layers of `slice`.
    pub fn new(inner: &'a mut S, slice: &'a Slice) -> Lining<'a, S> {
        Lining {
            inner,
            slice,
            last: None,
            crossings: 0,
            recoloured: 0,
        }
    }

    /// The lining's edge: half a road and [`LINING_TOL`] from a feature.
    fn edge(&self) -> f32 {
        (0.5 + LINING_TOL) * self.slice.settings().road_width
    }

    /// The feature nearest `p` and its distance (positive in the material).
    fn nearest(&self, p: Point) -> (usize, f32) {
        let (f, d, _) = self.slice.nearest_feature(p);
        (f, d)
    }

    fn material(&self, f: usize) -> Material {
        self.slice.material_at(f)
    }

    /// Where on the move from `a` to `b` feature `f`'s distance crosses the lining's edge,
    /// between parameters `inside` (within the lining) and `outside` (beyond it): a parameter
    /// beyond the edge, within 1/2^[`CROSSING_STEPS`] of the move of the crossing. The
    /// distance's linear guess first (exact along one straight edge of the feature, the
    /// common case), then halving.
    fn crossing(&self, f: usize, a: Point, b: Point, inside: f32, outside: f32) -> f32 {
        let edge = self.edge();
        let at = |t: f32| self.slice.clearance_to(f, a.lerp(b, t));
        let (d_in, d_out) = (at(inside), at(outside));
        let guess = inside + (outside - inside) * ((edge - d_in) / (d_out - d_in));
        // Beyond the edge, the guess narrows the bracket, and a few halvings go on from it.
        let ((mut lo, mut hi), steps) = if d_out > d_in && guess.is_finite() && at(guess) >= edge {
            ((inside, guess), GUESS_STEPS)
        } else {
            ((inside, outside), CROSSING_STEPS)
        };
        for _ in 0..steps {
            let mid = 0.5 * (lo + hi);
            if at(mid) >= edge {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        hi
    }

    /// Whether the move between `inside`, in feature `f`'s lining (`d_in` from it), and
    /// `outside`, beyond the lining's edge (`d_out`), would have an end of a piece other than
    /// the one at the lining's vertex within the lining, where that piece holds a mix between
    /// the two ([`moves::split`](super::moves::split) lays a move in [`pieces`] of equal
    /// length): a move straight across the edge from a vertex on the keep-out curve (an arc's
    /// or an MCL's end) has none, one that runs along the edge, or is cut into many short
    /// pieces where its width changes fast, may. By the distances' linear guess, or, where
    /// that says no, measured at that piece's end: a move grazing a curved stretch of the
    /// curve comes nearer it there than the guess (random slice 108's zigzag once ended such a
    /// piece 1 µm off a hole's keep-out curve in a blend of 1.6 % another material).
    fn pieces_within(
        &self,
        f: usize,
        inside: &Vertex,
        outside: &Vertex,
        d_in: f32,
        d_out: f32,
    ) -> bool {
        let n = pieces(inside, outside) as f32;
        d_in + (d_out - d_in) / n < self.edge()
            || (n > 1.0
                && self
                    .slice
                    .clearance_to(f, inside.at.lerp(outside.at, 1.0 / n))
                    < self.edge())
    }

    /// Where the move `a -> c` crosses the edge of feature `f`'s lining, leaving it (`leaving`:
    /// `a` lies in it) or entering it (`c` does), where it needs a vertex there: the end in the
    /// lining holds `f`'s material, the other end another, and that end was given the material
    /// here (`recoloured`) or a piece but the one at it would end within the lining
    /// ([`pieces_within`](Self::pieces_within); `d_in` and `d_out` the ends' distances from
    /// `f`). (An arc's or an MCL's end on the keep-out curve, left straight across it, has only
    /// its first piece there, which holds its material.) `None` where it needs none.
    fn edge_vertex(
        &self,
        f: usize,
        a: &Vertex,
        c: &Vertex,
        leaving: bool,
        (d_in, d_out): (f32, f32),
        recoloured: bool,
    ) -> Option<f32> {
        let (inside, outside) = if leaving { (a, c) } else { (c, a) };
        let needed = inside.material == self.material(f)
            && outside.material != inside.material
            && (recoloured || self.pieces_within(f, inside, outside, d_in, d_out));
        needed.then(|| {
            if leaving {
                self.crossing(f, a.at, c.at, 0.0, 1.0)
            } else {
                self.crossing(f, a.at, c.at, 1.0, 0.0)
            }
        })
    }

    /// The vertex on the move `a -> b` at parameter `t`, in feature `f`'s material.
    fn put(&mut self, a: &Vertex, b: &Vertex, t: f32, f: usize) -> Result<(), Vertex> {
        let v = Vertex {
            at: a.at.lerp(b.at, t),
            material: self.material(f),
            width: a.width + (b.width - a.width) * t,
            deposit: true,
        };
        self.crossings += 1;
        self.inner.push_vertex(v)
    }
}

impl<S: PathSink> PathSink for Lining<'_, S> {
    fn push_vertex(&mut self, v: Vertex) -> Result<(), Vertex> {
        let edge = self.edge();
        // The distance changes by at most the way gone: a vertex whose bound from the last
        // one's stays beyond the lining's edge, less rounding, is beyond it, and so is every
        // point of the move to it. Nothing to do, and nothing measured (a road far from the
        // features passes most of its vertices so).
        if let (Some(Known::Measured(_, d, _) | Known::Beyond(d)), Some(a)) =
            (self.last, self.inner.last_vertex())
        {
            let bound = d - a.at.dist(v.at) - BOUND_SLACK * self.slice.settings().road_width;
            if bound >= edge {
                self.inner.push_vertex(v)?;
                self.last = Some(Known::Beyond(bound));
                return Ok(());
            }
        }
        let (mut fc, mut dc) = self.nearest(v.at);
        // A vertex within the linings of two features (a pinch narrower than two roads) that
        // already holds the farther one's material keeps it: it lies on that feature's curve
        // (an arc along it, narrowed through the pinch), which is lined with it. Recoloured
        // to the nearer feature's, an arc of unseen slice 5134 laid three vertices on its
        // curve in the other hole's material.
        if dc < edge && v.material != self.material(fc) {
            let held = (0..=self.slice.holes().len())
                .filter(|&k| k != fc && self.material(k) == v.material)
                .map(|k| (k, self.slice.clearance_to(k, v.at)))
                .find(|&(_, d)| d < edge);
            if let Some(kd) = held {
                (fc, dc) = kd;
            }
        }
        let mut c = v;
        let own = self.material(fc);
        let in_c = dc < edge;
        let recoloured_c = in_c && c.material != own;
        if recoloured_c {
            c.material = own;
            self.recoloured += 1;
        }
        if let (true, Some(a)) = (c.deposit, self.inner.last_vertex()) {
            let len = a.at.dist(c.at);
            let (fa, da, recoloured_a) = match self.last {
                Some(Known::Measured(f, d, recoloured)) => (Some(f), d, recoloured),
                // Only a bound of `a`'s distance, beyond the lining's edge: enough where the
                // move can dip into no lining, else measured.
                Some(Known::Beyond(d)) if !in_c && d + dc - len >= 2.0 * edge => (None, d, false),
                _ => {
                    let (f, d) = self.nearest(a.at);
                    (Some(f), d, false)
                }
            };
            // The feature whose lining `a` lies in, if it does (then it was measured).
            let lining_a = fa.filter(|_| da < edge);
            match (lining_a, in_c) {
                // Out of a lining in its material: blend from where the move leaves it.
                (Some(fa), false) if len > 0.0 => {
                    let leave = self.edge_vertex(fa, &a, &c, true, (da, dc), recoloured_a);
                    if let Some(t) = leave.filter(|&t| t < 1.0) {
                        self.put(&a, &c, t, fa)?;
                    }
                }
                // Into a lining in its material: blend up to where the move enters it.
                (None, true) if len > 0.0 => {
                    let enter = self.edge_vertex(fc, &a, &c, false, (dc, da), recoloured_c);
                    if let Some(t) = enter.filter(|&t| t > 0.0) {
                        self.put(&a, &c, t, fc)?;
                    }
                }
                // From one lining into another's, in another material, where the move runs
                // between them outside both (two features a road or so apart: their linings
                // do not meet): blend from where it leaves the one to where it enters the
                // other. Before, the move blended all the way, and a piece of it ended on the
                // first feature's keep-out curve in a mix of both (random slice 141 drawn
                // with features a road apart: 0.76 off the hole's material).
                (Some(fa), true)
                    if fa != fc
                        && a.material == self.material(fa)
                        && c.material != a.material
                        && len > 0.0 =>
                {
                    let (a_from_c, c_from_a) = (
                        self.slice.clearance_to(fc, a.at),
                        self.slice.clearance_to(fa, c.at),
                    );
                    if a_from_c >= edge && c_from_a >= edge {
                        let leave =
                            self.edge_vertex(fa, &a, &c, true, (da, c_from_a), recoloured_a);
                        let enter =
                            self.edge_vertex(fc, &a, &c, false, (dc, a_from_c), recoloured_c);
                        // Only where the move leaves the one before it enters the other.
                        let (t1, t2) = (leave.unwrap_or(0.0), enter.unwrap_or(1.0));
                        if t1 < t2 {
                            if let Some(t) = leave.filter(|&t| t > 0.0) {
                                self.put(&a, &c, t, fa)?;
                            }
                            if let Some(t) = enter.filter(|&t| t < 1.0) {
                                self.put(&a, &c, t, fc)?;
                            }
                        }
                    }
                }
                // Both outside: the move may still dip past a lining's edge between them (a
                // chord sagging past the curve, laid narrower). The distance falls by at most
                // the way gone, so only a move longer than both ends' surplus can.
                (None, false) if da + dc - len < 2.0 * edge => {
                    if let Some((t, p)) = self.slice.segment_dip(a.at, c.at, edge) {
                        let (f, d) = self.nearest(p);
                        if d < edge && t > 0.0 && t < 1.0 {
                            let t1 = self.crossing(f, a.at, c.at, t, 0.0);
                            let t2 = self.crossing(f, a.at, c.at, t, 1.0);
                            self.put(&a, &c, t1, f)?;
                            self.put(&a, &c, t2, f)?;
                        }
                    }
                }
                _ => {}
            }
        }
        self.inner.push_vertex(c)?;
        self.last = Some(Known::Measured(fc, dc, recoloured_c));
        Ok(())
    }

    fn last_vertex(&self) -> Option<Vertex> {
        self.inner.last_vertex()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Feature, FeatureId, Settings};

    const WALL: Material = [1.0, 0.0, 0.0, 0.0];
    const HOLE: Material = [0.0, 1.0, 0.0, 0.0];
    const BLEND: Material = [0.5, 0.5, 0.0, 0.0];

    /// A 20 mm square wall round a 2 mm square hole at the origin, roads 0.4 mm: the hole's
    /// keep-out curve runs 0.2 mm off it, the lining's edge 0.204 mm.
    fn slice() -> Slice {
        let square = |r: f32| [(-r, -r), (r, -r), (r, r), (-r, r)].map(|(x, y)| Point::new(x, y));
        let wall = Feature::new(FeatureId::Wall, &square(10.0), WALL).unwrap();
        let hole = Feature::new(FeatureId::Hole(0), &square(1.0), HOLE).unwrap();
        Slice::new(wall, &[hole], Settings::for_road_width(0.4)).unwrap()
    }

    fn v(x: f32, y: f32, material: Material) -> Vertex {
        Vertex {
            at: Point::new(x, y),
            material,
            width: 0.4,
            deposit: true,
        }
    }

    fn run(vs: &[Vertex]) -> (heapless::Vec<Vertex, 16>, u32, u32) {
        run_on(&slice(), vs)
    }

    /// `vs` through a lining of `slice`: what it passes on, its crossings and recolourings.
    fn run_on(slice: &Slice, vs: &[Vertex]) -> (heapless::Vec<Vertex, 16>, u32, u32) {
        let mut out: heapless::Vec<Vertex, 16> = heapless::Vec::new();
        let mut lining = Lining::new(&mut out, slice);
        for &x in vs {
            lining.push_vertex(x).unwrap();
        }
        let counts = (lining.crossings, lining.recoloured);
        (out, counts.0, counts.1)
    }

    /// Every vertex within the lining's edge of the hole holds the hole's material.
    fn lined(out: &[Vertex]) {
        let slice = slice();
        let edge = (0.5 + LINING_TOL) * 0.4;
        for x in out {
            if slice.clearance_to(0, x.at) < edge {
                assert_eq!(x.material, HOLE, "{out:?}");
            }
        }
    }

    #[test]
    fn a_road_that_hugs_a_hole_is_laid_in_its_material_where_it_is_nearer_than_the_lining_s_edge() {
        // A blended road runs 0.15 mm off the hole's top side and back out: its vertex there
        // takes the hole's material, and where the moves cross the lining's edge a vertex in
        // the hole's material is put in, so the blend changes outside the lining only.
        let (out, crossings, recoloured) =
            run(&[v(-0.5, 1.6, BLEND), v(0.0, 1.15, BLEND), v(0.5, 1.6, BLEND)]);
        assert_eq!((crossings, recoloured), (2, 1), "{out:?}");
        assert_eq!(out.len(), 5);
        lined(&out);
        let slice = slice();
        for k in [1, 3] {
            let d = slice.clearance_to(0, out[k].at);
            assert!((0.204..0.2041).contains(&d), "{d} {out:?}");
            assert_eq!(out[k].material, HOLE);
        }
        assert_eq!(out[0].material, BLEND);
        assert_eq!(out[4].material, BLEND);
    }

    #[test]
    fn a_chord_that_dips_past_the_lining_s_edge_holds_the_hole_s_material_there() {
        // A chord from (0.7, 1.25) to (1.25, 0.7), both ends 0.25 mm off the hole, passes
        // its corner (1, 1) 0.035 mm off: the stretch within the lining's edge is laid in the
        // hole's material, between two vertices put in where the chord crosses the edge.
        let (out, crossings, recoloured) = run(&[v(0.7, 1.25, BLEND), v(1.25, 0.7, BLEND)]);
        assert_eq!((crossings, recoloured), (2, 0), "{out:?}");
        assert_eq!(out.len(), 4);
        lined(&out);
        assert_eq!(out[1].material, HOLE);
        assert_eq!(out[2].material, HOLE);
    }

    #[test]
    fn roads_on_the_keep_out_curve_or_clear_of_the_lining_are_passed_on_as_they_are() {
        // An arc along the keep-out curve in the hole's material, then a move straight out
        // of it (an MCL's end), then roads far off: nothing put in, nothing changed.
        let vs = [
            v(-0.5, 1.2, HOLE),
            v(0.5, 1.2, HOLE),
            v(0.5, 1.7, BLEND),
            v(0.5, 3.0, BLEND),
            v(4.0, 3.0, BLEND),
            v(4.0, -3.0, WALL),
        ];
        let (out, crossings, recoloured) = run(&vs);
        assert_eq!((crossings, recoloured), (0, 0), "{out:?}");
        assert_eq!(&out[..], &vs[..]);
        // A shallow approach to the curve in the hole's material blends outside the lining.
        let (out, crossings, _) = run(&[v(-0.5, 1.25, BLEND), v(0.5, 1.2, HOLE)]);
        assert_eq!(crossings, 1, "{out:?}");
        lined(&out);
    }

    /// Two holes 0.3 mm apart, a pinch narrower than a road: a point 0.2 mm off the left one
    /// (on its keep-out curve) is 0.1 mm off the right one. An arc along the left hole's
    /// curve through the pinch lays it in the left hole's material, and keeps it there; only a
    /// vertex in neither hole's material takes the nearer one's.
    const RIGHT: Material = [0.0, 0.0, 1.0, 0.0];

    /// Two 2 mm square holes, `HOLE` left and `RIGHT` right, their centres `cx` either side of
    /// the origin, in a 20 mm wall; roads 0.4 mm.
    fn two_holes(cx: f32) -> Slice {
        let square = |cx: f32, r: f32| {
            [(-r, -r), (r, -r), (r, r), (-r, r)].map(|(x, y)| Point::new(cx + x, y))
        };
        let wall = Feature::new(FeatureId::Wall, &square(0.0, 10.0), WALL).unwrap();
        let left = Feature::new(FeatureId::Hole(0), &square(-cx, 1.0), HOLE).unwrap();
        let right = Feature::new(FeatureId::Hole(1), &square(cx, 1.0), RIGHT).unwrap();
        Slice::new(wall, &[left, right], Settings::for_road_width(0.4)).unwrap()
    }

    #[test]
    fn a_vertex_within_two_linings_keeps_the_material_of_either_it_holds() {
        let (out, _, recoloured) = run_on(
            &two_holes(1.15),
            &[
                v(0.05, -0.5, HOLE),
                v(0.05, 0.0, HOLE),
                v(0.05, 0.5, HOLE),
                v(0.05, 0.6, WALL),
            ],
        );
        assert_eq!(recoloured, 1);
        let materials: heapless::Vec<Material, 16> = out.iter().map(|x| x.material).collect();
        assert_eq!(&materials[..], &[HOLE, HOLE, HOLE, RIGHT], "{out:?}");
    }

    /// Two holes 0.5 mm apart (a road and a quarter): their keep-out curves run 0.1 mm apart
    /// through the pinch, their linings' edges 0.092 mm. A move straight across from the left
    /// curve, in the left hole's material, to the right one, in the right's, blends only
    /// between the two edges: a vertex in each material where it leaves the one lining and
    /// enters the other. Before, it blended all the way, and its pieces ended within both
    /// linings in mixes of the two.
    #[test]
    fn a_move_from_one_lining_into_another_blends_between_them() {
        let vs = [
            v(-0.05, -0.5, HOLE),
            v(-0.05, 0.0, HOLE),
            v(0.05, 0.0, RIGHT),
        ];
        let (out, crossings, recoloured) = run_on(&two_holes(1.25), &vs);
        assert_eq!((crossings, recoloured), (2, 0), "{out:?}");
        let edge = (0.5 + LINING_TOL) * 0.4;
        for (x, material, at) in [(&out[2], HOLE, -0.05), (&out[3], RIGHT, 0.05)] {
            assert_eq!(x.material, material, "{out:?}");
            // Just beyond the lining's edge, on the move.
            let d = (x.at.x - at).abs();
            assert!(d > edge - 0.2 - 1e-4 && d < edge - 0.2 + 1e-3, "{out:?}");
            assert!(x.at.y.abs() < 1e-6, "{out:?}");
        }
    }
}
