//! The zigzag layer (paper, section 2.3): a crosshatch along the MCLs.
//!
//! Every MCL is deposited once. Its two ends lie on keep-out curves (a hole's, the wall's);
//! consecutive ends along each curve are paired by short *arcs* of that curve, so the road runs
//! out along one MCL, along the curve to the next MCL, back along it, and so on. Which of the
//! two pairings each curve uses decides how the MCLs and arcs link up: the roads form paths
//! and loops. The paper's parity rule (start on the wall when it holds an odd number of MCL
//! ends, else on a feature) is what leaves a curve with an unpaired end; here the pairings of
//! all curves are searched together for the fewest separate pieces, and loops that lie side
//! by side on a curve are then spliced into one (two neighbouring arcs swapped crosswise, at
//! the cost of one short doubled stretch of curve). Pieces that still lie apart but reach one
//! curve are then joined across the stretch between their nearest ends there
//! ([`splice_across`]: that stretch is laid twice, over the ends between). Only what reaches
//! no curve of the rest is reached by a travel move to the nearest free end, as the paper does
//! for its internal regions.
//!
//! Where the two MCLs an arc joins at a hole crowd their neighbours there (a strong fan round a
//! small hole), the road turns from one to the other short of the hole instead of along the
//! arc (`turns`): the pieces stay as paired, and the roads beside the pair widen into the
//! ground it leaves, their bands measured against what each MCL lays (`Fan::cut`).
//!
//! Each MCL's road owns half the gap to its neighbouring MCLs either side
//! (`meander::band::band_at`) and is as wide as that band up to
//! [`max_width`](crate::Settings::max_width). Where MCLs fan apart (toward the wall, in large
//! cells) the band outgrows it, and the road fills the band with a *meander* instead
//! (`meander::meander`): strokes across the band a road apart, each stroke's ends kept a road
//! off every keep-out curve where an arc may run, half a road where none does (a stretch the
//! pairing leaves between two ends, `ends::Arcs`), all still inside the one road. The strokes
//! lie on one grid along the whole MCL, the first and last a road from its ends, whatever the
//! spacing of its vertices; where a meander reaches an MCL end beside a stretch no arc lays, the
//! road lays its half of that stretch along the curve (`emit::Strip`), its run of strokes
//! starting (or ending) on that side. The strokes come in runs
//! of at least three (a band too wide for a road or two only, as on the outer side of a bend,
//! is left as slivers: a one-stroke jog laps over the road either side). Where the band stays
//! too wide for a long way (at least twice as long as it is wide), the road lays that stretch
//! in *lanes* instead (`meander::lanes`): an odd number of roads along the MCL, side by side
//! across the band, out and back in turn, which turn only at the stretch's two ends, where
//! strokes turn twice a road and the round corners of two neighbouring meanders' turns leave
//! stars of bare ground. The bands, road widths, meanders and lanes are in the sibling module
//! `meander`.

mod arc;
mod emit;
mod ends;
mod turns;

use arc::{emit_arc, inner_end};
use emit::{emit_mcl, Strip};
use ends::{end_point, even_out, find, open_pieces, Arcs, Ends};
use turns::{cut_turns, is_cut, Cuts};

use super::despike::{finish, Despike};
use super::lining::Lining;
use core::cell::RefCell;
use heapless::Vec;

use crate::config::{MAX_HOLES, MAX_MCLS};
use crate::error::Limit;
use crate::geometry::Point;
use crate::keep_out::{KeepOut, Side};
use crate::toolpath::meander::band::{fan_boxes, Fan, FanBoxes, FanChunks};
use crate::toolpath::meander::near::Near;
use crate::toolpath::PathSink;
use crate::{Error, Plan, Slice};

const ENDS: usize = 2 * MAX_MCLS;
/// Keep-out curves: one per hole, then the wall's.
const CURVES: usize = MAX_HOLES + 1;
// End ids, curve ranges and union-find parents are `u16`, with `NONE` (`u16::MAX`) spare;
// curve ids (`holes` for the wall) are `u8`.
const _: () = assert!(ENDS < u16::MAX as usize);
const _: () = assert!(CURVES <= u8::MAX as usize);
/// How far inside the material every road's edge stays, mm: roads along a keep-out curve are
/// this much narrower than a road each side, so the chords between the curve's points (whose
/// sagitta cuts a few µm into the keep-out band) do not reach into a feature.
pub(super) const EDGE_MARGIN: f32 = 3e-3;
/// Where the first and the last move of an MCL get extra vertices, road widths from its end:
/// the road narrows to a road width at a keep-out curve but may be wider just off it, so the
/// width follows the clearance there instead of tapering over the whole move. A meander
/// sample takes a vertex of its own only beyond the last of them (`meander`), so the road's
/// vertices stay in order along the MCL.
pub(super) const END_STEPS: [f32; 3] = [0.25, 0.5, 1.0];
pub(super) const NONE: u16 = u16::MAX;
/// Up to this many curves with an even number of ends, every combination of their pairings
/// is tried (every slice of up to 8 holes); beyond, pairings are improved one curve at a time.
const EXHAUSTIVE_PAIRINGS: usize = 9;
const _: () = assert!(EXHAUSTIVE_PAIRINGS < 32);

