//! Composition: blended between the materials of the features an MCL joins, by parametric
//! distance along it (paper, section 3).

use core::cell::Cell;

use crate::config::CHANNELS;
use crate::geometry::primitives::MinMax;
use crate::geometry::{polygon, polyline, primitives, Point};
use crate::{Material, Plan, Slice, Target};

/// `(1 - t) a + t b`, channel by channel; exactly `a` at `t = 0` and `b` at `t = 1`.
///
/// ```
/// use hollowpath::toolpath::composition::blend;
/// let m = blend(&[1.0, 0.0, 0.0, 0.0], &[0.0, 1.0, 0.0, 0.0], 0.25);
/// assert_eq!(m, [0.75, 0.25, 0.0, 0.0]);
/// ```
pub fn blend(a: &Material, b: &Material, t: f32) -> Material {
    let t = t.clamp(0.0, 1.0);
    if t == 0.0 {
        return *a;
    }
    if t == 1.0 {
        return *b;
    }
    let mut m = [0.0; CHANNELS];
    for c in 0..CHANNELS {
        m[c] = a[c] + (b[c] - a[c]) * t;
    }
    m
}

/// The materials at the two ends of MCL `k` of `plan`: its `from` hole's and the wall's or the
/// `to` hole's.
pub fn mcl_end_materials(slice: &Slice, plan: &Plan, k: usize) -> (Material, Material) {
    let m = &plan.mcls[k];
    let a = slice.holes()[m.from as usize].material();
    let b = match m.to {
        Target::Wall => slice.wall().material(),
        Target::Hole(j) => slice.holes()[j as usize].material(),
    };
    (a, b)
}

/// The composition at arc length `s` along a polyline of length `len` whose ends carry `a`
/// and `b`.
pub fn along(a: &Material, b: &Material, s: f32, len: f32) -> Material {
    if len <= 0.0 {
        return *a;
    }
    blend(a, b, s / len)
}

/// The blended field: at any point, the composition of the nearest point on any MCL, by its
/// parametric distance along that MCL. Keeps each MCL's bounding box so far MCLs are skipped.
///
/// ```
/// # // The host build's capacities take megabytes: run on a large stack.
/// # std::thread::Builder::new().stack_size(256 << 20).spawn(|| {
/// # use hollowpath::{Feature, FeatureId, Planner, Settings, Slice, geometry::Point};
/// # use hollowpath::toolpath::composition::BlendedField;
/// # let circle = |r: f32, n: usize| -> Vec<Point> {
/// #     (0..n).map(|k| { let a = k as f32 / n as f32 * std::f32::consts::TAU; Point::new(r * a.cos(), r * a.sin()) }).collect()
/// # };
/// let wall = Feature::new(FeatureId::Wall, &circle(8.0, 64), [1.0, 0.0, 0.0, 0.0]).unwrap();
/// let hole = Feature::new(FeatureId::Hole(0), &circle(4.0, 48), [0.0, 1.0, 0.0, 0.0]).unwrap();
/// let slice = Slice::new(wall, &[hole], Settings::default()).unwrap();
/// let mut planner = Box::new(Planner::new());
/// let plan = planner.plan(&slice).unwrap();
/// let field = BlendedField::new(&slice, plan);
/// // Half way between the hole and the wall the two materials are blended about evenly.
/// let m = field.at(Point::new(6.0, 0.0)).unwrap();
/// assert!((m[0] - 0.5).abs() < 0.05 && (m[1] - 0.5).abs() < 0.05);
/// # }).unwrap().join().unwrap();
/// ```
pub struct BlendedField<'a> {
    slice: &'a Slice,
    plan: &'a Plan,
    /// The bounding box of MCL `k` of the plan at `k` (the rest unused).
    boxes: [(Point, Point); crate::config::MAX_MCLS],
    /// The box around each run of [`RUN`] MCLs' boxes (MCLs are numbered round each hole in
    /// turn, so a run's lie together): a run farther than the best so far is passed over
    /// whole.
    runs: [(Point, Point); crate::config::MAX_MCLS.div_ceil(RUN)],
    /// How far MCL `k` strays from its chord (the segment between its ends, [`chord`]): no
    /// point of it is nearer `p` than the chord less this, a tighter bound than its box for
    /// an MCL that runs slantwise.
    strays: [f32; crate::config::MAX_MCLS],
    /// The MCL nearest to the last point asked about: looked at first next time.
    hint: Cell<usize>,
}

/// The ends of MCL `m`: the segment [`BlendedField`] bounds its distance by.
fn chord(plan: &Plan, m: &crate::Mcl) -> (Point, Point) {
    plan.mcl_ends(m)
}

