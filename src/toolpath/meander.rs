//! The zigzag's roads along its MCLs ([`super::zigzag`]): the band each MCL's road owns
//! between its neighbouring MCLs and the road's width and place in it (the sibling [`band`]),
//! and the meander that fills a band wider than the widest road: strokes across the band, or,
//! along a long stretch of it, lanes along the MCL (the sibling [`lanes`]).

use crate::geometry::primitives::MinMax;
use crate::geometry::{polyline, Point};
use crate::toolpath::composition::along;
use crate::toolpath::zigzag::{EDGE_MARGIN, END_STEPS};
use crate::toolpath::{emit_move, PathSink, Vertex};
use crate::{Error, Plan, Slice};

pub(in crate::toolpath) mod band;
mod lanes;
pub(in crate::toolpath) mod near;
mod probe;

use band::{band_at, road_at, Band, Fan};
use probe::features_within;

/// A road meanders only where its band is wider than the widest road by this many road
/// widths: a narrower excess costs less left as slivers either side than paid for with the
/// turns of a meander (which lap back over the wide road around them). On the random bench's
/// 200 slices (the zigzag, as printed): 0.5 road, median coverage 0.9665 and overfill 0.0365,
/// 54 slices meet the bar; 0.25, 0.9692 and 0.0392, 63. Once meanders were laid only in runs
/// of [`MIN_STROKES`] (no jogs of one or two strokes), on its first 40: 0.0, mean coverage
/// 0.9714 and overfill 0.0355, 25 meet; 0.125, 0.9714 and 0.0345, 26; 0.25, 0.9699 and
/// 0.0330, 24.
const MEANDER_MARGIN: f32 = 0.125;

/// Whether a band is wider than the widest road
/// ([`max_width`](crate::Settings::max_width)) by [`MEANDER_MARGIN`]: there the road meanders
/// ([`meander`]).
pub(super) fn too_wide(slice: &Slice, band: Option<Band>) -> bool {
    let settings = slice.settings();
    band.is_some_and(|(_, l, r)| {
        0.5 * (l + r) > settings.max_width + MEANDER_MARGIN * settings.road_width
    })
}

