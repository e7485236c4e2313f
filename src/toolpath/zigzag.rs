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

use heapless::Vec;

use crate::config::MAX_MCLS;
use crate::geometry::{polyline, Point};
use crate::keep_out::{KeepOut, Side};
use crate::toolpath::composition::{along, mcl_end_materials};
use crate::toolpath::{emit_move, PathSink, Vertex};
use crate::{Error, Plan, Slice, Target};

const ENDS: usize = 2 * MAX_MCLS;
const NONE: u16 = u16::MAX;

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
    /// For each curve, its range in `order`.
    ranges: Vec<(u16, u16), 9>,
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
    fn new(slice: &Slice, plan: &Plan, curves: &[KeepOut<'_>], mcls: &[u16]) -> Ends {
        let holes = slice.holes().len();
        let mut e = Ends {
            mcls: Vec::from_slice(mcls).unwrap_or_default(),
            curve: [0; ENDS],
            param: [0.0; ENDS],
            order: Vec::new(),
            ranges: Vec::new(),
            arc: [NONE; ENDS],
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
            let _ = e.order.push(id);
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
            let _ = e.ranges.push((start as u16, end as u16));
            start = end;
        }
        e
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

/// Writes the zigzag layer of `plan` into `sink`.
pub fn zigzag(slice: &Slice, plan: &Plan, sink: &mut impl PathSink) -> Result<ZigzagStats, Error> {
    let half = 0.5 * slice.settings().road_width;
    let holes = slice.holes().len();
    let mut curves: Vec<KeepOut<'_>, 9> = Vec::new();
    for h in slice.holes() {
        let _ = curves.push(KeepOut::new(h, half, Side::Outside));
    }
    let _ = curves.push(KeepOut::new(slice.wall(), half, Side::Inside));
    // Parity: every curve with an odd number of MCL ends leaves one end free, and each pair
    // of free ends is a separate path. Beyond one path, drop the shortest MCL joining two odd
    // curves (both turn even) until at most two curves are odd.
    let mut active: Vec<u16, MAX_MCLS> = (0..plan.mcls.len() as u16).collect();
    loop {
        let mut count = [0u16; 9];
        for &k in active.iter() {
            let (a, b) = curve_pair(plan, k as usize, holes);
            count[a] += 1;
            count[b] += 1;
        }
        let odd = |c: usize| count[c] % 2 == 1;
        if (0..=holes).filter(|&c| odd(c)).count() <= 2 {
            break;
        }
        let mut drop: Option<(usize, f32)> = None;
        for (i, &k) in active.iter().enumerate() {
            let (a, b) = curve_pair(plan, k as usize, holes);
            if odd(a) && odd(b) {
                let len = polyline::length(&plan.points(&plan.mcls[k as usize]));
                if drop.is_none_or(|d| len < d.1) {
                    drop = Some((i, len));
                }
            }
        }
        match drop {
            Some((i, _)) => {
                active.remove(i);
            }
            None => break,
        }
    }
    let mut stats = ZigzagStats {
        dropped: (plan.mcls.len() - active.len()) as u16,
        ..ZigzagStats::default()
    };
    let mut ends = Ends::new(slice, plan, &curves, &active);
    if ends.count == 0 {
        return Ok(stats);
    }
    let mut parent = [0u16; ENDS];

    // Odd curves: leave unpaired the end after the longest gap (just after a branch point,
    // where the paper starts). Even curves: search both pairings of each.
    let mut even: Vec<usize, 9> = Vec::new();
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
            let _ = even.push(c);
            ends.pair_curve(c, 0);
        }
    }
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
    stats.pieces_paired = best.0;

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
            emit_mcl(slice, plan, k, forward, first, sink)?;
            first = false;
            visited[id as usize] = true;
            let other = id ^ 1;
            visited[other as usize] = true;
            let mate = ends.arc[other as usize];
            if mate == NONE || visited[mate as usize] {
                here = Some(end_point(plan, &ends, other));
                break;
            }
            // Along the curve from `other` to `mate`.
            let c = ends.curve[other as usize] as usize;
            emit_arc(slice, &ends, &curves[c], c, other, mate, sink)?;
            id = mate;
        }
    }
    Ok(stats)
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

/// Deposits MCL `k` from its `from` end (`forward`) or from its far end; the first vertex of a
/// piece is reached by travel.
fn emit_mcl(
    slice: &Slice,
    plan: &Plan,
    k: usize,
    forward: bool,
    travel_to_start: bool,
    sink: &mut impl PathSink,
) -> Result<(), Error> {
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
    for step in 0..n {
        let i = if forward { step } else { n - 1 - step };
        let v = Vertex {
            at: pts[i],
            material: along(&ma, &mb, cum[i], len),
            // Reached by travel only at the start of a piece; else the arc before leads here.
            deposit: step != 0 || !travel_to_start,
        };
        emit_move(slice, sink, v)?;
    }
    Ok(())
}

/// Deposits the arc of curve `c` from end `from` to end `to` (the way that passes no other
/// end but those the arc spans).
fn emit_arc(
    slice: &Slice,
    ends: &Ends,
    curve: &KeepOut<'_>,
    c: usize,
    from: u16,
    to: u16,
    sink: &mut impl PathSink,
) -> Result<(), Error> {
    let material = if c < slice.holes().len() {
        slice.holes()[c].material()
    } else {
        slice.wall().material()
    };
    let (s0, s1) = (ends.param[from as usize], ends.param[to as usize]);
    // Forward if `to` is reached first going forward without passing ends outside the span.
    let (lo, hi) = ends.ranges[c];
    let n = (hi - lo) as usize;
    let pos = |id: u16| {
        (lo as usize..hi as usize)
            .position(|k| ends.order[k] == id)
            .unwrap_or(0)
    };
    let steps_forward = (pos(to) + n - pos(from)) % n;
    let forward = if n <= 2 {
        curve.wrap(s1 - s0) <= curve.wrap(s0 - s1)
    } else {
        steps_forward <= n / 2
    };
    // The curve's vertices strictly between the two MCL ends (the MCLs carry the ends).
    let mut inner: Vec<Point, { crate::config::MAX_VERTICES + 2 }> = Vec::new();
    curve.arc(s0, s1, forward, |p, _| {
        let _ = inner.push(p);
    });
    for &p in inner.iter().skip(1).take(inner.len().saturating_sub(2)) {
        emit_move(
            slice,
            sink,
            Vertex {
                at: p,
                material,
                deposit: true,
            },
        )?;
    }
    Ok(())
}