/// MCLs a run of [`BlendedField`]'s boxes holds.
const RUN: usize = 8;

impl<'a> BlendedField<'a> {
    /// The field of `plan`'s MCLs.
    pub fn new(slice: &'a Slice, plan: &'a Plan) -> BlendedField<'a> {
        let mut boxes = [(Point::default(), Point::default()); crate::config::MAX_MCLS];
        // One slot per MCL: `plan.mcls` holds at most MAX_MCLS, so none is left out.
        for (slot, m) in boxes.iter_mut().zip(plan.mcls.iter()) {
            *slot = plan.mcl_box(m);
        }
        let mut runs =
            [(Point::default(), Point::default()); crate::config::MAX_MCLS.div_ceil(RUN)];
        for (slot, run) in runs.iter_mut().zip(boxes[..plan.mcls.len()].chunks(RUN)) {
            *slot = primitives::union_all(run);
        }
        let mut strays = [0.0; crate::config::MAX_MCLS];
        for (slot, m) in strays.iter_mut().zip(plan.mcls.iter()) {
            let (a, b) = chord(plan, m);
            // The farthest vertex: a point between two vertices is no farther from the
            // chord than the farther of them (the distance to a segment is convex).
            *slot = plan
                .points_iter(m)
                .map(|q| primitives::closest_on_segment(a, b, q).0.dist(q))
                .fold(0.0, |m, d| if d > m { d } else { m });
        }
        BlendedField {
            slice,
            plan,
            boxes,
            runs,
            strays,
            hint: Cell::new(0),
        }
    }

    /// Whether MCL `k` is farther than `reach` from `p` by its chord: every point of it is
    /// within its stray of the chord, so it is at least the chord's distance less the stray
    /// away. `reach` carries the caller's rounding slack (four times
    /// [`polygon::rounding_slack`]: the chord's distance and the stray are each a few
    /// roundings deep), so an MCL passed over could neither have won nor tied.
    fn beyond(&self, k: usize, p: Point, reach: f32) -> bool {
        let (a, b) = chord(self.plan, &self.plan.mcls[k]);
        primitives::closest_on_segment(a, b, p).0.dist(p) - self.strays[k] > reach
    }

    /// The composition at `p`; `None` for a plan without MCLs (or a NaN point, whose
    /// distances are never less than any).
    ///
    /// The nearest MCL blends it (of equal distances, the lowest-numbered): the answer of the
    /// full search over every MCL. The MCL nearest to the previous query is looked at first:
    /// a road's vertices come one after another, so the best so far is near the answer early
    /// and the boxes of most MCLs rule them out. The answer does not depend on that order: a
    /// box is skipped only when it is farther than the best so far by more than rounding
    /// could move a distance. (The search in MCL order before it skipped a box as far as the
    /// best without that slack, so it could in principle miss a minimum an ulp inside a box's
    /// edge; every reference and random digest came out the same.)
    pub fn at(&self, p: Point) -> Option<Material> {
        let mcls = &self.plan.mcls;
        // (distance, MCL, parameter, squared reach)
        let mut best: (f32, usize, f32, f32) = (f32::INFINITY, usize::MAX, 0.0, f32::INFINITY);
        let slack = polygon::rounding_slack(p, self.slice.wall().bbox());
        let visit = |k: usize, best: &mut (f32, usize, f32, f32)| {
            let ((s, _, d), length) = polyline::project_points(self.plan.points_iter(&mcls[k]), p);
            if d < best.0 || (d == best.0 && k < best.1) {
                let r = d + slack;
                *best = (d, k, s / length.fmax(1e-9), r * r);
            }
        };
        let hint = self.hint.get();
        if hint < mcls.len() {
            visit(hint, &mut best);
        }
        // In MCL order as before runs were kept: a run is passed over only where each of its
        // boxes would have been (each lies inside the run's, and the best does not change
        // while none is visited).
        for (r, run) in self.runs.iter().enumerate().take(mcls.len().div_ceil(RUN)) {
            if polygon::bbox_distance2(*run, p) > best.3 {
                continue;
            }
            for k in r * RUN..((r + 1) * RUN).min(mcls.len()) {
                if k != hint
                    && polygon::bbox_distance2(self.boxes[k], p) <= best.3
                    && !self.beyond(k, p, best.0 + 4.0 * slack)
                {
                    visit(k, &mut best);
                }
            }
        }
        if best.1 == usize::MAX {
            return None;
        }
        self.hint.set(best.1);
        let (_, k, t, _) = best;
        let (a, b) = mcl_end_materials(self.slice, self.plan, k);
        Some(blend(&a, &b, t))
    }
}