/// Where the band an MCL's road owns ([`band_at`]) is wider than the widest road
/// ([`max_width`](crate::Settings::max_width)), as it is where MCLs fan apart toward the wall,
/// in large cells and around long channels, the road fills it with a meander: strokes across
/// the band, from its right edge to its left edge and back, a road apart, advancing along the
/// MCL. The strokes stand on one grid over the whole MCL (a road apart, evenly), not per move:
/// an MCL's vertices are mostly nearer each other than a road, and a move shorter than a road
/// holds one stroke or none. Where the strokes fan apart faster than their ends can widen
/// (far across a large cell, round a small hole), the stretch between two strokes is split
/// evenly by strokes between them ([`fan_parts`]), narrower at the MCL, so their far ends
/// stand at most the widest road apart. Emits the strokes along the MCL's move from `a` to `b` (arc
/// lengths `sa`, `sb` of `len` from the `from` end, materials `ma`, `mb` at its ends),
/// `state` the meander so far along the MCL.
#[allow(clippy::too_many_arguments)]
pub(super) fn meander(
    slice: &Slice,
    plan: &Plan,
    mcl: (&[Point], &[f32]),
    (a, b): (Point, Point),
    (sa, sb, len): (f32, f32, f32),
    (ma, mb): (&crate::Material, &crate::Material),
    fan: &Fan<'_>,
    closing: Option<Point>,
    state: &mut Strokes,
    sink: &mut impl PathSink,
) -> Result<(), Error> {
    let w = slice.settings().road_width;
    if len < 1e-6 || (sb - sa).abs() < 1e-9 {
        return Ok(());
    }
    // Strokes stand a road apart (a little less, evenly) over the whole MCL, the first and the
    // last a road from its ends ([`Grid::new`]), whatever the spacing of its vertices: a move
    // shorter than a road holds one stroke or none, a long one several.
    let step = if sb > sa { 1.0 } else { -1.0 };
    let grid = Grid::new(slice, plan, fan, mcl, len, step);
    let (offset, spacing, count) = (grid.at.offset, grid.at.spacing, grid.at.count as f32);
    let dir = b - a;
    // The strokes on this move, in walking order: from `sa` (included) toward `sb`.
    let first = if sb > sa {
        libm::ceilf((sa - offset) / spacing).fmax(0.0)
    } else {
        libm::floorf((sa - offset) / spacing).fmin(count - 1.0)
    };
    let mut k = first;
    loop {
        let s = offset + k * spacing;
        let inside = if sb > sa { s < sb } else { s > sb };
        if !inside || k < 0.0 || k >= count {
            break;
        }
        // Inside a stretch laid in lanes (its ends included): nothing more to lay.
        if state.lanes_span.is_some_and(|(lo, hi)| s >= lo && s <= hi) {
            k += step;
            continue;
        }
        let t = ((s - sa) / (sb - sa)).clamp(0.0, 1.0);
        let material = along(ma, mb, s, len);
        let q = a.lerp(b, t);
        // A stroke only in a run of `MIN_STROKES`: fewer lap back over the road either side
        // more than they fill.
        let raw = grid.band(&mut state.bands, k as i32);
        let band = raw.filter(|_| grid.in_run(&mut state.bands, k as i32));
        if too_wide(slice, band) && state.last.is_none() {
            // A run of strokes starts (a sample whose band is not too wide lies in a run
            // between its neighbours' strokes but lays none). If it runs on to the walk's end, where a bare strip
            // lies beside the MCL's end on the side of `closing`, it starts on the side that
            // makes its last stroke end there; the first run after a strip laid at the
            // walk's start starts beside that strip instead.
            if state.opened {
                state.opened = false;
            } else if let Some(right) =
                closing.and_then(|at| grid.closing_side(&mut state.bands, k as i32, at))
            {
                state.right_first = right;
            }
            // A run that stays too wide for a long way is laid in lanes along the MCL instead
            // of strokes across it (`lanes`), at once: the walk then skips its samples.
            let laid = lanes::lanes(
                slice,
                &grid,
                &mut state.bands,
                k as i32,
                step as i32,
                (ma, mb, len),
                state.right_first,
                closing,
                sink,
            )?;
            if let Some(laid) = laid {
                let s_last = offset + laid.last as f32 * spacing;
                state.lanes_span = Some((s.fmin(s_last), s.fmax(s_last)));
                state.laned = state.laned.saturating_add(1);
                state.in_meander = true;
                state.right_first = laid.on_right;
                state.last = Some(laid.end);
                k += step;
                continue;
            }
        }
        let mut ends = stroke_ends(slice, q, spacing, band, fan);
        // Where the strokes fan apart faster than their ends widen (a large cell, an MCL
        // curving round a small hole), strokes between the last and this one, at even steps
        // along the chord between their points on the MCL, close the wedges between their far
        // ends; all of them then stand a part of the spacing apart at the MCL.
        let parts = fan_parts(slice, dir, ends, state);
        let part = spacing / parts as f32;
        if let (Some(last), true) = (state.last, parts > 1) {
            for i in 1..parts {
                let f = i as f32 / parts as f32;
                let (qi, di) = (last.at.lerp(q, f), last.dir.lerp(dir, f));
                let ei = stroke_ends(slice, qi, part, band_at(slice, plan, qi, di, fan), fan);
                let mi = along(&last.material, &material, f, 1.0);
                stroke(slice, (qi, di), ei, part, mi, fan, state, sink)?;
            }
            ends = stroke_ends(slice, q, part, band, fan);
        }
        state.in_meander = stroke(slice, (q, dir), ends, part, material, fan, state, sink)?;
        // Along a move, where no meander runs, the road takes its band's width and place at
        // each sample (a road apart) at least `SAMPLE_GAP` roads from the move's ends, not only
        // at the MCL's vertices: each move is laid at one width. Near the MCL's own ends its
        // extra stops stand instead (`END_REACH`).
        let clear = |x: f32, roads: f32| (s - x).abs() >= roads * w;
        if !state.in_meander
            && clear(sa, SAMPLE_GAP)
            && clear(sb, SAMPLE_GAP)
            && clear(0.0, END_REACH)
            && clear(len, END_REACH)
        {
            let (at, width) = road_at(slice, fan, q, false, raw);
            emit_move(
                slice,
                sink,
                Vertex {
                    at,
                    material,
                    width,
                    deposit: true,
                },
            )?;
        }
        k += step;
    }
    Ok(())
}

