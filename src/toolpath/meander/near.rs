//! The segments and edges near the zigzag's last band query ([`Near`]), which answer most of
//! the next queries without a search over every MCL and feature.

use heapless::Vec;

use super::band::{laid_segments, Fan, CHUNK};
use super::probe::{meet_with, negated, products, touch_with};
use crate::geometry::primitives::MinMax;
use crate::geometry::{polygon, primitives, Point};
use crate::toolpath::zigzag::EDGE_MARGIN;
use crate::{Plan, Slice};

/// How many MCL segments [`Near`] holds. A disk of [`NEAR_ROADS`] road widths held at most 96 on
/// the reference slices and 147 on 193 random ones; a disk with more is not held (its queries
/// search everything, with the same answers).
const NEAR_SEGMENTS: usize = 160;
/// How many feature edges [`Near`] holds (at most 12 on the reference slices, 78 on the random
/// ones, whose contours keep a vertex every few hundredths of a millimetre).
const NEAR_EDGES: usize = 96;
/// The radius of [`Near`]'s disk, in road widths. It changes no answer, only how many queries
/// the disk answers and how many segments each measures: a query is answered where its ray
/// hit and its balls (`2 t` from `p`) stay inside the room the disk leaves around `p`, most
/// bands are one to two roads wide, and a wider disk holds more segments. 3 roads, filled
/// again at [`NEAR_REFILL`], took the fewest instructions on four_holes (QEMU) among radii of
/// 2 to 6 roads and refill distances of 0.4 to 1.0 of the radius. On six random slices of
/// 2-26 holes (host, callgrind, the zigzag alone) 3 roads took 1 703 M instructions in all,
/// 4 roads 3 % fewer, 5 roads 6 % more, and the full search alone 4 692 M.
const NEAR_ROADS: f32 = 3.0;
/// How far from its centre, as a share of its radius, a query has the disk filled again
/// around it before it is asked.
const NEAR_REFILL: f32 = 0.6;

#[cfg(test)]
std::thread_local! {
    /// Test builds only: whether this thread's queries leave the disk unasked (so a test can
    /// lay the same layer with and without it).
    static UNASKED: core::cell::Cell<bool> = const { core::cell::Cell::new(false) };
}

/// Whether the disk is left unasked: never, outside tests.
#[cfg(not(test))]
pub(super) const fn unasked() -> bool {
    false
}

/// Whether this thread's queries leave the disk unasked (test builds).
#[cfg(test)]
pub(super) fn unasked() -> bool {
    UNASKED.with(|u| u.get())
}

/// The segments of the MCLs laid and the features' edges within a disk, for the
/// [`reach`](super::band::reach) queries that follow one another along a road, and for the
/// clearances the road asks on the way: a query whose answer lies inside the room the disk
/// leaves around it needs nothing else (everything not held lies farther), so it measures only
/// these instead of searching every feature and MCL laid, and finds what the full search
/// finds. (Both searches skip segments by tests whose rounding differs from the measure's, so
/// two candidates within rounding of each other could in principle win in one order and not
/// in the other; no digest of the reference slices and no line of the 200 random slices
/// differs.) The disk moves (is filled again around the query) once a query lies
/// [`NEAR_REFILL`] of its radius from its centre, or when it answers a query only in part.
pub(in crate::toolpath) struct Near {
    centre: Point,
    radius: f32,
    /// Whether the disk was filled around `centre`.
    filled: bool,
    /// Whether `segs` and `edges` hold every segment and edge within the disk (false before the
    /// first fill, and after a fill that found more than [`NEAR_SEGMENTS`] or [`NEAR_EDGES`]).
    held: bool,
    /// Each segment's ends and the plan index of its MCL.
    segs: Vec<([Point; 2], u16), NEAR_SEGMENTS>,
    /// The features' edges within the disk.
    edges: Vec<[Point; 2], NEAR_EDGES>,
    /// Whether the centre lies in the material (clear of every feature), once asked.
    material: Option<bool>,
}

impl Near {
    /// No disk held.
    pub(in crate::toolpath) const fn new() -> Near {
        Near {
            centre: Point::new(0.0, 0.0),
            radius: 0.0,
            filled: false,
            held: false,
            segs: Vec::new(),
            edges: Vec::new(),
            material: None,
        }
    }

