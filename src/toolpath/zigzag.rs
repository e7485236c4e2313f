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
//! the cost of one short doubled stretch of curve). What still remains separate is reached by
//! a travel move to the nearest free end, as the paper does for its internal regions.
//!
//! Each MCL's road owns half the gap to its neighbouring MCLs either side
//! (`meander::band_at`) and is as wide as that band up to
//! [`max_width`](crate::Settings::max_width). Where MCLs fan apart (toward the wall, in large
//! cells) the band outgrows it, and the road fills the band with a *meander* instead
//! (`meander::meander`): strokes across the band a road apart, each stroke's ends kept a road
//! off every keep-out curve (where the arcs run), all still inside the one road. The strokes
//! lie on one grid along the whole MCL, whatever the spacing of its vertices. The bands, road
//! widths and meanders are in the sibling module `meander`.

use super::despike::{finish, Despike};
use heapless::Vec;

use crate::config::{MAX_HOLES, MAX_MCLS};
use crate::error::Limit;
use crate::geometry::{polyline, Point};
use crate::keep_out::{KeepOut, Side};
use crate::toolpath::composition::{along, mcl_end_materials};
use crate::toolpath::meander::{band_at, meander, road_at, too_wide, Fan, Strokes, CHUNK};
use crate::toolpath::{emit_move, PathSink, Vertex};
use crate::{Error, Plan, Slice, Target};

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
/// width follows the clearance there instead of tapering over the whole move.
const END_STEPS: [f32; 3] = [0.25, 0.5, 1.0];
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
    /// Pieces after splicing loops together: the extrusion starts of the layer.
    pub pieces: u16,
    /// Loops spliced together.
    pub splices: u16,
    /// MCLs left out to fix the parity of the curves.
    pub dropped: u16,
}

/// The curves (hole index, or `holes` for the wall) of the two ends of MCL `k`.
fn curve_pair(plan: &Plan, k: usize, holes: usize) -> (usize, usize) {
    let m = &plan.mcls[k];
    let b = match m.to {
        Target::Hole(j) => j as usize,
        Target::Wall => holes,
    };
    (m.from as usize, b)
}

/// The ends of all MCLs, on their curves.
struct Ends {
    /// The MCLs taking part: end ids `2i`, `2i + 1` are the ends of MCL `mcls[i]`.
    mcls: Vec<u16, MAX_MCLS>,
    /// Curve of each end: a hole index, or `holes` for the wall.
    curve: [u8; ENDS],
    /// Parameter of each end along its curve.
    param: [f32; ENDS],
    /// End ids sorted by (curve, param).
    order: Vec<u16, ENDS>,
    /// Where each end stands in `order`, counted from the start of its curve's range.
    slot: [u16; ENDS],
    /// For each curve, its range in `order`.
    ranges: Vec<(u16, u16), CURVES>,
    /// The arc partner of each end (NONE if unpaired).
    arc: [u16; ENDS],
    count: usize,
}

fn find(parent: &mut [u16], mut x: u16) -> u16 {
    while parent[x as usize] != x {
        parent[x as usize] = parent[parent[x as usize] as usize];
        x = parent[x as usize];
    }
    x
}

fn union(parent: &mut [u16], a: u16, b: u16) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        let (lo, hi) = (ra.min(rb), ra.max(rb));
        parent[hi as usize] = lo;
    }
}