/// Fewest strokes in a row a meander lays: where the band outgrows the widest road for a
/// shorter stretch (the outer side of a bend in the MCL, a bulge of the cell), its excess is
/// left as slivers either side of the road. A meander of one or two strokes jogs out of the
/// road and back within a road or two: its turns lap over the road before and after it, and
/// at a bend its strokes cross each other on the bend's inner side. On the random bench's
/// first 40 slices (the zigzag, as printed; with [`MEANDER_MARGIN`] 0.25): every stroke,
/// mean coverage 0.9717 and overfill 0.0389, 23 meet the bar; runs of 2, 0.9716 and 0.0373,
/// 25; runs of 3, 0.9708 and 0.0345, 24.
const MIN_STROKES: i32 = 3;

/// How far, in road widths, a meander sample must lie from the ends of the MCL's move it falls
/// on (the MCL's vertices, where the road already takes its band's width) for the road to take
/// a vertex of its own there, where no meander runs (and beyond [`END_REACH`] of the MCL's own
/// ends). A move laid
/// between two vertices is one width; where the band widens and narrows again between them
/// (beside the tip of a pair that turns short of a hole, past a crowded end) the move was
/// laid at its ends' narrower width and left a wedge of the band bare. At a whole road
/// (before), only moves longer than two roads took a sample's vertex. On the random bench
/// (seeds 1 / 5000 / 9000 / 20000, zigzag mean coverage and overfill) and its 48 lattices:
/// 1.0: 0.9840 / 0.0220, 0.9843 / 0.0209, 0.9841 / 0.0215, 0.9837 / 0.0217, meeting the bar
/// 200 / 198 / 199 / 198 and 38 lattices; 0.5: each coverage 0.0003-0.0004 higher and each
/// overfill 0.0004-0.0005 lower, 200 / 199 / 199 / 198 and 38; 0.25: 0.9848 / 0.0212, 0.9851
/// / 0.0201, 0.9850 / 0.0207, 0.9846 / 0.0210, 200 / 199 / 199 / 199 and 40. Nearer a vertex
/// than a quarter road a sample's band is nearly the vertex's. (The figures are from a first
/// form that kept samples a quarter road from the MCL's ends too; with [`END_REACH`] they
/// are the same to the fourth decimal.)
const SAMPLE_GAP: f32 = 0.25;
/// How far from an MCL's own ends, in road widths, a sample must lie to take a vertex: beyond
/// the road's extra stops there ([`END_STEPS`], laid before and after the meander's samples),
/// or the road would step back along itself.
const END_REACH: f32 = END_STEPS[END_STEPS.len() - 1];

/// The samples a meander's strokes stand on along one MCL: `count` of them `spacing` apart,
/// the `k`-th at arc length `offset + k spacing` from the MCL's `from` end.
struct Samples<'a> {
    /// The MCL's points from its `from` end, and the arc length at each.
    mcl: (&'a [Point], &'a [f32]),
    offset: f32,
    spacing: f32,
    count: i32,
    /// 1 walking from the `from` end, -1 toward it: the direction each band is measured
    /// along, so its sides are the walk's.
    walk: f32,
}

impl<'a> Samples<'a> {
    /// The samples along an MCL of length `len` (roads `w` wide), walked from its `from` end
    /// (`walk` 1) or toward it (-1): the first and last stand a road (and the edge margins)
    /// from its ends, the others evenly between, at most a road apart. A stroke a road from a
    /// keep-out curve lies beside the curve's strip, its edge on the strip's.
    fn new(w: f32, mcl: (&'a [Point], &'a [f32]), len: f32, walk: f32) -> Samples<'a> {
        // A stroke keeps its edge a road and two edge margins off the feature ([`stroke_ends`]):
        // its centre a road off the keep-out curve (half a road off the feature) and two more
        // margins clears that for any stroke no wider than a road, a hair to spare.
        let offset = (w + 4.0 * EDGE_MARGIN).fmin(0.5 * len);
        let inner = len - 2.0 * offset;
        // One sample where the MCL is no longer than two offsets (at its middle).
        let count = libm::ceilf(inner / w) + 1.0;
        let spacing = if count > 1.0 {
            inner / (count - 1.0)
        } else {
            w
        };
        Samples {
            mcl,
            offset,
            spacing,
            count: count as i32,
            walk,
        }
    }

    /// The MCL's point at sample `k` and its direction there (its segment's, along the walk).
    fn sample(&self, k: i32) -> (Point, Point) {
        let (pts, cum) = self.mcl;
        let (q, dir) = polyline::point_along(pts, cum, self.offset + k as f32 * self.spacing);
        (q, dir * self.walk)
    }
}