/// Counters of a zigzag layer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ZigzagStats {
    /// Separate pieces after choosing the pairings.
    pub pieces_paired: u16,
    /// Pieces after splicing loops together and bridging: the extrusion starts of the layer.
    pub pieces: u16,
    /// Loops spliced together.
    pub splices: u16,
    /// Pieces joined across a stretch of keep-out curve that other ends lie on (laid twice
    /// there), where splicing side by side left them apart.
    pub bridges: u16,
    /// MCLs left out to fix the parity of the curves.
    pub dropped: u16,
    /// Pairs of MCLs that turn short of a hole where they crowd (`turns`).
    pub turns: u16,
    /// Stretches of road laid in lanes along their MCL (`meander::lanes`), where the band
    /// stays too wide for one road for a long way.
    pub lanes: u16,
}

/// Writes the zigzag layer of `plan` into `sink`, spikes dropped
/// ([`despike`](super::despike)).
pub fn zigzag(slice: &Slice, plan: &Plan, sink: &mut impl PathSink) -> Result<ZigzagStats, Error> {
    if slice.holes().is_empty() {
        return Err(Error::NoHoles);
    }
    let mut lined = Lining::new(sink, slice);
    let mut despiked = Despike::new(&mut lined, slice);
    let stats = zigzag_into(slice, plan, &mut despiked)?;
    finish(&mut despiked)?;
    Ok(stats)
}