impl Ends {
    fn new(
        slice: &Slice,
        plan: &Plan,
        curves: &[KeepOut<'_>],
        mcls: &Vec<u16, MAX_MCLS>,
    ) -> Result<Ends, Error> {
        let holes = slice.holes().len();
        let mut e = Ends {
            mcls: mcls.clone(),
            curve: [0; ENDS],
            param: [0.0; ENDS],
            order: Vec::new(),
            ranges: Vec::new(),
            arc: [NONE; ENDS],
            slot: [0; ENDS],
            count: 2 * mcls.len(),
        };
        for (k, &mk) in mcls.iter().enumerate() {
            let m = &plan.mcls[mk as usize];
            e.curve[2 * k] = m.from;
            e.param[2 * k] = plan.halves[m.first as usize].s;
            match (m.to, m.second) {
                (Target::Hole(j), Some(second)) => {
                    e.curve[2 * k + 1] = j;
                    e.param[2 * k + 1] = plan.halves[second as usize].s;
                }
                _ => {
                    let last = plan.halves[m.first as usize].end_point();
                    e.curve[2 * k + 1] = holes as u8;
                    e.param[2 * k + 1] = curves[holes].param_of(last);
                }
            }
        }
        for id in 0..e.count as u16 {
            // Never full: two ends per MCL, at most ENDS.
            e.order.push(id).map_err(|_| Limit::Mcls.error())?;
        }
        let (curve, param) = (&e.curve, &e.param);
        e.order.sort_unstable_by(|&a, &b| {
            curve[a as usize]
                .cmp(&curve[b as usize])
                .then(param[a as usize].total_cmp(&param[b as usize]))
                .then(a.cmp(&b))
        });
        let mut start = 0;
        for c in 0..=holes {
            let mut end = start;
            while end < e.count && e.curve[e.order[end] as usize] as usize == c {
                end += 1;
            }
            for k in start..end {
                e.slot[e.order[k] as usize] = (k - start) as u16;
            }
            // Never full: one range per curve, at most CURVES.
            e.ranges
                .push((start as u16, end as u16))
                .map_err(|_| Limit::Holes.error())?;
            start = end;
        }
        Ok(e)
    }

    /// Pairs consecutive ends of curve `c` starting at position `offset` of its range; with an
    /// odd count the end at `offset - 1` stays unpaired.
    fn pair_curve(&mut self, c: usize, offset: usize) {
        let (a, b) = self.ranges[c];
        let (a, b) = (a as usize, b as usize);
        let n = b - a;
        for k in a..b {
            self.arc[self.order[k] as usize] = NONE;
        }
        for i in 0..n / 2 {
            let x = self.order[a + (offset + 2 * i) % n];
            let y = self.order[a + (offset + 2 * i + 1) % n];
            self.arc[x as usize] = y;
            self.arc[y as usize] = x;
        }
    }

    /// Number of separate pieces (paths and loops) of MCLs and arcs.
    fn pieces(&self, parent: &mut [u16; ENDS]) -> u16 {
        for (i, p) in parent.iter_mut().enumerate().take(self.count) {
            *p = i as u16;
        }
        for k in 0..self.count / 2 {
            union(parent, 2 * k as u16, 2 * k as u16 + 1);
        }
        for i in 0..self.count {
            if self.arc[i] != NONE {
                union(parent, i as u16, self.arc[i]);
            }
        }
        (0..self.count)
            .filter(|&i| find(parent, i as u16) == i as u16)
            .count() as u16
    }
}

/// Writes the zigzag layer of `plan` into `sink`, spikes dropped
/// ([`despike`](super::despike)).
pub fn zigzag(slice: &Slice, plan: &Plan, sink: &mut impl PathSink) -> Result<ZigzagStats, Error> {
    if slice.holes().is_empty() {
        return Err(Error::NoHoles);
    }
    let mut despiked = Despike::new(sink, slice.settings().road_width);
    let stats = zigzag_into(slice, plan, &mut despiked)?;
    finish(&mut despiked)?;
    Ok(stats)
}

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
    let mut ends = Ends::new(slice, plan, &curves, &active)?;
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
                ends.arc[a as usize] = d;
                ends.arc[d as usize] = a;
                ends.arc[b as usize] = cc;
                ends.arc[cc as usize] = b;
                stats.splices += 1;
                spliced = true;
                break 'curves;
            }
        }
    }
    stats.pieces = ends.pieces(&mut parent);

    // The MCLs laid, and their boxes: each road's band reaches to the next of them.
    let mut boxes: Vec<(Point, Point), MAX_MCLS> = Vec::new();
    for &k in ends.mcls.iter() {
        let pts = plan.points(&plan.mcls[k as usize]);
        let mut lo = pts[0];
        let mut hi = pts[0];
        for q in pts.iter() {
            lo = Point::new(lo.x.min(q.x), lo.y.min(q.y));
            hi = Point::new(hi.x.max(q.x), hi.y.max(q.y));
        }
        boxes
            .push((lo, hi))
            .map_err(|_| crate::error::Limit::Mcls.error())?;
    }
    let mut chunks: Vec<(Point, Point), { MAX_MCLS.div_ceil(CHUNK) }> = Vec::new();
    for run in boxes.chunks(CHUNK) {
        let (mut lo, mut hi) = run[0];
        for &(a, b) in run {
            lo = Point::new(lo.x.min(a.x), lo.y.min(a.y));
            hi = Point::new(hi.x.max(b.x), hi.y.max(b.y));
        }
        chunks
            .push((lo, hi))
            .map_err(|_| crate::error::Limit::Mcls.error())?;
    }
    let fan = Fan {
        me: NONE,
        at: 0,
        laid: &ends.mcls,
        boxes: &boxes,
        chunks: &chunks,
    };

    // Walk the pieces: paths from a free end, loops from their smallest end; between pieces,
    // travel to the nearest free end.
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
            let spliced = [id, id ^ 1]
                .map(|e| inner_end(&ends, &curves, e).then_some(ends.curve[e as usize] as usize));
            visited[id as usize] = true;
            let other = id ^ 1;
            visited[other as usize] = true;
            let mate = ends.arc[other as usize];
            let next = (mate != NONE && !visited[mate as usize]).then_some(mate);
            emit_mcl(slice, plan, k, &fan, spliced, forward, first, sink)?;
            first = false;
            let Some(mate) = next else {
                here = Some(end_point(plan, &ends, other));
                break;
            };
            // Along the curve from `other` to `mate`.
            let c = ends.curve[other as usize] as usize;
            emit_arc(slice, &ends, &curves[c], c, other, mate, sink)?;
            id = mate;
        }
    }
    Ok(stats)
}

