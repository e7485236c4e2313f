//! A turn's road at a ridge (where two features' turns, or two parts of one feature's, meet):
//! widened into the gap the last turn leaves before it, or narrowed where the turn beyond it
//! lies nearer than a road.

use super::{
    nearest, EDGE_DIRECTIONS, FIRST_TURN_MARGIN, LAID_TOL, NEXT_TURN_OVERLAP, RIDGE_MARGIN,
    RIDGE_STEPS, RIDGE_TOL_PER_ROAD, SEAM_CROSS, WIDEN_TRIES,
};
use crate::geometry::primitives::MinMax;
use crate::geometry::{polygon, Point};
use crate::Slice;

/// Whether feature `f` (not the nearest to the ray's start, which lies in the material at
/// distance `d` from the features) is at least `d + t` from the ray's point `q` at `t` by the
/// boxes of its chunks alone, so that [`widened`]'s gap there cannot fall below zero. Where
/// the ray enters the feature it crosses its boundary within `t` of `q`, so a point of the ray
/// inside the feature has a chunk's box nearer than `d + t`; elsewhere the boxes hold every
/// edge. A lower bound with the rounding slack: it skips only features the exact test skips,
/// without their exact distance (the nearest edge and, for the wall, the inside test).
fn clear_beyond(slice: &Slice, f: usize, d: f32, q: Point, t: f32) -> bool {
    let feature = slice.holes().get(f).unwrap_or(slice.wall());
    let need = d + t + polygon::rounding_slack(q, feature.bbox());
    d >= 0.0 && feature.nearest_box2(q) >= need * need
}

/// How fast the gap of a feature's own ridge ([`widened`]) must fall beyond it, per unit of the
/// ray, for the ridge to count: `1 - cos a` for two fronts of the feature that meet at angle
/// `a` (between their normals), here 60 degrees. A vertex of a polygon that samples a round
/// wall (or a round hole's concave side) turns its edges by `a = 360 / n` degrees, and its
/// spoke fell short of the tolerance [`RIDGE_TOL_PER_ROAD`] between half a road and a road
/// beyond it where `a` is 8 to 12 degrees (a circle of 32 to 40 vertices): every turn's road
/// widened by up to half a road at every vertex, and a plain disk of 36 or 40 vertices without
/// holes had overfill 0.06-0.11 (0.001-0.004 with 24 or 48 and more). On the random bench's
/// 200 slices (mean coverage / overfill of the offset spiral): without the test 0.9828 /
/// 0.0171; at 30 degrees (0.134) and 45 (0.29) 0.9827 / 0.0156; at 60 0.9827 / 0.0148; at 90
/// (1.0) 0.9825 / 0.0133, and one slice's coverage fell below 0.97.
const SPOKE_FALL: f32 = 0.5;
/// How far beyond an own ridge its fall is measured, in road widths.
const SPOKE_STEP: f32 = 0.1;