// Not inlined: its working set (the keep-out curves, the ends: some 50 KiB on a controller)
// stays in a frame of its own, which a caller's other branches (the spiral layer in
// `app::job::layer_path`) then share instead of adding to.
#[inline(never)]
fn zigzag_into(slice: &Slice, plan: &Plan, sink: &mut impl PathSink) -> Result<ZigzagStats, Error> {
    let half = 0.5 * slice.settings().road_width;
    let holes = slice.holes().len();
    // A slice holds at most MAX_HOLES holes, and one wall: a full buffer is a slice with more
    // holes than the capacity, said so.
    let mut curves: Vec<KeepOut<'_>, CURVES> = Vec::new();
    for h in slice.holes() {
        curves
            .push(KeepOut::new(h, half, Side::Outside))
            .map_err(|_| Limit::Holes.error())?;
    }
    curves
        .push(KeepOut::new(slice.wall(), half, Side::Inside))
        .map_err(|_| Limit::Holes.error())?;
    // Parity: every curve with an odd number of MCL ends leaves one end free, and each pair
    // of free ends is a separate path. Beyond one path, leave out MCLs until at most two
    // curves are odd ([`even_out`]).
    let mut active: Vec<u16, MAX_MCLS> = (0..plan.mcls.len() as u16).collect();
    even_out(plan, holes, &mut active);
    let mut stats = ZigzagStats {
        dropped: (plan.mcls.len() - active.len()) as u16,
        ..ZigzagStats::default()
    };
    let mut ends = Ends::empty();
    ends.fill(slice, plan, &curves, &active)?;
    if ends.count == 0 {
        return Ok(stats);
    }
    let mut parent = [0u16; ENDS];

    // Odd curves: leave unpaired the end after the longest gap (just after a branch point,
    // where the paper starts). Even curves: search both pairings of each.
    let mut even: Vec<usize, CURVES> = Vec::new();
    for c in 0..=holes {
        let (a, b) = ends.ranges[c];
        let n = (b - a) as usize;
        if n == 0 {
            continue;
        }
        if n % 2 == 1 {
            let mut best = (0, f32::NEG_INFINITY);
            for k in 0..n {
                let prev = ends.param[ends.order[a as usize + (k + n - 1) % n] as usize];
                let here = ends.param[ends.order[a as usize + k] as usize];
                let gap = curves[c].wrap(here - prev);
                if gap > best.1 {
                    best = (k, gap);
                }
            }
            ends.pair_curve(c, best.0 + 1);
        } else {
            // Never full: at most one entry per curve.
            even.push(c).map_err(|_| Limit::Holes.error())?;
            ends.pair_curve(c, 0);
        }
    }
    stats.pieces_paired = if even.len() <= EXHAUSTIVE_PAIRINGS {
        let mut best = (u16::MAX, 0u32);
        for mask in 0..(1u32 << even.len()) {
            for (bit, &c) in even.iter().enumerate() {
                ends.pair_curve(c, ((mask >> bit) & 1) as usize);
            }
            let p = ends.pieces(&mut parent);
            if p < best.0 {
                best = (p, mask);
            }
        }
        for (bit, &c) in even.iter().enumerate() {
            ends.pair_curve(c, ((best.1 >> bit) & 1) as usize);
        }
        best.0
    } else {
        // Too many curves to try every combination: flip one curve's pairing at a time while
        // that leaves fewer pieces.
        let mut best = ends.pieces(&mut parent);
        let mut choice = [0usize; CURVES];
        let mut improved = true;
        while improved {
            improved = false;
            for (i, &c) in even.iter().enumerate() {
                ends.pair_curve(c, 1 - choice[i]);
                let p = ends.pieces(&mut parent);
                if p < best {
                    best = p;
                    choice[i] = 1 - choice[i];
                    improved = true;
                } else {
                    ends.pair_curve(c, choice[i]);
                }
            }
        }
        best
    };

    // Splice loops lying side by side on a curve: arcs (a, b) and (c, d) with b, c adjacent
    // become (a, d) and (b, c).
    let mut spliced = true;
    while spliced {
        spliced = false;
        ends.pieces(&mut parent);
        let open = open_pieces(&ends, &mut parent);
        'curves: for c in 0..=holes {
            let (lo, hi) = ends.ranges[c];
            let n = (hi - lo) as usize;
            for k in 0..n {
                let b = ends.order[lo as usize + k];
                let cc = ends.order[lo as usize + (k + 1) % n];
                let (a, d) = (ends.arc[b as usize], ends.arc[cc as usize]);
                if a == NONE || d == NONE || a == cc || b == d {
                    continue;
                }
                // a must come just before b, d just after c, along the curve.
                let before = ends.order[lo as usize + (k + n - 1) % n];
                let after = ends.order[lo as usize + (k + 2) % n];
                if a != before || d != after {
                    continue;
                }
                let (rb, rc) = (find(&mut parent, b), find(&mut parent, cc));
                if rb == rc || (open[rb as usize] && open[rc as usize]) {
                    continue;
                }
                ends.rejoin(b, cc);
                stats.splices += 1;
                spliced = true;
                break 'curves;
            }
        }
    }
    // Pieces still apart that reach one curve: splice them across the stretch between their
    // nearest arcs there ([`splice_across`]), the shortest stretch first.
    while splice_across(&mut ends, &curves, &mut parent) {
        stats.bridges += 1;
    }
    stats.pieces = ends.pieces(&mut parent);

    // The MCLs laid, and their boxes: each road's band reaches to the next of them.
    let mut boxes: FanBoxes = Vec::new();
    let mut chunks: FanChunks = Vec::new();
    fan_boxes(plan, &ends.mcls, &mut boxes, &mut chunks)?;
    let near = RefCell::new(Near::new());
    // The strips along the curves that no arc lays, which the meanders' strokes may fill.
    let arcs = Arcs::new(&ends, &curves);
    let bare = |p: Point, margin: f32| arcs.bare(slice, &ends, &curves, p, margin);
    let fan = Fan {
        me: NONE,
        at: 0,
        laid: &ends.mcls,
        boxes: &boxes,
        chunks: &chunks,
        near: &near,
        bare: Some(&bare),
        cut: &[],
    };
    // Pairs that crowd at a hole turn short of it ([`turns`]).
    let mut cuts = Cuts::new();
    stats.turns = cut_turns(slice, plan, &ends, &curves, &fan, &mut cuts)?;
    let fan = Fan { cut: &cuts, ..fan };

    // Walk the pieces: paths from a free end, loops from their smallest end; between pieces
    // (which reach no keep-out curve in common, [`splice_across`]), travel to the nearest end
    // that may start one.
    let open = open_pieces(&ends, &mut parent);
    let mut visited = [false; ENDS];
    let mut here: Option<Point> = None;
    loop {
        let mut next: Option<(u16, f32)> = None;
        for id in 0..ends.count as u16 {
            if visited[id as usize] {
                continue;
            }
            let root = find(&mut parent, id);
            if open[root as usize] && ends.arc[id as usize] != NONE {
                continue;
            }
            let p = end_point(plan, &ends, id);
            let d = here.map_or(0.0, |h| h.dist(p));
            if next.is_none_or(|n| d < n.1) {
                next = Some((id, d));
            }
        }
        let Some((start, _)) = next else { break };
        let mut id = start;
        let mut first = true;
        loop {
            // Along the MCL from `id` to its other end.
            let k = ends.mcls[(id / 2) as usize] as usize;
            let forward = id % 2 == 0;
            let fan = Fan {
                me: k as u16,
                at: id / 2,
                ..fan
            };
            // In walking order: the end it starts from, then the other.
            let spliced = [id, id ^ 1].map(|e| {
                (!is_cut(&cuts, e) && inner_end(&ends, &curves, e))
                    .then_some(ends.curve[e as usize] as usize)
            });
            // The bare stretches beside its ends, which a meander reaching them lays.
            let strips = [id, id ^ 1].map(|e| {
                (!is_cut(&cuts, e))
                    .then(|| Strip::beside(&arcs, &ends, &curves, e))
                    .flatten()
            });
            visited[id as usize] = true;
            let other = id ^ 1;
            visited[other as usize] = true;
            let mate = ends.arc[other as usize];
            let next = (mate != NONE && !visited[mate as usize]).then_some(mate);
            let laned = emit_mcl(slice, plan, k, &fan, spliced, strips, forward, first, sink)?;
            stats.lanes = stats.lanes.saturating_add(laned);
            first = false;
            let Some(mate) = next else {
                here = Some(end_point(plan, &ends, other));
                break;
            };
            // Along the curve from `other` to `mate`.
            // (A short turn: the next MCL's first move lays it.)
            if !is_cut(&cuts, other) {
                let c = ends.curve[other as usize] as usize;
                emit_arc(slice, &ends, &curves[c], c, (other, mate), &cuts, sink)?;
            }
            id = mate;
        }
    }
    Ok(stats)
}

