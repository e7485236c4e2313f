//! Lanes: a meander whose strokes run along the MCL instead of across it (a sibling of the
//! meander's strokes, [`super::meander`]).
//!
//! A meander of strokes across its band turns twice per stroke, at the band's edges, a road
//! apart along the MCL; a round nozzle leaves the outer corner of every turn bare, and where
//! the turns of the meanders either side of one band edge meet, four such corners leave a
//! star of bare ground (about `0.107 w / B` of a band `B` wide at roads `w`: 3 to 6 % of a
//! large cell's ground). Where the band stays too wide for a long stretch (a large cell's
//! fan toward the wall, a long channel), the road lays the stretch in *lanes* instead: an odd
//! number of roads along the MCL, side by side across the band, each as wide as its share of
//! the band at every sample, laid out and back in turn (out along the first, back along the
//! second, ...), so that the road leaves the stretch at its far end on the other side, as a
//! meander of strokes can. It turns only at the stretch's two ends, once per lane. Where the
//! band widens so much along the stretch that one number of lanes would be too narrow at one
//! end or too wide at the other, the stretch is laid as consecutive runs, each with its own
//! number of lanes.
//!
//! A lane is narrowed by the cosine of its angle to the MCL (lanes converging across their own
//! way stand nearer than their share of the band), and the stretch ends before a lane would
//! turn steeper than [`LANE_COS`]; where it reaches an end of the MCL, each lane runs on to the
//! keep-out strip there ([`extend`]), so a wall met at a slant leaves no wedge bare.

use heapless::Vec;

use super::band::Fan;
use super::probe::features_within;
use super::{stroke_ends, Grid, Last, Seen, StripRoom};
use crate::geometry::primitives::MinMax;
use crate::geometry::Point;
use crate::toolpath::composition::along;
use crate::toolpath::{emit_move, PathSink, Vertex};
use crate::{Error, Material, Settings, Slice};

/// Most samples one stretch of lanes spans (a road apart: 64 roads): a longer stretch lays
/// its first this many in lanes and goes on in strokes. The sections live in the zigzag's
/// stack frame while it lays them, 36 bytes each.
const LANE_SAMPLES: usize = 64;

/// Most runs of one number of lanes a stretch is laid in: a stretch whose band widens more
/// than that allows (each run's lanes within `min_width..max_width`, 3.2 times) ends there
/// and goes on in strokes.
const LANE_RUNS: usize = 8;

/// A run of a stretch in lanes: its first section, the one after its last, and its number
/// of lanes.
type Run = (usize, usize, usize);

/// A stretch in lanes only where it is at least this many times as long as its band is wide
/// on average: a shorter one turns more often in lanes (once per lane at each end) than in
/// strokes (twice per road along it).
const LANE_ASPECT: f32 = 2.0;

/// Lanes only where every lane runs within this cosine of the MCL's direction: a lane at a
/// steeper angle to it (the band cut at a slant by a wall, or widening fast) stands nearer
/// its neighbours than their share of the band, and where the lanes turn along a wall their
/// ends leave the wall's strip bare.
const LANE_COS: f32 = 0.5;

/// The band across the MCL at one sample of a stretch in lanes.
#[derive(Clone, Copy)]
struct Section {
    /// The MCL's point.
    q: Point,
    /// The unit normal to the left of the walk.
    left_n: Point,
    /// The band's edges along `left_n` from `q` (`lo` on the right, negative).
    lo: f32,
    hi: f32,
    /// The MCL's direction there (along the walk).
    dir: Point,
    /// The arc length there from the MCL's `from` end.
    s: f32,
}

impl Section {
    fn width(&self) -> f32 {
        self.hi - self.lo
    }
}

/// What a stretch laid in lanes leaves.
pub(super) struct Laid {
    /// The last sample of the stretch.
    pub last: i32,
    /// Whether the road left it on the right.
    pub on_right: bool,
    /// The last section as a meander's strokes go on from it: its outermost lanes' ends
    /// (right, left; where they ran on to a feature past it), its MCL point and direction, and
    /// the composition there.
    pub end: Last,
}

