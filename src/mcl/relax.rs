//! Relaxation of the MCLs crowding near branch points (section 2.2).
//!
//! Near a branch point the ends of MCLs from several cells (on the wall, on two or three
//! bisectors) converge. Every *end* (a wall end, or the joint `p*` of a matched pair) closer
//! than [`relax_spacing`](crate::Settings::relax_spacing) to another end is pushed away from
//! it along its own curve (the wall's keep-out curve, or the bisector, where the partner moves
//! with it), as the paper disperses the crowded lines through the extra space of their
//! neighbours. A move that would cross another MCL or leave the cell is not made. This runs
//! [`relax_iterations`](crate::Settings::relax_iterations) sweeps; ends still crowding after
//! that are thinned (the most crowded first), so the spacing holds whatever the iteration count.

use heapless::Vec;

use crate::cells::{onto_bisector, Cells};
use crate::config::MAX_HALVES;
use crate::error::{Error, Limit};
use crate::geometry::{polyline, primitives, Point};
use crate::mcl::insert::sorted_halves;
use crate::mcl::matching::{crosses_finished_chunked, HalfBoxes};
use crate::mcl::{reshape_end, Half, HalfEnd, Halves};
use crate::stats::PlanStats;
use crate::Slice;

/// One end: the half that carries it (the lower index of a pair).
fn ends(halves: &[Half]) -> Result<Vec<u16, MAX_HALVES>, Error> {
    let mut out: Vec<u16, MAX_HALVES> = Vec::new();
    for (k, h) in halves.iter().enumerate() {
        let carrier = match h.partner {
            Some(p) => (p as usize) > k,
            None => h.end == HalfEnd::Wall,
        };
        if h.alive && carrier {
            // Never full: at most one per half, and `halves` has the same capacity.
            out.push(k as u16).map_err(|_| Limit::Halves.error())?;
        }
    }
    Ok(out)
}

/// For every half, the halves before and after it around its hole (by start parameter).
fn ring_neighbours(halves: &[Half], holes: usize) -> Result<Vec<(u16, u16), MAX_HALVES>, Error> {
    let mut out: Vec<(u16, u16), MAX_HALVES> = Vec::new();
    // Never full: `halves` has the same capacity.
    out.resize(halves.len(), (0, 0))
        .map_err(|_| Limit::Halves.error())?;
    for i in 0..holes {
        let order = sorted_halves(halves, i)?;
        let n = order.len();
        for k in 0..n {
            out[order[k] as usize] = (order[(k + n - 1) % n], order[(k + 1) % n]);
        }
    }
    Ok(out)
}

/// Relaxes and thins the ends of `halves`.
// Not inlined: its working set stays in a frame of its own, which the planner's other
// phases then share instead of adding to (`Planner::plan`'s frame).
#[inline(never)]
pub fn relax(
    slice: &Slice,
    cells: &Cells,
    halves: &mut Halves,
    stats: &mut PlanStats,
) -> Result<(), Error> {
    let settings = *slice.settings();
    let spacing = settings.relax_spacing;
    let ring = ring_neighbours(halves, slice.holes().len())?;
    // Every half's bounding box, kept up to date as ends move: each move is checked against
    // the halves around it, and measuring all of them again for each was most of the work.
    let mut boxes: Vec<(Point, Point), MAX_HALVES> = Vec::new();
    halves.boxes(&mut boxes)?;
    let mut chunks: Vec<(Point, Point), { MAX_HALVES.div_ceil(RUN) }> = Vec::new();
    for run in boxes.chunks(RUN) {
        // Never full: one box per run of the boxes.
        chunks
            .push(primitives::union_all(run))
            .map_err(|_| Limit::Halves.error())?;
    }
    // The order of each sweep's ends by `x` (`EndIndex`), kept here for every sweep.
    let mut by_x: Vec<u16, MAX_HALVES> = Vec::new();
    for _ in 0..settings.relax_iterations {
        // Jacobi-style: every step is computed from the same state, then applied, so the
        // result does not depend on the order of the ends (symmetric slices stay symmetric).
        let list = ends(halves)?;
        let index = EndIndex::new(halves, &list, &mut by_x)?;
        let mut steps: Vec<Point, MAX_HALVES> = Vec::new();
        for k in 0..list.len() {
            // Never full: one step per end, and `list` has the same capacity.
            steps
                .push(relax_step(halves, &ring, &index, k, spacing))
                .map_err(|_| Limit::Halves.error())?;
        }
        let mut moved = false;
        for (&e, &step) in list.iter().zip(steps.iter()) {
            if step.norm2() > 0.0
                && try_move(
                    slice,
                    cells,
                    halves,
                    &mut boxes,
                    &mut chunks,
                    e as usize,
                    step,
                )
            {
                stats.relax_moves += 1;
                moved = true;
            }
        }
        if !moved {
            break;
        }
    }
    // Thinning: remove the most crowded end until no two ends are closer than the spacing.
    loop {
        let list = ends(halves)?;
        let index = EndIndex::new(halves, &list, &mut by_x)?;
        let mut worst: Option<(usize, usize)> = None;
        for (k, &e) in list.iter().enumerate() {
            let here = index.at(k);
            let crowd = index
                .near(here, spacing)
                .filter(|&o| o != k && index.at(o).dist(here) < spacing - 1e-4)
                .count();
            if crowd > 0 && worst.is_none_or(|w| crowd > w.1) {
                worst = Some((e as usize, crowd));
            }
        }
        let Some((e, _)) = worst else { break };
        halves[e].alive = false;
        if let Some(p) = halves[e].partner {
            halves[p as usize].alive = false;
        }
        stats.thinned += 1;
    }
    Ok(())
}