/// MCL ends per curve (a hole index, or `holes` for the wall) among the `active` MCLs.
fn end_counts(plan: &Plan, holes: usize, active: &[u16]) -> [u16; CURVES] {
    let mut count = [0u16; CURVES];
    for &k in active {
        let (a, b) = curve_pair(plan, k as usize, holes);
        count[a] += 1;
        count[b] += 1;
    }
    count
}

/// How many separate groups the curves holding MCL ends form, joined by the `active` MCLs.
fn curve_groups(plan: &Plan, holes: usize, active: &[u16]) -> usize {
    let mut parent = [0u16; CURVES];
    for (i, p) in parent.iter_mut().enumerate() {
        *p = i as u16;
    }
    for &k in active {
        let (a, b) = curve_pair(plan, k as usize, holes);
        union(&mut parent, a as u16, b as u16);
    }
    let count = end_counts(plan, holes, active);
    (0..=holes)
        .filter(|&c| count[c] > 0 && find(&mut parent, c as u16) == c as u16)
        .count()
}

/// Leaves MCLs out of `active` until at most two curves hold an odd number of MCL ends (a
/// T-join: every odd curve is a free end, and each pair of free ends a separate path).
///
/// Each step takes the shortest chain of MCLs (by length, Dijkstra over the curves) from one
/// odd curve to another and leaves the whole chain out: its two end curves turn even, and
/// every curve it passes through loses two ends and keeps its parity. A chain is taken only
/// if every curve it touches keeps at least one MCL end (each feature's strip is still laid)
/// and the curves stay as connected as they were (the pieces can still be spliced into one
/// road). The neighbours' bands reach over the ground of the MCLs left out
/// (`meander::band_at` measures to the MCLs laid). Where no chain qualifies, the odd curves
/// that remain stay odd, and the layer needs a start per pair of them.
fn even_out(plan: &Plan, holes: usize, active: &mut Vec<u16, MAX_MCLS>) {
    let curves = holes + 1;
    let mut length = [0.0f32; MAX_MCLS];
    for &k in active.iter() {
        length[k as usize] = polyline::length(&plan.points(&plan.mcls[k as usize]));
    }
    // Chains found to split the curves or empty one: not tried again.
    let mut refused: Vec<(u8, u8), { 4 * CURVES }> = Vec::new();
    loop {
        let count = end_counts(plan, holes, active);
        let odd = |c: usize| count[c] % 2 == 1;
        if (0..curves).filter(|&c| odd(c)).count() <= 2 {
            return;
        }
        let groups = curve_groups(plan, holes, active);
        // The shortest MCL joining each pair of curves.
        let mut edge = [[(f32::INFINITY, NONE); CURVES]; CURVES];
        for &k in active.iter() {
            let (a, b) = curve_pair(plan, k as usize, holes);
            if a != b && length[k as usize] < edge[a][b].0 {
                edge[a][b] = (length[k as usize], k);
                edge[b][a] = (length[k as usize], k);
            }
        }
        // The shortest chain from each odd curve to the nearest other odd curve.
        let mut best: Option<(f32, u8, u8, [u16; CURVES])> = None;
        for src in (0..curves).filter(|&c| odd(c)) {
            let mut dist = [f32::INFINITY; CURVES];
            // The MCL by which each curve was reached (NONE for the source).
            let mut via = [NONE; CURVES];
            let mut done = [false; CURVES];
            dist[src] = 0.0;
            while let Some(c) = (0..curves)
                .filter(|&c| !done[c] && dist[c].is_finite())
                .min_by(|&a, &b| dist[a].total_cmp(&dist[b]))
            {
                done[c] = true;
                if c != src && odd(c) && !refused.contains(&(src as u8, c as u8)) {
                    if best.is_none_or(|b| dist[c] < b.0) {
                        best = Some((dist[c], src as u8, c as u8, via));
                    }
                    break;
                }
                for other in 0..curves {
                    let (len, k) = edge[c][other];
                    let d = dist[c] + len;
                    if !done[other] && d < dist[other] {
                        dist[other] = d;
                        via[other] = k;
                    }
                }
            }
        }
        let Some((_, src, dst, via)) = best else {
            return;
        };
        // Walk the chain back from `dst` and leave it out, unless that empties a curve or
        // splits the curves.
        let before: Vec<u16, MAX_MCLS> = active.clone();
        let mut c = dst as usize;
        while c != src as usize {
            let k = via[c];
            let (a, b) = curve_pair(plan, k as usize, holes);
            if let Some(i) = active.iter().position(|&m| m == k) {
                active.remove(i);
            }
            c = if a == c { b } else { a };
        }
        let after = end_counts(plan, holes, active);
        let emptied = (0..curves).any(|c| count[c] > 0 && after[c] == 0);
        if emptied || curve_groups(plan, holes, active) > groups {
            *active = before;
            if refused.push((src, dst)).is_err() {
                return;
            }
        }
    }
}