/// Lays the stretch of samples from `k0` on (walking by `step`), all too wide
/// ([`Grid::wide`]), in lanes: up to the first sample where a lane would run more steeply to
/// the MCL than [`LANE_COS`] allows, at most [`LANE_SAMPLES`] and [`LANE_RUNS`] runs, if that
/// is long enough ([`LANE_ASPECT`]). The first lane starts on the right if `right_first`,
/// unless `closing` (a point beside the walk's far end) asks the last lane to end on its side
/// and the stretch reaches the walk's end. Returns `None` (nothing laid) where the stretch is
/// better laid in strokes; the walk goes on in strokes after the last sample laid.
#[allow(clippy::too_many_arguments)]
pub(super) fn lanes(
    slice: &Slice,
    grid: &Grid<'_>,
    seen: &mut Seen,
    k0: i32,
    step: i32,
    (ma, mb, len): (&Material, &Material, f32),
    right_first: bool,
    closing: Option<Point>,
    sink: &mut impl PathSink,
) -> Result<Option<Laid>, Error> {
    let settings = slice.settings();
    let spacing = grid.at.spacing;
    let material = |section: &Section| along(ma, mb, section.s, len);
    let mut sections: Vec<Section, LANE_SAMPLES> = Vec::new();
    let mut k = k0;
    while k >= 0 && k < grid.at.count && grid.wide(seen, k) {
        let band = grid.band(seen, k);
        let (q, dir) = grid.at.sample(k);
        let Some(((left_n, _, _), ends)) = band.zip(stroke_ends(slice, q, spacing, band, grid.fan))
        else {
            break;
        };
        let ws = spacing.fmax(settings.min_width);
        let lo = (ends[0].0 - q).dot(left_n) - 0.5 * ws;
        let hi = (ends[1].0 - q).dot(left_n) + 0.5 * ws;
        let section = Section {
            q,
            left_n,
            lo,
            hi,
            dir,
            s: grid.at.offset + k as f32 * spacing,
        };
        // Full: the stretch goes on in strokes.
        if sections.push(section).is_err() {
            break;
        }
        k += step;
    }
    // The lanes run only as far as each keeps within `LANE_COS` of the MCL's direction:
    // the stretch ends before the first section where one turns steeper.
    let mut runs = runs_of(&mut sections, settings);
    while let Some(m) = first_steep(&sections, &runs) {
        sections.truncate(m);
        runs = runs_of(&mut sections, settings);
    }
    let count = sections.len();
    if count < 2 {
        return Ok(None);
    }
    let mean = sections.iter().map(Section::width).sum::<f32>() / count as f32;
    if ((count - 1) as f32) * spacing < LANE_ASPECT * mean {
        return Ok(None);
    }
    let k = k0 + step * count as i32;
    // The side the first lane starts on: where the stretch reaches the walk's end beside a
    // bare strip, the last lane ends on the strip's side; each run crosses the band once.
    let reaches_end = k < 0 || k >= grid.at.count;
    let mut right = right_first;
    if let (true, Some(at)) = (reaches_end, closing) {
        let last = &sections[count - 1];
        let end_right = (at - last.q).dot(last.left_n) < 0.0;
        right = if runs.len() % 2 == 0 {
            end_right
        } else {
            !end_right
        };
    }
    // Where the stretch begins at the walk's first sample or ends at its last, each lane runs
    // on past the end section toward the feature there, as far as it keeps a road off it (the
    // arcs' strip): a wall met at a slant leaves no wedge bare between the lanes' ends and
    // the strip.
    let first = if step > 0 { 0 } else { grid.at.count - 1 };
    let ends_open = [k0 == first, reaches_end];
    let last_run = runs.len() - 1;
    let mut tips = [Point::new(0.0, 0.0); 2];
    for (r, &(i, j, n)) in runs.iter().enumerate() {
        for lane in 0..n {
            let forward = lane % 2 == 0;
            let point = |x: usize| lane_at(&sections[x], lane, n, right);
            // The lane's width at section `x`: the lanes stand their share apart across the
            // MCL; where they run at an angle to it (the band widening or narrowing fast, cut
            // by a wall at a slant), they stand that much nearer each other across their own
            // way.
            let width = |x: usize| {
                let (a, b) = (x.saturating_sub(1).max(i), (x + 1).min(j - 1));
                let along = point(b) - point(a);
                let mcl = sections[b].q - sections[a].q;
                let cos = if along.norm() > 1e-9 && mcl.norm() > 1e-9 {
                    libm::fabsf(along.dot(mcl)) / (along.norm() * mcl.norm())
                } else {
                    1.0
                };
                (cos * sections[x].width() / n as f32).fmax(settings.min_width)
            };
            // The lane's end past section `x` (from `inner`'s side), if it is open.
            let past = |x: usize, inner: usize, open: bool| {
                (open && inner != x).then(|| {
                    let (to, from) = (point(x), point(inner));
                    extend(slice, grid.fan, from, to, width(x), sections[x].width())
                })
            };
            let head = past(i, i + 1, r == 0 && ends_open[0]);
            let tail = past(j - 1, j.saturating_sub(2), r == last_run && ends_open[1]);
            let (before, after) = if forward { (head, tail) } else { (tail, head) };
            let (x0, x1) = if forward { (i, j - 1) } else { (j - 1, i) };
            let mut lay = |at: Point, x: usize| {
                emit_move(
                    slice,
                    sink,
                    Vertex {
                        at,
                        material: material(&sections[x]),
                        width: width(x),
                        deposit: true,
                    },
                )
            };
            if let Some(at) = before {
                lay(at, x0)?;
            }
            for m in 0..j - i {
                let x = if forward { i + m } else { j - 1 - m };
                lay(point(x), x)?;
            }
            if let Some(at) = after {
                lay(at, x1)?;
            }
            if r == last_run && (lane == 0 || lane == n - 1) {
                let end = tail.unwrap_or(point(j - 1));
                // Lanes counted from the side `right` names: the first is the right one if
                // `right`.
                let on_right = (lane == 0) == right;
                tips[if on_right { 0 } else { 1 }] = end;
            }
        }
        right = !right;
    }
    let last = &sections[count - 1];
    Ok(Some(Laid {
        last: k0 + step * (count as i32 - 1),
        on_right: right,
        end: Last {
            tips,
            at: last.q,
            dir: last.dir,
            material: material(last),
        },
    }))
}