/// The ends of one sweep (`list`, by position there) in the order of their points' `x`, so
/// that the ends near a point are found by two binary searches instead of measuring every
/// end (the relaxation's sweeps measured every pair: a third of the plan's work).
struct EndIndex<'a> {
    halves: &'a Halves,
    list: &'a [u16],
    /// Positions in `list`, by the `x` of their end point (then by position).
    by_x: &'a [u16],
}

// A position in `list` is a `u16` in `by_x`.
const _: () = assert!(MAX_HALVES <= u16::MAX as usize + 1);

impl<'a> EndIndex<'a> {
    /// The index of `list`'s ends, its order kept in `by_x` (emptied first).
    fn new(
        halves: &'a Halves,
        list: &'a [u16],
        by_x: &'a mut Vec<u16, MAX_HALVES>,
    ) -> Result<EndIndex<'a>, Error> {
        by_x.clear();
        for k in 0..list.len() {
            // Never full: one per end, and `list` has the same capacity.
            by_x.push(k as u16).map_err(|_| Limit::Halves.error())?;
        }
        let x = |k: u16| halves.end_point(list[k as usize] as usize).x;
        by_x.sort_unstable_by(|&a, &b| x(a).total_cmp(&x(b)).then(a.cmp(&b)));
        Ok(EndIndex { halves, list, by_x })
    }

    /// The end point of position `k`.
    fn at(&self, k: usize) -> Point {
        self.halves.end_point(self.list[k] as usize)
    }

    /// Every position whose end lies within `reach` of `p` in `x` (with room to spare: twice
    /// `reach`, so that every end nearer `p` than `reach`, as `dist` rounds it, is among
    /// them), and some more, in the order of their `x`.
    fn near(&self, p: Point, reach: f32) -> impl Iterator<Item = usize> + '_ {
        let (lo, hi) = (p.x - 2.0 * reach, p.x + 2.0 * reach);
        let x = |k: &u16| self.at(*k as usize).x;
        let first = self.by_x.partition_point(|k| x(k) < lo);
        let last = self.by_x.partition_point(|k| x(k) <= hi);
        self.by_x[first..last.max(first)]
            .iter()
            .map(|&k| k as usize)
    }
}

/// Ends nearer each other than the spacing that [`relax_step`] sums in order from a buffer;
/// a crowd larger than that is summed by a pass over every end.
const CROWD: usize = 16;

/// The relaxation step of end `list[k]` (`index` holds the sweep's ends): towards the middle
/// of its neighbours around the hole(s) it joins (smoothing), and away from every end nearer
/// than `spacing` (repulsion, summed in the order of `list`), at most half the spacing long.
fn relax_step(
    halves: &Halves,
    ring: &[(u16, u16)],
    index: &EndIndex<'_>,
    k: usize,
    spacing: f32,
) -> Point {
    let list = index.list;
    let (e, here) = (list[k] as usize, index.at(k));
    let mut pull = Point::default();
    for k in [Some(e), halves[e].partner.map(|p| p as usize)]
        .into_iter()
        .flatten()
    {
        let (prev, next) = ring[k];
        let (prev, next) = (
            halves.end_point(prev as usize),
            halves.end_point(next as usize),
        );
        pull = pull + ((prev - here) + (next - here)) * 0.25;
    }
    // The ends nearer than `spacing`, in the order of `list` (the order the sum took when it
    // ran over every end): from the index, sorted, or where more crowd here than the buffer
    // holds, by a pass over every end.
    let near = |o: usize| o != k && here.dist(index.at(o)) < spacing;
    let mut crowd: Vec<u16, CROWD> = Vec::new();
    let mut overflow = false;
    for o in index.near(here, spacing).filter(|&o| near(o)) {
        // A position is a `u16` (`EndIndex`).
        if crowd.push(o as u16).is_err() {
            overflow = true;
            break;
        }
    }
    crowd.sort_unstable();
    debug_assert!(
        overflow
            || crowd
                .iter()
                .map(|&o| o as usize)
                .eq((0..list.len()).filter(|&o| near(o))),
        "the index missed an end near end {e}"
    );
    let mut push = Point::default();
    let mut repel = |o: usize| {
        let there = index.at(o);
        let d = here.dist(there);
        let away = if d > 1e-6 {
            (here - there) * (1.0 / d)
        } else {
            // Coincident ends: push along the order of their starts.
            Point::new(if e < list[o] as usize { -1.0 } else { 1.0 }, 0.0)
        };
        push = push + away * (0.5 * (spacing - d));
    };
    if overflow {
        (0..list.len()).filter(|&o| near(o)).for_each(&mut repel);
    } else {
        crowd.iter().for_each(|&o| repel(o as usize));
    }
    let step = pull + push;
    let len = step.norm();
    if len < 1e-4 * spacing {
        Point::default()
    } else if len > 0.5 * spacing {
        step * (0.5 * spacing / len)
    } else {
        step
    }
}

