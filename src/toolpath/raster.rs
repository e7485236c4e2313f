//! The baseline: a Cartesian raster fill as ordinary slicers make it (one perimeter around
//! the wall and around every feature, then parallel lines a road width apart, alternating
//! between 45 and 135 degrees by layer, linked where the next line's end is near). Composition
//! comes from the blended field at each vertex. It is measured exactly like the MCL layers, so
//! their gain is shown rather than claimed.

use crate::geometry::primitives::MinMax;
use crate::geometry::Point;
use crate::keep_out::{KeepOut, Side};
use crate::toolpath::composition::BlendedField;
use crate::toolpath::{emit_move, PathSink, Vertex};
use crate::{Error, Limit, Plan, Slice};

/// Longest deposited piece between two vertices, mm (so composition can change along it).
const MAX_PIECE: f32 = 1.0;
/// Most lines of the infill.
const MAX_LINES: usize = 512;
/// Most runs on one line.
const MAX_RUNS: usize = 16;
// Line indices are stored as `u16`.
const _: () = assert!(MAX_LINES <= u16::MAX as usize);

/// Writes the raster layer `layer` (its index sets the line angle) into `sink`.
pub fn raster(
    slice: &Slice,
    plan: &Plan,
    layer: usize,
    sink: &mut impl PathSink,
) -> Result<(), Error> {
    let w = slice.settings().road_width;
    let field = BlendedField::new(slice, plan);
    let material_at = |p: Point| field.at(p).unwrap_or(slice.wall().material());

    // Perimeters: the keep-out curves of the wall and of every feature, each a closed loop.
    let wall = KeepOut::new(slice.wall(), 0.5 * w, Side::Inside);
    perimeter(slice, &wall, slice.wall().material(), sink)?;
    for h in slice.holes() {
        perimeter(
            slice,
            &KeepOut::new(h, 0.5 * w, Side::Outside),
            h.material(),
            sink,
        )?;
    }

    // Infill lines: centres at least a road width from every feature.
    let angle = if layer % 2 == 0 { 0.25 } else { 0.75 } * core::f32::consts::PI;
    let dir = Point::new(libm::cosf(angle), libm::sinf(angle));
    let across = dir.perp();
    let inside = |p: Point| slice.wall_clearance(p) >= w && slice.nearest_holes(p).1 >= w;
    let (lo, hi) = slice.wall().bbox();
    let corners = [lo, Point::new(hi.x, lo.y), hi, Point::new(lo.x, hi.y)];
    let (mut a0, mut a1, mut d0, mut d1) = (
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
    );
    for c in corners {
        a0 = a0.fmin(c.dot(across));
        a1 = a1.fmax(c.dot(across));
        d0 = d0.fmin(c.dot(dir));
        d1 = d1.fmax(c.dot(dir));
    }
    let lines = libm::floorf((a1 - a0) / w) as usize;
    if lines > MAX_LINES {
        return Err(Error::Capacity {
            limit: Limit::PathVertices,
            feature: None,
        });
    }
    let step = 0.25 * w;
    let samples = libm::ceilf((d1 - d0) / step) as usize + 1;
    // Runs of every line, as (line, start, end) along `dir`.
    let mut runs: heapless::Vec<(u16, f32, f32), { MAX_LINES * 4 }> = heapless::Vec::new();
    for l in 0..lines {
        let off = a0 + (l as f32 + 0.5) * w;
        let at = |t: f32| across * off + dir * t;
        let mut start: Option<f32> = None;
        let mut count = 0;
        for k in 0..=samples {
            let t = d0 + k as f32 * step;
            let inn = k < samples && inside(at(t));
            match (start, inn) {
                (None, true) => {
                    start = Some(if k == 0 {
                        t
                    } else {
                        refine(&inside, &at, t - step, t)
                    });
                }
                (Some(s), false) => {
                    let e = refine(&inside, &at, t, t - step);
                    if e - s > 0.5 * w {
                        count += 1;
                        if count > MAX_RUNS || runs.push((l as u16, s, e)).is_err() {
                            return Err(Error::Capacity {
                                limit: Limit::PathVertices,
                                feature: None,
                            });
                        }
                    }
                    start = None;
                }
                _ => {}
            }
        }
    }
    // Link runs greedily: from the current end to the nearest free run end; deposit the link
    // when it is short and stays in the region, else travel.
    let mut used: heapless::Vec<bool, { MAX_LINES * 4 }> = heapless::Vec::new();
    // Never full: `runs` has the same capacity.
    used.resize(runs.len(), false)
        .map_err(|_| Limit::PathVertices.error())?;
    let point_of = |r: &(u16, f32, f32), t: f32| across * (a0 + (r.0 as f32 + 0.5) * w) + dir * t;
    let mut here: Option<Point> = sink.last_vertex().map(|v| v.at);
    let mut linked = false;
    for _ in 0..runs.len() {
        let mut best: Option<(usize, bool, f32)> = None;
        for (i, r) in runs.iter().enumerate() {
            if used[i] {
                continue;
            }
            for (rev, t) in [(false, r.1), (true, r.2)] {
                let d = here.map_or(0.0, |h| h.dist(point_of(r, t)));
                if best.is_none_or(|b| d < b.2) {
                    best = Some((i, rev, d));
                }
            }
        }
        let Some((i, rev, d)) = best else { break };
        used[i] = true;
        let r = runs[i];
        let (t0, t1) = if rev { (r.2, r.1) } else { (r.1, r.2) };
        let p0 = point_of(&r, t0);
        let printable = |p: Point| slice.is_printable(p, 1e-4);
        let link =
            linked && d <= 2.0 * w && here.is_some_and(|h| segment_inside(&printable, h, p0));
        emit_move(
            slice,
            sink,
            Vertex {
                at: p0,
                material: material_at(p0),
                width: slice.settings().road_width,
                deposit: link,
            },
        )?;
        let pieces = libm::ceilf(libm::fabsf(t1 - t0) / MAX_PIECE).fmax(1.0) as usize;
        for k in 1..=pieces {
            let p = point_of(&r, t0 + (t1 - t0) * k as f32 / pieces as f32);
            emit_move(
                slice,
                sink,
                Vertex {
                    at: p,
                    material: material_at(p),
                    width: slice.settings().road_width,
                    deposit: true,
                },
            )?;
        }
        here = Some(point_of(&r, t1));
        linked = true;
    }
    Ok(())
}