/// The lane from `from` to `to` (`width` wide), run on past `to` as far as it keeps its
/// edge a road off every feature (clear of the arcs' strip), at most `cap`.
fn extend(slice: &Slice, fan: &Fan<'_>, from: Point, to: Point, width: f32, cap: f32) -> Point {
    let way = to - from;
    let len = way.norm();
    if len < 1e-9 {
        return to;
    }
    let d = way * (1.0 / len);
    let rooms = StripRoom::new(slice.settings(), width);
    let mut t = features_within(slice, to, d, rooms.room);
    // Into the strip where no arc lays it, as a stroke's end runs into it ([`stroke_ends`]).
    if let Some(bare) = fan.bare {
        let into = features_within(slice, to, d, rooms.bare_room);
        if into > t && into <= cap && bare(to + d * into, rooms.bare_margin) {
            t = into;
        }
    }
    to + d * t.fmin(cap).fmax(0.0)
}

/// The runs of a stretch's `sections`: each from its first section to the section before
/// the next run's, with its number of lanes (odd, at least 3), each lane within the slice's
/// widths all along. Where the runs would be more than [`LANE_RUNS`], the stretch ends before
/// the first that does not fit.
fn runs_of(sections: &mut Vec<Section, LANE_SAMPLES>, settings: &Settings) -> Vec<Run, LANE_RUNS> {
    let mut runs = Vec::new();
    let mut i = 0;
    while i < sections.len() {
        let n = lanes_for(sections[i].width(), settings);
        let mut j = i + 1;
        while j < sections.len() {
            let lane = sections[j].width() / n as f32;
            if lane < settings.min_width || lane > settings.max_width {
                break;
            }
            j += 1;
        }
        if runs.push((i, j, n)).is_err() {
            sections.truncate(i);
            break;
        }
        i = j;
    }
    runs
}