/// For every piece (by its union-find root), whether it has a free end: a path, not a loop.
fn open_pieces(ends: &Ends, parent: &mut [u16; ENDS]) -> [bool; ENDS] {
    let mut open = [false; ENDS];
    for i in 0..ends.count {
        if ends.arc[i] == NONE {
            open[find(parent, i as u16) as usize] = true;
        }
    }
    open
}

fn end_point(plan: &Plan, ends: &Ends, id: u16) -> Point {
    let pts = plan.points(&plan.mcls[ends.mcls[(id / 2) as usize] as usize]);
    if id % 2 == 0 {
        pts[0]
    } else {
        pts[pts.len() - 1]
    }
}

/// Deposits MCL `k` from its `from` end (`forward`) or from its far end, `near` its
/// neighbouring MCLs ([`neighbours`]), `spliced` the curve of each end (`from` end first) that
/// leads into a splice's inner arc ([`inner_end`]); the first vertex of a piece is reached by
/// travel.
#[allow(clippy::too_many_arguments)]
fn emit_mcl(
    slice: &Slice,
    plan: &Plan,
    k: usize,
    fan: &Fan<'_>,
    spliced: [Option<usize>; 2],
    forward: bool,
    travel_to_start: bool,
    sink: &mut impl PathSink,
) -> Result<(), Error> {
    let w = slice.settings().road_width;
    let pts = plan.points(&plan.mcls[k]);
    let (ma, mb) = mcl_end_materials(slice, plan, k);
    // Arc length at every vertex, summed from the `from` end either way, so both ends carry
    // exactly their feature's material.
    let mut cum = [0.0f32; crate::config::MCL_POINTS];
    for i in 1..pts.len() {
        cum[i] = cum[i - 1] + pts[i - 1].dist(pts[i]);
    }
    let n = pts.len();
    let len = cum[n - 1];
    // The MCL's vertices in walking order, with extra ones near both ends (`END_STEPS`).
    let order = |step: usize| if forward { step } else { n - 1 - step };
    // Cannot fail: at most `END_STEPS.len()` extras before and after one vertex.
    let mut stops: Vec<(Point, Point, f32, bool), { 2 * END_STEPS.len() + 2 }> = Vec::new();
    // Extra stops on the move from end vertex `e` toward vertex `q`, nearest the end first;
    // on a move that is both first and last, each end's stay on its own half.
    let (pts, cum) = (&pts, &cum);
    let extras = |e: usize, q: usize| {
        let seg = pts[e].dist(pts[q]);
        let reach = if n == 2 { 0.5 * seg } else { seg - 1e-4 };
        END_STEPS
            .iter()
            .filter(move |&&f| f * w < reach)
            .map(move |&f| {
                let t = f * w / seg;
                let at_cum = cum[e] + (cum[q] - cum[e]) * t;
                (pts[e].lerp(pts[q], t), pts[q] - pts[e], at_cum, false)
            })
    };
    let mut strokes = Strokes::new();
    for step in 0..n {
        let i = order(step);
        let dir = pts[(i + 1).min(n - 1)] - pts[i.saturating_sub(1)];
        let is_end = step == 0 || step + 1 == n;
        stops.clear();
        if step + 1 == n && n >= 2 {
            // Approaching the far end.
            for stop in extras(i, order(step - 1)).rev() {
                stops.push(stop).map_err(|_| Limit::PathVertices.error())?;
            }
        }
        stops
            .push((pts[i], dir, cum[i], is_end))
            .map_err(|_| Limit::PathVertices.error())?;
        if step == 0 && n >= 2 {
            // Leaving the first end.
            for stop in extras(i, order(1)) {
                stops.push(stop).map_err(|_| Limit::PathVertices.error())?;
            }
        }
        for (k, &(p, dir, at_cum, is_end)) in stops.iter().enumerate() {
            // Inside a meander (the last sample before was a stroke, and the band here is
            // wide too) the strokes fill the band: no road along the MCL's middle.
            let band = band_at(slice, plan, p, dir, fan);
            if strokes.in_meander && !is_end && step != 0 && step + 1 != n && too_wide(slice, band)
            {
                continue;
            }
            strokes.in_meander = false;
            let (mut at, mut width) = road_at(slice, p, is_end, band);
            // An end into a splice's inner arc lies on its line, a quarter road off the curve.
            let shifted = match step {
                0 if k == 0 => spliced[0],
                _ if step + 1 == n && k + 1 == stops.len() => spliced[1],
                _ => None,
            };
            if let Some(c) = shifted {
                let (share, _, farther) = shared_strip(slice);
                at = off_curve(slice, c, at, farther);
                width = share;
            }
            let v = Vertex {
                at,
                material: along(&ma, &mb, at_cum, len),
                width,
                // Reached by travel only at the start of a piece; else the arc before leads
                // here.
                deposit: step != 0 || k != 0 || !travel_to_start,
            };
            emit_move(slice, sink, v)?;
        }
        if step + 1 < n {
            let j = order(step + 1);
            meander(
                slice,
                plan,
                (pts[i], pts[j]),
                (cum[i], cum[j], len),
                (&ma, &mb),
                fan,
                &mut strokes,
                sink,
            )?;
        }
    }
    Ok(())
}