fn perimeter(
    slice: &Slice,
    curve: &KeepOut<'_>,
    material: crate::Material,
    sink: &mut impl PathSink,
) -> Result<(), Error> {
    let mut result = Ok(());
    let mut first = true;
    let len = curve.length();
    curve.arc(0.0, len * 0.999_999, true, |p, _| {
        if result.is_ok() {
            result = emit_move(
                slice,
                sink,
                Vertex {
                    at: p,
                    material,
                    width: slice.settings().road_width,
                    deposit: !first,
                },
            );
            first = false;
        }
    });
    result?;
    emit_move(
        slice,
        sink,
        Vertex {
            at: curve.at(0.0),
            material,
            width: slice.settings().road_width,
            deposit: true,
        },
    )
}

/// The boundary between `a` (inside) and `b` (outside) along the line, by bisection.
fn refine(
    inside: &impl Fn(Point) -> bool,
    at: &impl Fn(f32) -> Point,
    mut a: f32,
    mut b: f32,
) -> f32 {
    if !inside(at(a)) {
        core::mem::swap(&mut a, &mut b);
    }
    for _ in 0..16 {
        let m = 0.5 * (a + b);
        if inside(at(m)) {
            a = m;
        } else {
            b = m;
        }
    }
    a
}

fn segment_inside(inside: &impl Fn(Point) -> bool, a: Point, b: Point) -> bool {
    (0..=8).all(|k| inside(a.lerp(b, k as f32 / 8.0)))
}