    /// Holds the segments of `fan`'s MCLs laid and the features' edges that come within
    /// `radius` of `centre` (by their boxes: one left out lies wholly farther), or nothing, if
    /// they are too many.
    fn fill(&mut self, slice: &Slice, plan: &Plan, fan: &Fan<'_>, centre: Point, radius: f32) {
        self.segs.clear();
        self.edges.clear();
        self.material = None;
        self.centre = centre;
        self.radius = radius;
        self.filled = true;
        self.held = false;
        let r2 = radius * radius;
        for f in slice.holes().iter().chain(core::iter::once(slice.wall())) {
            if polygon::bbox_distance2(f.bbox(), centre) > r2 {
                continue;
            }
            let pts = f.points();
            for (run_box, edges) in f.edge_runs() {
                if polygon::bbox_distance2(run_box, centre) > r2 {
                    continue;
                }
                for i in edges {
                    let edge = [pts[i], pts[(i + 1) % pts.len()]];
                    if !segment_box_within(edge, centre, r2) {
                        continue;
                    }
                    if self.edges.push(edge).is_err() {
                        // Too many to hold: every query searches everything until the next
                        // fill.
                        self.edges.clear();
                        return;
                    }
                }
            }
        }
        let count = fan.laid.len();
        for (c, &chunk) in fan.chunks.iter().enumerate() {
            if polygon::bbox_distance2(chunk, centre) > r2 {
                continue;
            }
            for i in c * CHUNK..((c + 1) * CHUNK).min(count) {
                let m = fan.laid[i];
                if polygon::bbox_distance2(fan.boxes[i], centre) > r2 {
                    continue;
                }
                let mut full = false;
                laid_segments(plan, fan, i, |seg| {
                    if segment_box_within(seg, centre, r2) && self.segs.push((seg, m)).is_err() {
                        full = true;
                    }
                    !full
                });
                if full {
                    self.segs.clear();
                    self.edges.clear();
                    return;
                }
            }
        }
        self.held = true;
    }

    /// [`reach`](super::band::reach)'s least ball radius at `p` along `n` and along `-n`, each if
    /// the disk answers it; `None` where something not held could be nearer. The disk is
    /// filled again around `p` first if `p` lies [`NEAR_REFILL`] of its radius from its
    /// centre, and after a partial answer if `p` lies more than a quarter of it away (nearer,
    /// the room would hardly grow). A disk too full to hold waits until the road walks away.
    pub(super) fn reach_both(
        &mut self,
        slice: &Slice,
        plan: &Plan,
        p: Point,
        n: Point,
        fan: &Fan<'_>,
    ) -> [Option<f32>; 2] {
        let radius = NEAR_ROADS * slice.settings().road_width;
        let off = p.dist(self.centre);
        let fresh = !self.filled || off >= NEAR_REFILL * radius;
        if fresh {
            self.fill(slice, plan, fan, p, radius);
        }
        let mut got = self.answer(slice, p, n, fan);
        if !fresh && self.held && off > 0.25 * radius && got.iter().any(Option::is_none) {
            self.fill(slice, plan, fan, p, radius);
            got = self.answer(slice, p, n, fan);
        }
        got
    }

    /// [`reach_both`](Self::reach_both) from the disk as it is. The ends' products are
    /// measured once for both sides.
    ///
    /// Everything not held lies farther than the radius from the centre, so farther than
    /// `room` from `p`: the ray meets no edge not held before `room`, and no ball within
    /// `2 t < room` of `p` touches a segment not held. So an edge met before `room` is the
    /// feature the full search finds; where none is, the features lie at least `room` away,
    /// and a ball smaller than their strip there is the answer.
    fn answer(&self, slice: &Slice, p: Point, n: Point, fan: &Fan<'_>) -> [Option<f32>; 2] {
        if !self.held {
            return [None, None];
        }
        let w = slice.settings().road_width;
        // A thousandth of the radius and the coordinates' rounding spare.
        let slack = 1e-3 * self.radius + polygon::rounding_slack(p, (self.centre, self.centre));
        let room = self.radius - p.dist(self.centre) - slack;
        if room <= 0.0 {
            return [None, None];
        }
        let strip = w + 2.0 * EDGE_MARGIN;
        let back = n * -1.0;
        let mut hit = [f32::INFINITY; 2];
        for &edge in self.edges.iter() {
            let hg = products(p, n, edge);
            meet_with(p, n, edge, 0.0, hg, &mut hit[0]);
            meet_with(p, back, edge, 0.0, negated(hg), &mut hit[1]);
        }
        // As the full search starts, where the feature met is held; else from no bound.
        let mut best = hit.map(|hit| {
            if hit < room {
                (hit - strip).fmax(0.0)
            } else {
                f32::INFINITY
            }
        });
        for &(seg, m) in self.segs.iter() {
            let hg = products(p, n, seg);
            let own = m == fan.me;
            touch_with(p, n, seg, own, w, hg, &mut best[0]);
            touch_with(p, back, seg, own, w, negated(hg), &mut best[1]);
        }
        [0, 1].map(|k| {
            (2.0 * best[k] < room && (hit[k] < room || best[k] < room - strip)).then_some(best[k])
        })
    }
}