/// How many halves in a row share one box of `relax`'s runs.
const RUN: usize = 16;

/// Moves end `e` by (the projection onto its curve of) `push`; false if the move is refused.
/// `boxes` holds every half's bounding box and `runs` the box around each run of [`RUN`]
/// halves' boxes, and are kept so.
fn try_move(
    slice: &Slice,
    cells: &Cells,
    halves: &mut Halves,
    boxes: &mut [(Point, Point)],
    runs: &mut [(Point, Point)],
    e: usize,
    push: Point,
) -> bool {
    let half = 0.5 * slice.settings().road_width;
    let here = halves.end_point(e);
    let hole = halves[e].hole as usize;
    let (target, new_u) = match (halves[e].partner, halves[e].on_bisector) {
        (Some(_), Some((k, u))) => {
            let piece = &cells.bisectors[k as usize];
            let bis = &piece.points;
            let t = polyline::tangent_at(bis, u);
            let len = polyline::length(bis);
            let nu = (u + push.dot(t)).clamp(0.0, len);
            let on = onto_bisector(
                slice,
                piece.a as usize,
                piece.b as usize,
                polyline::point_at(bis, nu),
            );
            (on, Some((k, nu)))
        }
        _ => {
            // The wall's chunked distance query (`Feature::nearest`) for the nearest edge and
            // point, and its sign for the side.
            let wall = slice.wall().points();
            let edge = slice.wall().nearest(here).edge;
            let t = (wall[(edge + 1) % wall.len()] - wall[edge]).normalized();
            let moved = here + t * push.dot(t);
            let near = slice.wall().nearest(moved);
            let c = near.point;
            let inward = if near.distance < 0.0 {
                moved - c
            } else {
                c - moved
            };
            let inward = if inward.norm2() > 1e-12 {
                inward.normalized()
            } else {
                (here - c).normalized()
            };
            (c + inward * half, None)
        }
    };
    let partner = halves[e].partner.map(|p| p as usize);
    // A wall end must stay in its own cell; a joint stays on its bisector by construction.
    let leaves_cell = partner.is_none() && slice.nearest_holes(target).0 != hole;
    if target.dist(here) < 1e-5 || !slice.is_printable(target, 1e-3) || leaves_cell {
        return false;
    }
    let mut a = halves.points_copy(e);
    reshape_end(&mut a, target);
    let mut b = partner.map(|p| {
        let mut b = halves.points_copy(p);
        reshape_end(&mut b, target);
        b
    });
    let skip = [e, partner.unwrap_or(e)];
    let holes = [
        halves[e].hole,
        partner.map_or(halves[e].hole, |p| halves[p].hole),
    ];
    let index = HalfBoxes {
        boxes,
        runs,
        run: RUN,
    };
    if crosses_finished_chunked(halves, index, &a, &skip, &holes)
        || b.as_ref()
            .is_some_and(|b| crosses_finished_chunked(halves, index, b, &skip, &holes))
    {
        return false;
    }
    if let Some(nu) = new_u {
        halves[e].on_bisector = Some(nu);
        if let Some(p) = partner {
            halves[p].on_bisector = Some(nu);
        }
    }
    boxes[e] = primitives::bbox(&a);
    halves.set_points(e, &a);
    if let (Some(p), Some(b)) = (partner, b.as_mut()) {
        boxes[p] = primitives::bbox(b);
        halves.set_points(p, b);
    }
    for k in [Some(e), partner].into_iter().flatten() {
        let c = k / RUN;
        runs[c] = primitives::union_all(&boxes[c * RUN..((c + 1) * RUN).min(boxes.len())]);
    }
    true
}