/// How an arc of a curve lies among the others.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Arc {
    /// Alone on its stretch of curve.
    Plain,
    /// A splice's outer arc: it passes the ends of the inner arc, and shares the stretch
    /// between them (arc lengths from its start, along it) with that arc.
    Outer(f32, f32),
    /// A splice's inner arc: between two neighbouring ends, under an outer arc.
    Inner,
}

/// The ends of curve `c` strictly between `from` and `to` going forward (increasing arc
/// length) or back: how many, and whether they are paired among themselves (arcs never
/// cross, so an arc may pass over only an arc nested inside it).
fn spanned(ends: &Ends, c: usize, from: u16, to: u16, forward: bool) -> (usize, bool) {
    let (lo, hi) = ends.ranges[c];
    let (lo, n) = (lo as usize, (hi - lo) as usize);
    // Steps from `from` to end `id` in the direction of travel.
    let steps = |id: u16| {
        let (pf, k) = (
            ends.slot[from as usize] as usize,
            ends.slot[id as usize] as usize,
        );
        if forward {
            (k + n - pf) % n
        } else {
            (pf + n - k) % n
        }
    };
    let count = steps(to).saturating_sub(1);
    let pf = ends.slot[from as usize] as usize;
    let closed = (1..=count).all(|k| {
        let p = if forward { pf + k } else { pf + n - k };
        let mate = ends.arc[ends.order[lo + p % n] as usize];
        mate != NONE && (1..=count).contains(&steps(mate))
    });
    (count, closed)
}