/// The grid a meander's strokes stand on along one MCL: its [`Samples`], and what the band
/// at each is measured against.
struct Grid<'a> {
    at: Samples<'a>,
    slice: &'a Slice,
    plan: &'a Plan,
    fan: &'a Fan<'a>,
}

impl<'a> Grid<'a> {
    /// The grid along an MCL ([`Samples::new`], at the slice's road width).
    fn new(
        slice: &'a Slice,
        plan: &'a Plan,
        fan: &'a Fan<'a>,
        mcl: (&'a [Point], &'a [f32]),
        len: f32,
        walk: f32,
    ) -> Grid<'a> {
        let at = Samples::new(slice.settings().road_width, mcl, len, walk);
        Grid {
            at,
            slice,
            plan,
            fan,
        }
    }

    /// The band at sample `k` ([`band_at`], along the walk; none beyond the MCL), measured
    /// once: asked while a neighbour's run is counted, it is kept for the walk's arrival.
    fn band(&self, seen: &mut Seen, k: i32) -> Option<Band> {
        if k < 0 || k >= self.at.count {
            return None;
        }
        if let Some(band) = seen.get(k) {
            return band;
        }
        let (q, dir) = self.at.sample(k);
        let band = band_at(self.slice, self.plan, q, dir, self.fan);
        seen.put(k, band);
        band
    }

    /// Whether the band at sample `k` is too wide ([`too_wide`]).
    fn wide(&self, seen: &mut Seen, k: i32) -> bool {
        too_wide(self.slice, self.band(seen, k))
    }

    /// For a run of strokes starting at sample `k`: the side its first stroke starts on (right:
    /// `true`) for its last to end on the side of point `at`, if the run reaches the walk's
    /// last sample (every sample from `k` on too wide).
    fn closing_side(&self, seen: &mut Seen, k: i32, at: Point) -> Option<bool> {
        let last = if self.at.walk > 0.0 {
            self.at.count - 1
        } else {
            0
        };
        let step = if self.at.walk > 0.0 { 1 } else { -1 };
        let mut strokes = 1;
        let mut j = k;
        while j != last {
            j += step;
            if !self.wide(seen, j) {
                return None;
            }
            strokes += 1;
        }
        let (q, _) = self.at.sample(last);
        let (left_n, _, _) = self.band(seen, last)?;
        let end_right = (at - q).dot(left_n) < 0.0;
        // Each stroke crosses to the other side: an even number ends where it started.
        Some(if strokes % 2 == 0 {
            end_right
        } else {
            !end_right
        })
    }

    /// Whether sample `k` (too wide) lies in a run of at least [`MIN_STROKES`] samples too
    /// wide.
    fn in_run(&self, seen: &mut Seen, k: i32) -> bool {
        let mut run = 1;
        for step in [-1, 1] {
            let mut j = k + step;
            while run < MIN_STROKES && self.wide(seen, j) {
                run += 1;
                j += step;
            }
        }
        run >= MIN_STROKES
    }
}

/// The bands at the last few samples of a meander's [`Grid`] asked: a sample is asked while
/// its neighbours' runs are counted, and again when the walk reaches it.
#[derive(Clone, Copy, Debug)]
pub(super) struct Seen([(i32, Option<Band>); SEEN]);

/// Samples [`Seen`] holds: the run around one sample spans `2 MIN_STROKES - 1`.
const SEEN: usize = 2 * MIN_STROKES as usize;

impl Seen {
    fn get(&self, k: i32) -> Option<Option<Band>> {
        let (at, band) = self.0[k.rem_euclid(SEEN as i32) as usize];
        (at == k).then_some(band)
    }

    fn put(&mut self, k: i32, band: Option<Band>) {
        self.0[k.rem_euclid(SEEN as i32) as usize] = (k, band);
    }
}

