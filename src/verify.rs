//! Independent checks of a finished plan: what must hold for every slice.
//!
//! [`verify`] re-derives each property from the slice and the plan alone (no planner state),
//! so tests, the host tool and the firmware can check a plan before anything is printed.

use crate::geometry::primitives::MinMax;
use crate::geometry::{polygon, polyline, primitives, Point};
use crate::{FeatureId, Plan, Slice, Target};

/// A property of a plan that does not hold.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Violation {
    /// MCL `mcl` does not start on the keep-out curve of its hole.
    StartOffFeature {
        /// The MCL.
        mcl: u16,
    },
    /// MCL `mcl` does not end on the wall's keep-out curve or on its target hole's.
    EndOffBoundary {
        /// The MCL.
        mcl: u16,
    },
    /// The joint `p*` of MCL `mcl` is not on a bisector between its two holes.
    JointOffBisector {
        /// The MCL.
        mcl: u16,
    },
    /// A point of MCL `mcl` (or of a segment) lies outside the printable region.
    OutsideRegion {
        /// The MCL.
        mcl: u16,
        /// Where.
        at: Point,
    },
    /// MCL `mcl` crosses a feature's boundary.
    CrossesFeature {
        /// The MCL.
        mcl: u16,
        /// The feature.
        feature: FeatureId,
    },
    /// Two MCLs cross.
    Crossing {
        /// One MCL.
        a: u16,
        /// The other.
        b: u16,
    },
    /// The far ends of two MCLs are closer than the relaxation spacing.
    Crowded {
        /// One MCL.
        a: u16,
        /// The other.
        b: u16,
    },
    /// A half is not part of exactly one MCL (a dangling half).
    Dangling {
        /// The half.
        half: u16,
    },
    /// A hollow feature has no MCL: its material would never be deposited.
    HoleWithoutMcl {
        /// The hollow feature.
        hole: u8,
    },
}

/// Tolerance of "on a curve", mm.
pub const ON_CURVE_TOL: f32 = 2e-3;

/// Checks every property of `plan` for `slice`; the first violation found is returned.
// Not inlined: its working set (every MCL's box) stays in a frame of its own instead of its
// caller's, which every other phase would then carry.
#[inline(never)]
pub fn verify(slice: &Slice, plan: &Plan) -> Result<(), Violation> {
    let settings = slice.settings();
    let half = 0.5 * settings.road_width;
    let hole_d = |i: usize, p: Point| slice.holes()[i].signed_distance(p);
    let mut uses = [0u8; crate::config::MAX_HALVES];
    // The printable region's bar (`Slice::is_printable`: `fits` at the road width), and the
    // rounding a clearance may carry: every point of an MCL lies in the wall's box, and twice
    // the slack at its corner bounds the slack at any of them.
    let bar = settings.road_width * 0.5 - ON_CURVE_TOL;
    let wall_box = slice.wall().bbox();
    let slack = 2.0 * polygon::rounding_slack(wall_box.0, wall_box);
    for (k, m) in plan.mcls.iter().enumerate() {
        let id = k as u16;
        uses[m.first as usize] += 1;
        if let Some(s) = m.second {
            uses[s as usize] += 1;
        }
        let pts = plan.points(m);
        let (first, last) = (pts[0], pts[pts.len() - 1]);
        if libm::fabsf(hole_d(m.from as usize, first) - half) > ON_CURVE_TOL {
            return Err(Violation::StartOffFeature { mcl: id });
        }
        match m.to {
            Target::Wall => {
                if libm::fabsf(slice.wall_clearance(last) - half) > ON_CURVE_TOL {
                    return Err(Violation::EndOffBoundary { mcl: id });
                }
            }
            Target::Hole(j) => {
                if libm::fabsf(hole_d(j as usize, last) - half) > ON_CURVE_TOL {
                    return Err(Violation::EndOffBoundary { mcl: id });
                }
                let p = m.joint;
                // Exactly equidistant from the two holes, and on a piece of the bisector the
                // plan stored for them: near its polyline (simplified, coarser where the
                // bisector is long and winding), or, where no other hole is nearer (a third
                // as near is a branch point), within half a road of it: the traced points are
                // chords of a bisector that curves tightly round a star's spike (a parabola
                // about a vertex; on random slice 154 a joint lay 0.027 mm off its chord at
                // 0.46 mm roads, where the polyline alone allowed 0.023).
                let d = hole_d(m.from as usize, p);
                let equidistant = libm::fabsf(d - hole_d(j as usize, p)) < 10.0 * ON_CURVE_TOL;
                // The nearest piece's distance, less the tolerance it was stored with.
                let off = plan
                    .cells
                    .between(m.from as usize, j as usize)
                    .map(|(_, b)| polyline::project(&b.points, p).2 - b.tolerance)
                    .fold(f32::INFINITY, |a, b| a.fmin(b));
                let nearest_two = || {
                    let (_, nearest, _, second) = slice.nearest_holes(p);
                    nearest >= d - 10.0 * ON_CURVE_TOL && second >= d - 10.0 * ON_CURVE_TOL
                };
                let on_piece = off < 0.05 * settings.road_width
                    || (off < 0.5 * settings.road_width && nearest_two());
                if !on_piece || !equidistant || !pts.contains(&p) {
                    return Err(Violation::JointOffBisector { mcl: id });
                }
            }
        }
        // Every point, and points along every segment, in the printable region.
        for w in pts.windows(2) {
            if let Some(at) = first_outside(slice, w[0], w[1], bar, slack) {
                return Err(Violation::OutsideRegion { mcl: id, at });
            }
            // The holes in order, then the wall.
            if let Some(f) = slice.features_crossed(w[0], w[1]).next() {
                return Err(Violation::CrossesFeature {
                    mcl: id,
                    feature: f.id(),
                });
            }
        }
    }
    for i in 0..slice.holes().len() {
        let touches = |m: &crate::Mcl| m.from as usize == i || m.to == Target::Hole(i as u8);
        if !plan.mcls.iter().any(touches) {
            return Err(Violation::HoleWithoutMcl { hole: i as u8 });
        }
    }
    for (h, &n) in uses.iter().enumerate().take(plan.halves.len()) {
        if n != 1 {
            return Err(Violation::Dangling { half: h as u16 });
        }
    }
    // Every MCL's box, measured once for all the pairs it is in (`plan.mcls` has the same
    // capacity: the indices fit).
    let mut boxes = [(Point::default(), Point::default()); crate::config::MAX_MCLS];
    for (k, m) in plan.mcls.iter().enumerate() {
        boxes[k] = plan.mcl_box(m);
    }
    for (a, ma) in plan.mcls.iter().enumerate() {
        let pa = plan.points(ma);
        let ba = primitives::bbox(&pa);
        for (b, mb) in plan.mcls.iter().enumerate().skip(a + 1) {
            if ma.joint.dist(mb.joint) < settings.relax_spacing - ON_CURVE_TOL {
                return Err(Violation::Crowded {
                    a: a as u16,
                    b: b as u16,
                });
            }
            if polyline::boxes_overlap(ba, boxes[b], 1e-4)
                && polyline::polylines_cross(&pa, &plan.points(mb))
            {
                return Err(Violation::Crossing {
                    a: a as u16,
                    b: b as u16,
                });
            }
        }
    }
    Ok(())
}