impl Near {
    /// [`Slice::clearance`] at `q`, if the disk answers it: where `q` lies in the material and
    /// its nearest edge held is nearer than anything not held can be. `q` is in the material
    /// if the centre is (asked of the slice once per disk) and the segment from the centre to
    /// `q`, which lies in the disk, meets no edge held (so none at all). Its clearance is then
    /// the least distance to an edge, measured as [`Feature::nearest`] measures it (the same
    /// closest point, the square root of the least squared distance), so the same bits.
    ///
    /// [`Feature::nearest`]: crate::Feature::nearest
    pub(super) fn clearance(&mut self, slice: &Slice, q: Point) -> Option<f32> {
        if !self.held {
            return None;
        }
        let slack = 1e-3 * self.radius + polygon::rounding_slack(q, (self.centre, self.centre));
        let room = self.radius - q.dist(self.centre) - slack;
        let c = self.centre;
        if room <= 0.0
            || self
                .edges
                .iter()
                .any(|&[a, b]| primitives::segments_meet(c, q, a, b))
            || !*self
                .material
                .get_or_insert_with(|| slice.clearance(c) > 0.0)
        {
            return None;
        }
        let d2 = self.edges.iter().fold(f32::INFINITY, |m, &[a, b]| {
            let d2 = (primitives::closest_on_segment(a, b, q).0 - q).norm2();
            if d2 < m {
                d2
            } else {
                m
            }
        });
        let d = hollowpath_fpu::sqrtf(d2);
        (d < room).then_some(d)
    }
}

/// Whether the box around segment `seg` comes within `sqrt(r2)` of `c` (a segment whose box
/// does not lies wholly farther).
#[inline(always)]
fn segment_box_within([a, b]: [Point; 2], c: Point, r2: f32) -> bool {
    let (lo, hi) = (
        Point::new(a.x.fmin(b.x), a.y.fmin(b.y)),
        Point::new(a.x.fmax(b.x), a.y.fmax(b.y)),
    );
    polygon::bbox_distance2((lo, hi), c) <= r2
}

#[cfg(test)]
mod tests {
    use super::super::band::{fan_boxes, search, FanBoxes, FanChunks};
    use super::*;
    use crate::{Feature, FeatureId, Planner, Settings};
    use core::cell::RefCell;
    use std::boxed::Box;
    use std::vec::Vec as StdVec;

    /// A xorshift generator: the same slices on every run.
    struct Rng(u64);

    impl Rng {
        fn unit(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
        fn range(&mut self, lo: f32, hi: f32) -> f32 {
            lo + (hi - lo) * self.unit()
        }
    }

    /// A wobbly closed curve around `c`: radius `r (1 + a cos(k t + phase))`, stretched by `s`.
    fn blob(
        c: Point,
        r: f32,
        s: (f32, f32),
        a: f32,
        k: f32,
        phase: f32,
        n: usize,
    ) -> StdVec<Point> {
        (0..n)
            .map(|i| {
                let t = i as f32 / n as f32 * core::f32::consts::TAU;
                let rr = r * (1.0 + a * libm::cosf(k * t + phase));
                Point::new(
                    c.x + s.0 * rr * libm::cosf(t),
                    c.y + s.1 * rr * libm::sinf(t),
                )
            })
            .collect()
    }

    /// A random slice: an oval wall 10-16 mm across each way and up to 6 blob holes that keep
    /// a millimetre from the wall and from each other, roads 0.3-0.6 mm.
    fn random_slice(rng: &mut Rng) -> Option<Slice> {
        let (rx, ry) = (rng.range(10.0, 16.0), rng.range(10.0, 16.0));
        let wall = blob(
            Point::new(0.0, 0.0),
            1.0,
            (rx, ry),
            rng.range(0.0, 0.15),
            3.0,
            0.4,
            128,
        );
        let wall = Feature::new(FeatureId::Wall, &wall, [1.0, 0.0, 0.0, 0.0]).ok()?;
        let mut holes: StdVec<Feature> = StdVec::new();
        for k in 0..6 {
            let c = Point::new(rng.range(-0.7, 0.7) * rx, rng.range(-0.7, 0.7) * ry);
            let pts = blob(
                c,
                rng.range(1.0, 3.0),
                (1.0, 1.0),
                rng.range(0.0, 0.3),
                5.0,
                rng.unit() * 6.0,
                48,
            );
            let clear = pts.iter().all(|&p| wall.signed_distance(p) < -1.0)
                && holes
                    .iter()
                    .all(|o| pts.iter().all(|&p| o.signed_distance(p) > 1.0));
            if clear {
                let mut m = [0.0; 4];
                m[1 + k % 3] = 1.0;
                holes.push(Feature::new(FeatureId::Hole(holes.len() as u8), &pts, m).ok()?);
            }
        }
        if holes.is_empty() {
            return None;
        }
        Slice::new(wall, &holes, Settings::for_road_width(rng.range(0.3, 0.6))).ok()
    }