/// The arc of curve `c` from end `from` to end `to`: which way it runs (forward: increasing
/// arc length; [`arc_of_direction`]), and its [`Arc`] role.
fn arc_of(ends: &Ends, curve: &KeepOut<'_>, c: usize, from: u16, to: u16) -> (bool, Arc) {
    let s0 = ends.param[from as usize];
    let (forward, (count, closed)) = arc_of_direction(ends, curve, c, from, to);
    let (lo, hi) = ends.ranges[c];
    let (lo, n) = (lo as usize, (hi - lo) as usize);
    if n < 4 || !closed {
        return (forward, Arc::Plain);
    }
    let pf = ends.slot[from as usize] as usize;
    // The end `k` steps from `from` along the arc's direction.
    let at = |k: isize| {
        let step = if forward { k } else { -k };
        ends.order[lo + (pf as isize + step).rem_euclid(n as isize) as usize]
    };
    let along = |id: u16| {
        let s = ends.param[id as usize];
        if forward {
            curve.wrap(s - s0)
        } else {
            curve.wrap(s0 - s)
        }
    };
    match count {
        // Over a nested arc: the outer arc of a splice.
        2 => (forward, Arc::Outer(along(at(1)), along(at(2)))),
        // Under one: the arc from the end before to the end after passes over exactly these
        // two.
        0 => {
            let (before, after) = (at(-1), at(2));
            let outer = ends.arc[before as usize] == after && {
                arc_of_direction(ends, curve, c, before, after) == (forward, (2, true))
            };
            (forward, if outer { Arc::Inner } else { Arc::Plain })
        }
        _ => (forward, Arc::Plain),
    }
}

/// Which way the arc of curve `c` from `from` to `to` runs, and what it passes over
/// ([`spanned`]): the way that passes over no end but those of an arc nested inside it; of
/// two such ways (or none), the one over fewer ends, then the shorter.
fn arc_of_direction(
    ends: &Ends,
    curve: &KeepOut<'_>,
    c: usize,
    from: u16,
    to: u16,
) -> (bool, (usize, bool)) {
    let (s0, s1) = (ends.param[from as usize], ends.param[to as usize]);
    let ways = [true, false].map(|fwd| spanned(ends, c, from, to, fwd));
    let shorter = curve.wrap(s1 - s0) <= curve.wrap(s0 - s1);
    let forward = match (ways[0], ways[1]) {
        ((_, true), (_, false)) => true,
        ((_, false), (_, true)) => false,
        ((a, _), (b, _)) if a != b => a < b,
        _ => shorter,
    };
    (forward, ways[usize::from(!forward)])
}