/// Where a meander along one MCL stands.
#[derive(Clone, Copy, Debug)]
pub(super) struct Strokes {
    /// The side the next stroke starts on.
    pub right_first: bool,
    /// Whether the last sample along the MCL was a stroke.
    pub in_meander: bool,
    /// Whether the side of the first run's first stroke is set (beside a strip laid at the
    /// walk's start).
    pub opened: bool,
    /// The last stroke, while the strokes run on.
    last: Option<Last>,
    /// The bands at the grid's samples around the last one asked.
    bands: Seen,
    /// The arc lengths (from the MCL's `from` end) of the first and last samples of the last
    /// stretch laid in lanes: the walk skips the samples from one to the other, and the MCL's
    /// vertices between lay nothing (a vertex inside an earlier stretch was passed before the
    /// next began).
    lanes_span: Option<(f32, f32)>,
    /// Stretches laid in lanes so far.
    pub laned: u16,
}

/// The last stroke of a meander (or the last section of a stretch in lanes, [`lanes`]): where
/// the next one's ends widen to ([`stroke`]) and where strokes between the two start from
/// ([`fan_parts`]).
#[derive(Clone, Copy, Debug)]
struct Last {
    /// Its ends (right, left).
    tips: [Point; 2],
    /// Its point on the MCL.
    at: Point,
    /// The MCL's direction there.
    dir: Point,
    /// Its composition.
    material: crate::Material,
}

/// The band at the sample a meander along MCL `mcl` (points and arc lengths from its `from`
/// end) walked from that end (`forward`) or from its far end starts with, if a stroke stands
/// there (the band too wide, in a run of [`MIN_STROKES`]).
pub(super) fn opening_stroke(
    slice: &Slice,
    plan: &Plan,
    mcl: (&[Point], &[f32]),
    forward: bool,
    fan: &Fan<'_>,
    state: &mut Strokes,
) -> Option<Band> {
    let len = *mcl.1.last()?;
    if len < 1e-6 {
        return None;
    }
    let grid = Grid::new(slice, plan, fan, mcl, len, if forward { 1.0 } else { -1.0 });
    let k = if forward { 0 } else { grid.at.count - 1 };
    let band = grid.band(&mut state.bands, k);
    band.filter(|_| too_wide(slice, band) && grid.in_run(&mut state.bands, k))
}

impl Strokes {
    /// Where the road stands after the last stroke, if the last sample along the MCL was one:
    /// the stroke's end the next one starts from.
    pub(super) fn tip(&self) -> Option<Point> {
        let last = self.last.filter(|_| self.in_meander)?;
        Some(last.tips[if self.right_first { 0 } else { 1 }])
    }

    /// Before the first stroke of an MCL.
    pub(super) fn new() -> Strokes {
        Strokes {
            right_first: true,
            in_meander: false,
            opened: false,
            last: None,
            bands: Seen([(-1, None); SEEN]),
            lanes_span: None,
            laned: 0,
        }
    }

    /// Whether the MCL's point at arc length `s` (from its `from` end) lies inside the last
    /// stretch laid in lanes: the road lays nothing there.
    pub(super) fn in_lanes(&self, s: f32) -> bool {
        self.lanes_span.is_some_and(|(lo, hi)| s > lo && s < hi)
    }
}