/// The first section some lane reaches at an angle steeper than [`LANE_COS`] to the MCL.
fn first_steep(sections: &[Section], runs: &[Run]) -> Option<usize> {
    let mut first: Option<usize> = None;
    for &(i, j, n) in runs {
        for lane in 0..n {
            for m in i + 1..j {
                let (a, b) = (&sections[m - 1], &sections[m]);
                let (pa, pb) = (lane_at(a, lane, n, true), lane_at(b, lane, n, true));
                let (mcl, way) = (b.q - a.q, pb - pa);
                if way.dot(mcl) < LANE_COS * way.norm() * mcl.norm() {
                    first = Some(first.map_or(m, |f| f.min(m)));
                    break;
                }
            }
        }
    }
    first
}

/// The point of lane `lane` of `n` at `section`, lanes counted from the right if `right`.
fn lane_at(section: &Section, lane: usize, n: usize, right: bool) -> Point {
    let share = section.width() / n as f32;
    let off = if right {
        section.lo + (lane as f32 + 0.5) * share
    } else {
        section.hi - (lane as f32 + 0.5) * share
    };
    section.q + section.left_n * off
}

/// How many lanes (odd, at least 3) a band `c` wide is laid in: each as near the road width
/// as may be, within `min_width..max_width` where an odd number allows it.
fn lanes_for(c: f32, settings: &Settings) -> usize {
    let w = settings.road_width;
    // The odd numbers either side of `c / w`, the nearer one first where both fit.
    let below = (((c / w - 1.0) * 0.5).fmax(1.0)) as usize * 2 + 1;
    [below, below + 2]
        .into_iter()
        .filter(|&n| {
            let lane = c / n as f32;
            lane >= settings.min_width && lane <= settings.max_width
        })
        .min_by(|&a, &b| {
            let off = |n: usize| libm::fabsf(c / n as f32 - w);
            off(a).total_cmp(&off(b))
        })
        .unwrap_or(below)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_band_is_laid_in_an_odd_number_of_lanes_near_the_road_width() {
        let settings = Settings::for_road_width(0.4);
        let (min, max) = (settings.min_width, settings.max_width);
        for tenth in 18..400 {
            let c = 0.04 * tenth as f32;
            let n = lanes_for(c, &settings);
            let lane = c / n as f32;
            assert!(n >= 3 && n % 2 == 1, "{c}: {n}");
            // Within the widths wherever a band too wide for one road allows 3 lanes or more.
            assert!(lane >= min && lane <= max, "{c}: {n} lanes of {lane}");
            // No other odd number of lanes within the widths is nearer the road width.
            for other in [n.saturating_sub(2).max(3), n + 2] {
                let off = |n: usize| (c / n as f32 - 0.4).abs();
                let fits = (min..=max).contains(&(c / other as f32));
                assert!(
                    !fits || off(n) <= off(other) + 1e-6,
                    "{c}: {n}, {other} nearer"
                );
            }
        }
    }

    #[test]
    fn lanes_stand_their_share_of_the_band_apart_from_either_side() {
        // A band from 0.3 right of the MCL to 0.9 left of it: 3 lanes of 0.4.
        let section = Section {
            q: Point::new(1.0, 0.0),
            left_n: Point::new(0.0, 1.0),
            lo: -0.3,
            hi: 0.9,
            dir: Point::new(1.0, 0.0),
            s: 0.0,
        };
        let ys = |right| (0..3).map(move |l| lane_at(&section, l, 3, right).y);
        for (y, want) in ys(true).zip([-0.1, 0.3, 0.7]) {
            assert!((y - want).abs() < 1e-6, "{y} {want}");
        }
        for (y, want) in ys(false).zip([0.7, 0.3, -0.1]) {
            assert!((y - want).abs() < 1e-6, "{y} {want}");
        }
    }
}