/// Whether end `id` starts or ends a splice's inner arc ([`Arc::Inner`]).
fn inner_end(ends: &Ends, curves: &[KeepOut<'_>], id: u16) -> bool {
    let mate = ends.arc[id as usize];
    if mate == NONE {
        return false;
    }
    let c = ends.curve[id as usize] as usize;
    arc_of(ends, &curves[c], c, id, mate).1 == Arc::Inner
}

/// How two arcs share one stretch of a keep-out curve's strip (a splice, [`emit_arc`]): the
/// width of each, and how far off the keep-out curve (away from the feature) the nearer and
/// the farther one run. Half a road each, a quarter road either side of the curve, when the
/// slice's [`min_width`](crate::Settings::min_width) allows; wider and nearer the curve (so
/// overlapping) when it does not; their outer edges [`EDGE_MARGIN`] inside the strip.
fn shared_strip(slice: &Slice) -> (f32, f32, f32) {
    let w = slice.settings().road_width;
    let share = (0.5 * w - 2.0 * EDGE_MARGIN)
        .max(slice.settings().min_width)
        .min(w - 2.0 * EDGE_MARGIN);
    let nearer = 0.5 * share + EDGE_MARGIN - 0.5 * w;
    let farther = 0.5 * w - 0.5 * share - EDGE_MARGIN;
    (share, nearer, farther)
}

/// `p`, on the keep-out curve of curve `c` (a hole index, or `holes` for the wall), moved
/// `delta` farther from its feature (nearer for a negative `delta`).
fn off_curve(slice: &Slice, c: usize, p: Point, delta: f32) -> Point {
    match slice.holes().get(c) {
        Some(h) => {
            let near = h.nearest(p);
            p + near.gradient(p) * delta
        }
        None => {
            let near = slice.wall().nearest(p);
            p - near.gradient(p) * delta
        }
    }
}

/// Deposits the arc of curve `c` from end `from` to end `to` (the way that passes no other
/// end but those the arc spans).
///
/// A splice lays two arcs over one stretch of curve (the outer arc passing the inner arc's
/// ends). There they share the road's strip half and half instead of both covering it: the
/// outer arc runs a quarter road nearer the feature and the inner one a quarter road farther,
/// both half a road wide ([`shared_strip`]), and the MCLs into the inner arc end on its line
/// ([`inner_end`]).
fn emit_arc(
    slice: &Slice,
    ends: &Ends,
    curve: &KeepOut<'_>,
    c: usize,
    from: u16,
    to: u16,
    sink: &mut impl PathSink,
) -> Result<(), Error> {
    let w = slice.settings().road_width;
    let material = if c < slice.holes().len() {
        slice.holes()[c].material()
    } else {
        slice.wall().material()
    };
    let (s0, s1) = (ends.param[from as usize], ends.param[to as usize]);
    let (forward, role) = arc_of(ends, curve, c, from, to);
    let vertex = |at: Point, width: f32| Vertex {
        at,
        material,
        width,
        deposit: true,
    };
    let (share, nearer_by, farther_by) = shared_strip(slice);
    let shared = |p: Point, nearer: bool| {
        let delta = if nearer { nearer_by } else { farther_by };
        vertex(off_curve(slice, c, p, delta), share)
    };
    let w = w - 2.0 * EDGE_MARGIN;
    // The curve's vertices strictly between the two MCL ends (the MCLs carry the ends), with
    // their arc lengths from `s0`.
    // `arc` gives both ends and at most every vertex in between: a full buffer is a
    // contour of more vertices than the core holds.
    let mut inner: Vec<(Point, f32), { crate::config::MAX_VERTICES + 2 }> = Vec::new();
    let mut full = false;
    curve.arc(s0, s1, forward, |p, s| {
        let along = if forward {
            curve.wrap(s - s0)
        } else {
            curve.wrap(s0 - s)
        };
        full |= inner.push((p, along)).is_err();
    });
    if full {
        return Err(Limit::Vertices.error());
    }
    let between = inner.iter().skip(1).take(inner.len().saturating_sub(2));
    match role {
        Arc::Plain => {
            for &(p, _) in between {
                emit_move(slice, sink, vertex(p, w))?;
            }
        }
        Arc::Inner => {
            for &(p, _) in between {
                emit_move(slice, sink, shared(p, false))?;
            }
        }
        Arc::Outer(x, y) => {
            let point = |along: f32| curve.at(if forward { s0 + along } else { s0 - along });
            let mut state = 0;
            for &(p, along) in between {
                if state == 0 && along > x {
                    emit_move(slice, sink, vertex(point(x), w))?;
                    emit_move(slice, sink, shared(point(x), true))?;
                    state = 1;
                }
                if state == 1 && along >= y {
                    emit_move(slice, sink, shared(point(y), true))?;
                    emit_move(slice, sink, vertex(point(y), w))?;
                    state = 2;
                }
                emit_move(
                    slice,
                    sink,
                    if state == 1 {
                        shared(p, true)
                    } else {
                        vertex(p, w)
                    },
                )?;
            }
            if state == 0 {
                emit_move(slice, sink, vertex(point(x), w))?;
                emit_move(slice, sink, shared(point(x), true))?;
                state = 1;
            }
            if state == 1 {
                emit_move(slice, sink, shared(point(y), true))?;
                emit_move(slice, sink, vertex(point(y), w))?;
            }
        }
    }
    Ok(())
}
