//! Independent checks of a finished plan: what must hold for every slice.
//!
//! [`verify`] re-derives each property from the slice and the plan alone (no planner state),
//! so tests, the host tool and the firmware can check a plan before anything is printed.

use crate::geometry::primitives::MinMax;
use crate::geometry::{polyline, primitives, Point};
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
pub fn verify(slice: &Slice, plan: &Plan) -> Result<(), Violation> {
    let settings = slice.settings();
    let half = 0.5 * settings.road_width;
    let hole_d = |i: usize, p: Point| slice.holes()[i].signed_distance(p);
    let mut uses = [0u8; crate::config::MAX_HALVES];
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
                // On (near: the stored polyline is simplified) a piece of their bisector, and
                // exactly equidistant.
                let on_piece = plan
                    .cells
                    .between(m.from as usize, j as usize)
                    .any(|(_, b)| polyline::project(&b.points, p).2 < 0.05 * settings.road_width);
                let equidistant = libm::fabsf(hole_d(m.from as usize, p) - hole_d(j as usize, p))
                    < 10.0 * ON_CURVE_TOL;
                if !on_piece || !equidistant || !pts.contains(&p) {
                    return Err(Violation::JointOffBisector { mcl: id });
                }
            }
        }
        // Every point, and points along every segment, in the printable region.
        for w in pts.windows(2) {
            let n = libm::ceilf(w[0].dist(w[1]) / (0.25 * half)).fmax(1.0) as usize;
            for t in 0..=n {
                let p = w[0].lerp(w[1], t as f32 / n as f32);
                if !slice.is_printable(p, ON_CURVE_TOL) {
                    return Err(Violation::OutsideRegion { mcl: id, at: p });
                }
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
            let pb = plan.points(mb);
            if polyline::boxes_overlap(ba, primitives::bbox(&pb), 1e-4)
                && polyline::polylines_cross(&pa, &pb)
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