/// Splices two pieces that lie apart but reach one keep-out curve, where splicing side by side
/// could not (their arcs on it are not neighbours). Of ends `b` and `c` of two pieces on one
/// curve (two paths only by free ends), `c` the first end after `b` along the curve that
/// belongs to another such piece, the pair with the shortest stretch from `b` to `c` is joined
/// by an arc ([`Ends::rejoin`]): where both have arcs, `(a, b)` and `(c, d)` become `(a, d)`
/// and `(b, c)`; where one is a path's free end, the other's arc is broken and its mate
/// becomes the path's new free end; two free ends are joined as they are. The two pieces
/// become one; the new arcs run over the ends between `b` and `c` (and `(a, d)` over
/// both old arcs' stretches), so that stretch of curve is laid twice: a doubled stretch
/// instead of a jump and a new start. Returns whether it spliced.
fn splice_across(ends: &mut Ends, curves: &[KeepOut<'_>], parent: &mut [u16; ENDS]) -> bool {
    if ends.pieces(parent) <= 1 {
        return false;
    }
    let open = open_pieces(ends, parent);
    // (stretch, b, c)
    let mut best: Option<(f32, u16, u16)> = None;
    for (c, curve) in curves.iter().enumerate() {
        let (lo, hi) = ends.ranges[c];
        let (lo, n) = (lo as usize, (hi - lo) as usize);
        for k in 0..n {
            let b = ends.order[lo + k];
            let rb = find(parent, b);
            for j in 1..n {
                let cc = ends.order[lo + (k + j) % n];
                let rc = find(parent, cc);
                // Two paths join only end to end (swapping their arcs leaves two paths).
                let both_open = open[rb as usize] && open[rc as usize];
                let free = ends.arc[b as usize] == NONE && ends.arc[cc as usize] == NONE;
                if rc == rb || (both_open && !free) {
                    continue;
                }
                let stretch = curve.wrap(ends.param[cc as usize] - ends.param[b as usize]);
                if best.is_none_or(|x| stretch < x.0) {
                    best = Some((stretch, b, cc));
                }
                break;
            }
        }
    }
    let Some((_, b, cc)) = best else {
        return false;
    };
    ends.rejoin(b, cc);
    true
}