/// A turn's point `p` widened into the gap it leaves before a ridge, and the road width there;
/// `own`, `d` and `n` are its nearest feature, the distance to it and the gradient
/// ([`nearest`]).
///
/// Turns lie at fixed distances from the features, so where two features' turns meet at the
/// ridge between them (the bisector, where the distances agree) the last turn on each side
/// leaves a sliver narrower than a road. Along the distance gradient `n` from `p` (a straight
/// line inside the feature's cell), the ridge lies where another feature's distance `D_j(p + t
/// n)` drops to `D(p) + t` (or the feature's own distance falls behind `D(p) + t`, at a ridge
/// between two parts of one non-convex feature); the function `D_j(p + t n) - D(p) - t` only
/// falls (`D_j` is 1-Lipschitz), so bisection finds it. If it lies closer than a road width `w`
/// there is no next turn beyond `p`: the road widens by the sliver `g` (the ridge's distance
/// beyond the
/// road's outer edge, `t - w/2`) and its centre moves `g/2` outward, so its inner edge stays
/// where it was and its outer edge reaches the ridge, where the other side's last turn, widened
/// the same way, meets it. Where the next turn does cross the ray but was left out (a small
/// loop no join reached, `laid(q, level)` false at its crossing `q`), the road widens the same
/// way as far as [`Settings::max_width`] allows. The road is never wider than
/// [`Settings::max_width`], and half its width never exceeds its clearance (`D` grows by `g/2`,
/// and every other feature is at least that far: it is farther than the ridge). Where the
/// ridge lies nearer than half a road, the road narrows instead ([`narrowed`]).
///
/// [`Settings::max_width`]: crate::Settings::max_width
pub(super) fn widened(
    slice: &Slice,
    p: Point,
    (own, d, n): (usize, f32, Point),
    laid: impl Fn(Point, u16, f32) -> bool,
) -> (Point, f32) {
    let w = slice.settings().road_width;
    let holes = slice.holes().len();
    let len = n.norm();
    if len < 1e-6 {
        return (p, w);
    }
    let n = n * (1.0 / len);
    // The nearest ridge along `n` within reach of the widest road's outer edge.
    let gap = |f: usize, t: f32| slice.clearance_to(f, p + n * t) - d - t;
    // The ridge is looked for as far as a turn can be missing: beyond a road width out the
    // next turn crosses the ray, and the road widens only where that turn was left out (or
    // never traced: a sliver of a level too thin for the grid near a saddle of `D`). The
    // widening itself stops at `max_width`, short of a far ridge: a partial fill of a gap
    // wider than the widest road still covers most of it.
    let reach = (slice.settings().max_width - 0.5 * w).fmax(2.0 * w) + RIDGE_MARGIN;
    let mut ridge = reach;
    // The room for rounding a bound of the gap keeps ([`RIDGE_STEPS`]' steps below).
    let sure = 2.0 * polygon::rounding_slack(p, slice.wall().bbox()) + 1e-5 * w;
    for f in 0..=holes {
        // The feature's own ridges count too (a non-convex feature's parts face each other):
        // along its own normal its distance grows exactly with `t` until one, to rounding.
        let tol = if f == own {
            RIDGE_TOL_PER_ROAD * w
        } else {
            0.0
        };
        // A hole whose box is at least `d + 2 reach` away is farther than `d + t` from every
        // point of the ray within reach (its distance falls by at most `t`).
        let far = slice
            .holes()
            .get(f)
            .is_some_and(|h| f != own && polygon::bbox_distance(h.bbox(), p) >= d + 2.0 * reach);
        if far || (f != own && clear_beyond(slice, f, d, p + n * ridge, ridge)) {
            continue;
        }
        let at_ridge = gap(f, ridge);
        if at_ridge >= -tol {
            continue;
        }
        // The gap falls by at most 2 a unit of `t` (`D_f` is 1-Lipschitz along the ray, and
        // `t` rises by 1): from a bound of it at `lo` (below) or `hi` (above), a step whose
        // answer those bounds already give, with room for the rounding of both values the
        // bound rests on, is taken without measuring: the same steps as measuring each, so
        // the same ridge to the bit. (`below` is unknown at 0 until a step measures.)
        let (mut lo, mut hi) = (0.0f32, ridge);
        let (mut below, mut above) = (f32::NEG_INFINITY, at_ridge);
        for _ in 0..RIDGE_STEPS {
            let mid = 0.5 * (lo + hi);
            let (low, high) = (below - 2.0 * (mid - lo), above + 2.0 * (hi - mid));
            let (holds, at) = if low >= sure - tol {
                (true, low)
            } else if high < -tol - sure {
                (false, high)
            } else {
                let g = gap(f, mid);
                (g >= -tol, g)
            };
            debug_assert!(
                (gap(f, mid) >= -tol) == holds,
                "the ridge search's bound at {mid} disagrees with the gap measured there"
            );
            if holds {
                lo = mid;
                below = at;
            } else {
                hi = mid;
                above = at;
                // The ridge found will lie below `hi`, and the features after this one only
                // lower it: nearer than [`NARROW_FLOOR`] the road keeps its width, whatever
                // the rest of the search finds ([`narrowed`]).
                if hi < NARROW_FLOOR * w {
                    return (p, w);
                }
            }
        }
        // Past a vertex's spoke (the ridge where a polygon's two edges at a vertex are equally
        // near) the feature's own distance still grows, only more slowly: the next turn goes
        // on round the corner, and there is no sliver to widen into. Two parts that face each
        // other are a ridge: beyond it the distance falls, or grows at most as slowly as
        // fronts meeting at [`SPOKE_FALL`]'s angle.
        if f == own {
            let step = SPOKE_STEP * w;
            if (gap(f, hi) - gap(f, hi + step)) / step < SPOKE_FALL {
                continue;
            }
        }
        ridge = lo;
    }
    let g = (ridge - 0.5 * w - RIDGE_MARGIN).fmin(slice.settings().max_width - w);
    if g < 0.0 {
        return narrowed(slice, p, (d, n), ridge, laid);
    }
    if g == 0.0 {
        return (p, w);
    }
    // The next turn crosses the ray a road width out: widen only if it was left out, and
    // only as far as the widened road keeps off every laid piece of that turn (near a corner
    // of the next turn, where it meets another feature's turn at the ridge, the traced turn
    // cuts the corner and passes the ray's point at a distance). Where the ridge is nearer,
    // no turn of this feature's lies beyond, but another feature's turn of the next level may
    // reach across the ridge (the small loop round a pocket where three or four cells meet,
    // whose arms run out along the seams): the widened road may lay at most
    // [`NEXT_TURN_OVERLAP`] of its widening over that turn's road.
    let level = turn_level(d, w) + 1;
    let beyond = ridge >= w;
    if beyond && laid(p + n * w, level, LAID_TOL * w) {
        return (p, w);
    }
    let overlap = if beyond { 0.0 } else { NEXT_TURN_OVERLAP };
    // Where the ridge bends toward the road (near a corner where two features' turns meet),
    // the widened road's round edge would cross it sideways onto the other side's road:
    // widen less, or not at all. By at most [`SEAM_CROSS`], it may (the other side's road
    // stops short of the same corner).
    // The same across the feature's own ridges ([`OWN_SIDE`]).
    // No feature is nearer `q` than its own by more than that (of equal distances, either
    // counts).
    let in_cell = |q: Point| {
        let (nearest, d, near) = slice.nearest_feature(q);
        if nearest == own {
            // On this side of the feature's own ridges: its distance grows away from the
            // same part of it (beyond a ridge between two parts facing each other, the
            // gradient turns toward the road).
            let grad = slice.clearance_gradient(own, &near, q);
            grad.dot(n) >= OWN_SIDE * grad.norm()
        } else {
            d + SEAM_CROSS * w >= slice.clearance_to(own, q)
        }
    };
    let fits = |g: f32| {
        let (c, r) = (p + n * (0.5 * g), 0.5 * (w + g));
        !laid(c, level, r + 0.5 * w - overlap * g)
            && EDGE_DIRECTIONS
                .iter()
                .all(|&(x, y)| in_cell(c + Point::new(x, y) * r))
    };
    // The whole sliver, or as much of it as fits, by bisection (a ridge met at a slant lets
    // the round edge reach it only part of the way; halving the widening gave away up to half
    // of what fits, a seam of bare ground between the cells of a lattice of channels).
    let (mut lo, mut hi) = (0.0, g);
    if !fits(g) {
        for _ in 0..WIDEN_TRIES {
            let mid = 0.5 * (lo + hi);
            if fits(mid) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
    } else {
        lo = g;
    }
    if lo > 0.0 {
        (p + n * (0.5 * lo), w + lo)
    } else {
        (p, w)
    }
}

/// The level of the turn at distance `d` from its feature (`w/2 + k w`, less the first turn's
/// margin, rounded). A float-to-int `as` saturates: a level beyond `u16::MAX` (a slice 650 m
/// deep at the finest road) would only be clipped, never wrapped.
fn turn_level(d: f32, w: f32) -> u16 {
    libm::roundf((d - 0.5 * w - FIRST_TURN_MARGIN) / w).fmax(0.0) as u16
}

/// How nearly a widened road's edge must lie on its own side of its feature's own ridges
/// ([`widened`]): the cosine of the largest angle between the feature's distance gradient
/// there and at the road. Beyond a ridge between two parts of a feature that face each other
/// (a star's notch), the gradient points back toward the road: more than a right angle off.
/// On 200 random slices (with the first turns narrowed too, since undone) a right angle took
/// the spiral's median overfill from 0.018 to 0.017 and let 199 meet the bar; 60 degrees
/// (0.5) took it to 0.015 but cost coverage (one slice at 0.969) and left 198. Since a
/// widening that does not fit is bisected rather than halved (roads reach the ridge where it
/// is met at a slant), coverage has room to spare and the overlap where the two arms of a
/// turn's inner corner both widen is what is left: on the random bench (seeds from 1 and
/// from 9000) a right angle gave mean coverage 0.9895 / 0.9897 and overfill 0.0174 / 0.0173,
/// the worst 0.0395 / 0.0394; 60 degrees 0.9890 / 0.9893, 0.0159 / 0.0157, the worst
/// 0.0352 / 0.0376; 45 degrees (0.7) 0.9888 and 0.0157 from 1, the worst 0.0349.
const OWN_SIDE: f32 = 0.5;

/// How nearly the other turn must face a narrowed road's ([`narrowed`]): the cosine of the
/// largest angle between the two gradients' opposites.
const FACING: f32 = 0.9;
/// The nearest ridge, road widths out, at which a road narrows ([`narrowed`]). Nearer, the two
/// turns are less than half a road apart: the tip of a lens where they converge on a corner
/// of the ridge, or the two sides of a small loop round a peak of `D`, whose round ends (not
/// the other turn) cover the ground beyond the ridge there, and narrowed they left it bare.
/// On 200 random slices narrowing down to the ridge itself (0; the first turns and the
/// bridges narrowed too) lowered the spiral's overfill by 0.0028 on average but its coverage
/// by 0.0012 (one slice fell below 0.97); see the README's random slices for this floor's
/// figures.
const NARROW_FLOOR: f32 = 0.25;

/// A turn's point `p` (at distance `d` from its nearest feature, `n` the unit gradient) whose
/// ridge lies `ridge` out, nearer than half a road: the same level's turn beyond the ridge (the
/// other feature's, or another part of the same one) lies less than a road away, and two roads
/// a road wide would lay the ground between them twice. Where that turn is laid, the road
/// narrows to the ridge: its inner edge stays where it was (on the turn below's outer edge)
/// and its outer edge stops [`RIDGE_MARGIN`] short of the ridge, where the other turn,
/// narrowed the same way, meets it; never narrower than
/// [`min_width`](crate::Settings::min_width); not where the ridge is nearer than
/// [`NARROW_FLOOR`], and not on the first turn (on the keep-out curve, in its feature's own
/// material).
fn narrowed(
    slice: &Slice,
    p: Point,
    (d, n): (f32, Point),
    ridge: f32,
    laid: impl Fn(Point, u16, f32) -> bool,
) -> (Point, f32) {
    let settings = slice.settings();
    let w = settings.road_width;
    let g = (ridge - 0.5 * w - RIDGE_MARGIN).fmax(settings.min_width - w);
    if g >= 0.0 || ridge < NARROW_FLOOR * w {
        return (p, w);
    }
    let level = turn_level(d, w);
    // The first turn runs on the keep-out curve in its feature's own material: narrowed, its
    // centre would move inside the curve, and a move from a blended vertex onto it would
    // cross the curve in a blend.
    if level == 0 {
        return (p, w);
    }
    // The other turn crosses the ray about twice the ridge's distance out, facing back along
    // it (near a corner where the turns meet at the ridge at an angle, the ground beyond the
    // ridge is not the other turn's: narrowing there would leave it bare).
    let q = p + n * (2.0 * ridge);
    let (_, _, back) = nearest(slice, q);
    let len = back.norm();
    if len < 1e-6 || back.dot(n) > -FACING * len || !laid(q, level, LAID_TOL * w) {
        return (p, w);
    }
    (p + n * (0.5 * g), w + g)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Settings;

    /// A 10 mm square wall with a rectangular hole whose left side is at `x`, from y = 2 to 8:
    /// between x = 0 and `x` the wall's turns and the hole's face each other across the ridge
    /// at `x / 2`.
    fn facing(x: f32) -> Slice {
        let p = Point::new;
        let wall = [p(0.0, 0.0), p(10.0, 0.0), p(10.0, 10.0), p(0.0, 10.0)];
        let hole = [p(x, 2.0), p(x + 2.0, 2.0), p(x + 2.0, 8.0), p(x, 8.0)];
        let holes = [(&hole[..], [0.0, 1.0, 0.0, 0.0])];
        Slice::from_contours(&wall, [1.0, 0.0, 0.0, 0.0], &holes, Settings::default()).unwrap()
    }

    /// The wall's turn of level 4 (`w/2 + 4 w` from it) at y = 5.
    fn turn_point(slice: &Slice) -> Point {
        let w = slice.settings().road_width;
        Point::new(0.5 * w + 4.0 * w + FIRST_TURN_MARGIN, 5.0)
    }

    #[test]
    fn a_turn_narrows_to_the_ridge_where_the_turn_beyond_it_lies_nearer_than_a_road() {
        // Ridge at x = 1.95: the wall's level-4 turn (x = 1.803) and the hole's (x = 2.097)
        // lie 0.294 apart, 0.106 less than a road.
        let slice = facing(3.9);
        let w = slice.settings().road_width;
        let p = turn_point(&slice);
        let ridge = 1.95 - p.x;
        let (at, width) = widened(&slice, p, nearest(&slice, p), |_, _, _| true);
        // The inner edge stays; the outer one stops RIDGE_MARGIN short of the ridge.
        assert!(
            (at.x - 0.5 * width - (p.x - 0.5 * w)).abs() < 1e-4,
            "{at:?} {width}"
        );
        assert!(
            (at.x + 0.5 * width - (1.95 - RIDGE_MARGIN)).abs() < 1e-4,
            "{at:?} {width}"
        );
        assert!((width - (0.5 * w + ridge - RIDGE_MARGIN)).abs() < 1e-4);
        assert!(width < w && width >= slice.settings().min_width);
        // Where the turn beyond the ridge was left out, the road keeps its width.
        assert_eq!(
            widened(&slice, p, nearest(&slice, p), |_, _, _| false),
            (p, w)
        );
        // And where the ridge is nearer than NARROW_FLOOR (the turns less than half a road
        // apart).
        let slice = facing(2.0 * (p.x + 0.8 * NARROW_FLOOR * w));
        assert_eq!(
            widened(&slice, p, nearest(&slice, p), |_, _, _| true),
            (p, w)
        );
        let slice = facing(2.0 * (p.x + 1.2 * NARROW_FLOOR * w));
        assert!(widened(&slice, p, nearest(&slice, p), |_, _, _| true).1 < w);
        // The first turn, on the keep-out curve, never narrows.
        let first = Point::new(0.5 * w + FIRST_TURN_MARGIN, 5.0);
        let slice = facing(2.0 * (first.x + 1.5 * NARROW_FLOOR * w));
        assert_eq!(
            widened(&slice, first, nearest(&slice, first), |_, _, _| true),
            (first, w)
        );
    }

    #[test]
    fn a_road_widening_into_a_notch_keeps_to_its_side_of_the_notch_ridge() {
        // A hole with a V notch from above, its arms from (3, 6) down to (5, 2) and back up to
        // (7, 6): the material in the notch has the feature's own ridge at x = 5.
        let q = Point::new;
        let wall = [q(-5.0, -5.0), q(15.0, -5.0), q(15.0, 15.0), q(-5.0, 15.0)];
        let hole = [
            q(0.0, 0.0),
            q(10.0, 0.0),
            q(10.0, 6.0),
            q(7.0, 6.0),
            q(5.0, 2.0),
            q(3.0, 6.0),
            q(0.0, 6.0),
        ];
        let holes = [(&hole[..], [0.0, 1.0, 0.0, 0.0])];
        let slice =
            Slice::from_contours(&wall, [1.0, 0.0, 0.0, 0.0], &holes, Settings::default()).unwrap();
        let w = slice.settings().road_width;
        // The first turn beside the left arm, 0.35 mm (along its normal) short of the ridge:
        // it widens into the sliver, with no next turn to keep off.
        let n = Point::new(2.0, 1.0) * (1.0 / libm::sqrtf(5.0));
        let d = 0.5 * w + FIRST_TURN_MARGIN;
        let p = q(5.0 - 0.35 * n.x, 3.0);
        let p = q(p.x, 6.0 - 2.0 * (p.x - d * n.x - 3.0) + d * n.y);
        let near = nearest(&slice, p);
        assert!((near.1 - d).abs() < 1e-4, "{near:?}");
        let (at, width) = widened(&slice, p, near, |_, _, _| false);
        assert!(width > w, "{width}");
        // Its round edge stays left of the ridge all round (measured at its widest, along `n`,
        // it would stop short of it; sideways, toward the notch's opening, it used to cross).
        for k in 0..72 {
            let a = k as f32 * core::f32::consts::PI / 36.0;
            let e = at + Point::new(libm::cosf(a), libm::sinf(a)) * (0.5 * width);
            assert!(e.x <= 5.0 + 1e-4, "edge {e:?} of {at:?} {width}");
        }
    }

    #[test]
    fn a_turn_widens_into_a_sliver_before_the_ridge_and_keeps_its_width_a_road_from_it() {
        let w = Settings::default().road_width;
        // Ridge at x = 2.2, 0.397 beyond the turn: the sliver between the two sides' turns
        // (0.394 apart edge to edge, less than a road) is shared, each side widening to it.
        let slice = facing(4.4);
        let p = turn_point(&slice);
        let (at, width) = widened(&slice, p, nearest(&slice, p), |_, _, _| false);
        assert!(
            (at.x + 0.5 * width - (2.2 - RIDGE_MARGIN)).abs() < 1e-4,
            "{at:?} {width}"
        );
        assert!(width > w);
        // Ridge exactly half a road beyond the turn (plus the margin): neither.
        let slice = facing(2.0 * (p.x + 0.5 * w + RIDGE_MARGIN));
        let (at, width) = widened(&slice, p, nearest(&slice, p), |_, _, _| true);
        assert!(
            (width - w).abs() < 1e-4 && at.dist(p) < 1e-4,
            "{at:?} {width}"
        );
    }
}