/// One stroke of a [`meander`] at `q` (the MCL's direction `dir`), `spacing` from the last,
/// between `ends` ([`stroke_ends`]), if the band there is wider than the widest road: from the side
/// `state.right_first` names to the other, which the next stroke then starts from. Returns
/// whether the band is that wide (whether `q` belongs to a meander).
///
/// The strokes stand a road apart along the MCL; where they fan apart across a wide band (the
/// MCL curves away from that side), each end is as wide as the gap to the last stroke's end
/// on its side, up to [`max_width`](crate::Settings::max_width) and a road off the strip, and
/// the stroke tapers from it to `spacing` at the MCL, so the fan leaves no wedges bare; where
/// that is not wide enough, [`meander`] lays strokes between ([`fan_parts`]).
#[allow(clippy::too_many_arguments)]
fn stroke(
    slice: &Slice,
    (q, dir): (Point, Point),
    ends: Option<[(Point, f32); 2]>,
    spacing: f32,
    material: crate::Material,
    fan: &Fan<'_>,
    state: &mut Strokes,
    sink: &mut impl PathSink,
) -> Result<bool, Error> {
    let settings = slice.settings();
    let Some(ends) = ends else {
        state.last = None;
        return Ok(false);
    };
    let ws = spacing.fmax(settings.min_width);
    let tips = ends.map(|(tip, _)| tip);
    // Each end as wide as the gap to the last stroke's end on its side, where the strokes fan
    // apart (across the MCL's direction), within reach of the strip; the wider end stops
    // short by its extra half width, so its round end keeps to the band.
    let along_mcl = dir * (1.0 / dir.norm());
    // The point `back` from tip `k` toward the MCL.
    let pulled = |k: usize, back: f32| {
        let out = tips[k].dist(q);
        if out > 1e-6 {
            tips[k] + (q - tips[k]) * (back.fmin(out) / out)
        } else {
            tips[k]
        }
    };
    let tip = |k: usize| {
        let gap = state
            .last
            .map_or(ws, |last| (last.tips[k] - tips[k]).dot(along_mcl).abs());
        let wanted = gap.fmin(settings.max_width).fmax(ws);
        // Stopped short for the width wanted, and as wide there as its edge stays `kept` off
        // the feature (a road, or half a road in a bare strip): at most the width wanted, so
        // it stands at least as far back as its width needs.
        let at = pulled(k, 0.5 * (wanted - ws));
        let kept = ends[k].1;
        let cap = 2.0 * (fan.clearance(slice, at) - kept - 2.0 * EDGE_MARGIN);
        (at, wanted.fmin(cap).fmax(ws))
    };
    let (t0, t1) = (tip(0), tip(1));
    let widths = [t0.1, t1.1];
    let tips = [t0.0, t1.0];
    let order = if state.right_first { [0, 1] } else { [1, 0] };
    let at = |k: usize| Vertex {
        at: tips[k],
        material,
        width: widths[k],
        deposit: true,
    };
    emit_move(slice, sink, at(order[0]))?;
    if tips[0].dist(q) > ws && tips[1].dist(q) > ws {
        // The MCL's point between the two tapers.
        emit_move(
            slice,
            sink,
            Vertex {
                at: q,
                material,
                width: ws,
                deposit: true,
            },
        )?;
    }
    emit_move(slice, sink, at(order[1]))?;
    state.right_first = !state.right_first;
    state.last = Some(Last {
        tips,
        at: q,
        dir,
        material,
    });
    Ok(true)
}

/// The ends (right, left) of a stroke across the band `band` at `q`, `spacing` from the last,
/// each with how far its edge keeps off the feature there (a road, or half a road in a bare
/// strip); `None` where the band is no wider than the widest road ([`too_wide`]).
fn stroke_ends(
    slice: &Slice,
    q: Point,
    spacing: f32,
    band: Option<Band>,
    fan: &Fan<'_>,
) -> Option<[(Point, f32); 2]> {
    let settings = slice.settings();
    let (left_n, left, right) = band.filter(|_| too_wide(slice, band))?;
    let ws = spacing.fmax(settings.min_width);
    let half = 0.5 * settings.road_width;
    let StripRoom {
        room,
        bare_room,
        bare_margin,
    } = StripRoom::new(settings, ws);
    let side = |reach: f32, sign: f32| {
        // As far out as the band reaches, short of the strip along the stroke's line (a stroke
        // beside a wall or a hole runs on beside it): the line up to where it first comes
        // within `room` of a feature's edge keeps `room` from every feature, and crosses
        // none (it would meet the edge first). None where `q` itself is within `room`.
        let n = left_n * sign;
        let free = features_within(slice, q, n, room);
        if reach > free - STRIP_TOLERANCE * settings.road_width {
            if let Some(bare) = fan.bare {
                // Into the strip where no arc runs: up to `bare_room` off the feature, if the
                // strip beside the new end is bare. Where the band itself stops at the strip
                // (the feature it meets along the normal, not a neighbour's medial line), its
                // ground reaches half a road further once the strip is bare.
                let into = features_within(slice, q, n, bare_room);
                let hit = features_within(slice, q, n, 0.0);
                let cut = hit - (settings.road_width + 2.0 * EDGE_MARGIN) - 0.5 * ws;
                let reach = if reach >= cut - STRIP_TOLERANCE * settings.road_width {
                    reach + half
                } else {
                    reach
                };
                let out = reach.fmin(into);
                if into > free && bare(q + n * out, bare_margin) {
                    return (q + n * out, half);
                }
            }
        }
        (q + n * reach.fmin(free), settings.road_width)
    };
    Some([
        side((0.5 * right - 0.5 * ws).fmax(0.0), -1.0),
        side((0.5 * left - 0.5 * ws).fmax(0.0), 1.0),
    ])
}