/// The first of the samples along `a`-`b` (the ends and points a quarter of a half road apart)
/// that is not in the printable region ([`Slice::is_printable`] with [`ON_CURVE_TOL`]: a
/// clearance of at least `bar`), if any. The clearance changes by no more than the way gone,
/// so the samples within a measured clearance's surplus over the bar (less `slack`, the
/// rounding a clearance may carry) are printable too and are not measured: the same answer
/// as measuring every sample.
fn first_outside(slice: &Slice, a: Point, b: Point, bar: f32, slack: f32) -> Option<Point> {
    let half = 0.5 * slice.settings().road_width;
    let n = libm::ceilf(a.dist(b) / (0.25 * half)).fmax(1.0) as usize;
    // A sample's distance from the next, a little over (rounding of `lerp`).
    let step = a.dist(b) / n as f32 * 1.001;
    let mut t = 0;
    while t <= n {
        let p = a.lerp(b, t as f32 / n as f32);
        let clearance = slice.clearance(p);
        // As `Slice::fits` compares (a NaN clearance is not printable).
        let printable = clearance >= bar;
        if !printable {
            return Some(p);
        }
        let surplus = clearance - bar - slack;
        t += 1;
        if surplus > step {
            // At most `n`: the loop ends there anyway.
            t += libm::floorf(surplus / step).fmin(n as f32) as usize;
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Feature, Settings};

    /// Along random segments of a slice with three holes, some wholly in the material and some
    /// across features, the samples skipped by their clearance change nothing: the first
    /// sample outside the printable region is the one that measuring every sample finds.
    #[test]
    fn skipping_by_clearance_finds_the_first_sample_outside() {
        let circle = |c: Point, r: f32, n: usize| -> std::vec::Vec<Point> {
            (0..n)
                .map(|i| {
                    let t = i as f32 / n as f32 * core::f32::consts::TAU;
                    Point::new(c.x + r * libm::cosf(t), c.y + r * libm::sinf(t))
                })
                .collect()
        };
        let wall = Feature::new(
            FeatureId::Wall,
            &circle(Point::new(0.0, 0.0), 20.0, 96),
            [1.0, 0.0, 0.0, 0.0],
        )
        .unwrap();
        let holes: std::vec::Vec<Feature> = [(-8.0, 0.0, 3.0), (7.0, 5.0, 2.0), (2.0, -9.0, 4.0)]
            .iter()
            .enumerate()
            .map(|(k, &(x, y, r))| {
                Feature::new(
                    FeatureId::Hole(k as u8),
                    &circle(Point::new(x, y), r, 48),
                    [0.0, 1.0, 0.0, 0.0],
                )
                .unwrap()
            })
            .collect();
        let slice = Slice::new(wall, &holes, Settings::for_road_width(0.4)).unwrap();
        let bar = slice.settings().road_width * 0.5 - ON_CURVE_TOL;
        let wall_box = slice.wall().bbox();
        let slack = 2.0 * polygon::rounding_slack(wall_box.0, wall_box);
        let half = 0.5 * slice.settings().road_width;
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut unit = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let (mut inside, mut outside) = (0, 0);
        for _ in 0..2000 {
            let a = Point::new(unit() * 36.0 - 18.0, unit() * 36.0 - 18.0);
            let b = a + Point::new(unit() * 8.0 - 4.0, unit() * 8.0 - 4.0);
            let n = libm::ceilf(a.dist(b) / (0.25 * half)).fmax(1.0) as usize;
            let every = (0..=n)
                .map(|t| a.lerp(b, t as f32 / n as f32))
                .find(|&p| !slice.is_printable(p, ON_CURVE_TOL));
            let skipping = first_outside(&slice, a, b, bar, slack);
            assert_eq!(skipping, every, "{a:?} -> {b:?}");
            if every.is_some() {
                outside += 1;
            } else {
                inside += 1;
            }
        }
        assert!(
            inside > 200 && outside > 200,
            "{inside} in the material, {outside} not"
        );
    }
}