    /// Calls `each` with the number (from 1), the slice and the plan of the first `count`
    /// random slices from `seed` that plan.
    fn planned_slices(seed: u64, count: usize, mut each: impl FnMut(usize, &Slice, &crate::Plan)) {
        let mut rng = Rng(seed);
        let mut planner = Box::new(Planner::new());
        let mut slices = 0;
        while slices < count {
            let Some(slice) = random_slice(&mut rng) else {
                continue;
            };
            let Ok(plan) = planner.plan(&slice) else {
                continue;
            };
            slices += 1;
            each(slices, &slice, plan);
        }
    }

    /// Wherever the near disk answers a band query, it answers as the search over every
    /// feature and every MCL, to the bit, and a clearance as the slice does; and it answers
    /// most of them. Queries along every MCL (at its points and between them, both normals,
    /// clearances up to two roads across), in walking order as the zigzag asks.
    #[test]
    fn the_near_disk_answers_as_the_full_search() {
        let (mut asked, mut answered) = (0usize, 0usize);
        let mut cleared = (0usize, 0usize);
        let (mut boxes, mut chunks) = (Box::new(FanBoxes::new()), Box::new(FanChunks::new()));
        planned_slices(0x9e37_79b9_7f4a_7c15, 6, |slices, slice, plan| {
            let laid: StdVec<u16> = (0..plan.mcls.len() as u16).collect();
            fan_boxes(plan, &laid, &mut boxes, &mut chunks).unwrap();
            let near = RefCell::new(Near::new());
            let w = slice.settings().road_width;
            for (at, &k) in laid.iter().enumerate() {
                let fan = Fan {
                    me: k,
                    at: at as u16,
                    laid: &laid,
                    boxes: &boxes,
                    chunks: &chunks,
                    near: &near,
                    bare: None,
                    cut: &[],
                };
                let pts = plan.points(&plan.mcls[k as usize]);
                for seg in pts.windows(2) {
                    let dir = seg[1] - seg[0];
                    let len = dir.norm();
                    if len < 1e-6 {
                        continue;
                    }
                    let left = Point::new(-dir.y / len, dir.x / len);
                    for p in [seg[0], seg[0].lerp(seg[1], 0.5)] {
                        let got = near.borrow_mut().reach_both(slice, plan, p, left, &fan);
                        // The clearance across the MCL, where the road and its strokes ask.
                        for across in [-2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0] {
                            let q = p + left * (across * w);
                            cleared.0 += 1;
                            if let Some(d) = near.borrow_mut().clearance(slice, q) {
                                cleared.1 += 1;
                                assert_eq!(
                                    d.to_bits(),
                                    slice.clearance(q).to_bits(),
                                    "slice {slices}: clearance at {q:?}"
                                );
                            }
                        }
                        for (got, n) in got.into_iter().zip([left, left * -1.0]) {
                            let full = search(slice, plan, p, n, &fan);
                            asked += 1;
                            if let Some(best) = got {
                                answered += 1;
                                assert_eq!(
                                    (2.0 * best).to_bits(),
                                    full.to_bits(),
                                    "slice {slices}, MCL {k} at {p:?} toward {n:?}: {} != {full}",
                                    2.0 * best
                                );
                            }
                        }
                    }
                }
            }
        });
        assert!(
            answered * 4 >= asked * 3,
            "the disk answered {answered} of {asked} queries"
        );
        assert!(
            cleared.1 * 5 >= cleared.0,
            "the disk answered {} of {} clearances",
            cleared.1,
            cleared.0
        );
    }

    /// The zigzag layer of random slices is the same with and without the disk, to the bit:
    /// every band and clearance the roads and the meanders' strokes ask, over the MCLs the
    /// zigzag lays (its parity subset, in its order).
    #[test]
    fn the_zigzag_is_the_same_without_the_disk() {
        use crate::toolpath::zigzag::zigzag;
        use crate::toolpath::DigestSink;
        planned_slices(0x5851_f42d_4c95_7f2d, 6, |slices, slice, plan| {
            let layer = |unasked: bool| {
                UNASKED.with(|u| u.set(unasked));
                let mut sink = DigestSink::new();
                let stats = zigzag(slice, plan, &mut sink).map(|s| (s, sink.digest()));
                UNASKED.with(|u| u.set(false));
                stats
            };
            let (with, without) = (layer(false), layer(true));
            assert!(with.is_ok(), "slice {slices}: {with:?}");
            assert_eq!(with, without, "slice {slices}");
        });
    }
}