/// How far the centre of a road `ws` wide (a stroke's end, a lane's) keeps off the features:
/// off every keep-out curve's strip (each feature's own material's place, where an arc may
/// run), its edge a road off the feature (`room`); where no arc lays the strip, its edge half a
/// road off the feature (the printable region's bar), clear of the arcs' round ends either
/// side (`bare_room`), the strip counting as bare where it is `bare_margin` from the centre.
pub(super) struct StripRoom {
    pub room: f32,
    pub bare_room: f32,
    pub bare_margin: f32,
}

impl StripRoom {
    pub(super) fn new(settings: &crate::Settings, ws: f32) -> StripRoom {
        let half = 0.5 * settings.road_width;
        StripRoom {
            room: settings.road_width + 0.5 * ws + 2.0 * EDGE_MARGIN,
            bare_room: half + 0.5 * ws + 2.0 * EDGE_MARGIN,
            bare_margin: half + 0.5 * ws,
        }
    }
}

/// How near (road widths) a stroke's reach may come to where the keep-out strip begins and
/// still count as stopped by it: the band there is cut at the strip, which rounding puts a
/// hair either side of where the stroke's line comes within a road of the feature.
const STRIP_TOLERANCE: f32 = 1e-3;

/// Most strokes a fanning stretch between two strokes is split into ([`fan_parts`]).
const FAN_PARTS: usize = 3;

/// Into how many even steps the stretch of MCL from the last stroke to the next, whose ends
/// are `ends` ([`stroke_ends`]; `dir` the MCL's direction there), goes: as many as it takes
/// for the strokes' far ends to stand at most [`max_width`](crate::Settings::max_width)
/// apart (each end is as wide as the gap to the last, up to that), at most [`FAN_PARTS`].
/// Where the strokes run parallel it is 1.
fn fan_parts(slice: &Slice, dir: Point, ends: Option<[(Point, f32); 2]>, state: &Strokes) -> usize {
    let (Some(last), Some(ends)) = (state.last, ends) else {
        return 1;
    };
    let len = dir.norm();
    if len < 1e-6 {
        return 1;
    }
    let along_mcl = dir * (1.0 / len);
    let gap = (0..2)
        .map(|k| libm::fabsf((last.tips[k] - ends[k].0).dot(along_mcl)))
        .fold(0.0, |a, b| a.fmax(b));
    let parts = libm::ceilf(gap / slice.settings().max_width);
    if parts > 1.0 {
        (parts as usize).min(FAN_PARTS)
    } else {
        1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grid_samples_its_mcl_by_arc_length() {
        // An L: 2 mm along x, then 1 mm along y.
        let pts = [
            Point::new(0.0, 0.0),
            Point::new(2.0, 0.0),
            Point::new(2.0, 1.0),
        ];
        let cum = [0.0, 2.0, 3.0];
        let grid = Samples {
            mcl: (&pts, &cum),
            offset: 0.25,
            spacing: 0.5,
            count: 6,
            walk: 1.0,
        };
        // Sample k at 0.25 + k 0.5: 0.25, 0.75, ..., 2.75.
        let (q, dir) = grid.sample(0);
        assert!(q.dist(Point::new(0.25, 0.0)) < 1e-6 && dir.y == 0.0 && dir.x > 0.0);
        let (q, dir) = grid.sample(4);
        assert!(q.dist(Point::new(2.0, 0.25)) < 1e-6 && dir.x == 0.0 && dir.y > 0.0);
        let (q, _) = grid.sample(5);
        assert!(q.dist(Point::new(2.0, 0.75)) < 1e-6);
    }

    #[test]
    fn seen_remembers_the_last_samples_asked() {
        let band = Some((Point::new(0.0, 1.0), 2.0, 3.0));
        let mut seen = Seen([(-1, None); SEEN]);
        assert_eq!(seen.get(0), None);
        seen.put(3, band);
        seen.put(4, None);
        assert_eq!(seen.get(3), Some(band));
        assert_eq!(seen.get(4), Some(None));
        // A sample SEEN further on takes the slot of an older one.
        seen.put(3 + SEEN as i32, None);
        assert_eq!(seen.get(3), None);
        assert_eq!(seen.get(3 + SEEN as i32), Some(None));
    }
}
