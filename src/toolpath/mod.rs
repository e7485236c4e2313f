//! Toolpaths: what the nozzle does on one layer, as a sequence of [`Vertex`]es.
//!
//! A layer is written vertex by vertex into a [`PathSink`] (a fixed-capacity buffer on the
//! MCU, a growable one on the host), so nothing here needs an allocator and a long layer can be
//! streamed to the motion planner. Each vertex says where the nozzle goes, the composition it
//! deposits there, and whether the move into it deposits (a road) or travels (valves shut).

pub mod composition;
pub mod despike;
pub mod lining;
mod meander;
pub mod moves;
pub mod offset;
pub mod raster;
pub mod spiral;
pub mod zigzag;

use crate::geometry::primitives::MinMax;
use crate::geometry::Point;
use crate::keep_out::{KeepOut, Side};
use crate::{Error, FeatureId, Limit, Material, Slice};

/// The fill pattern of a layer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Pattern {
    /// Crosshatch along the MCLs (paper, section 2.3).
    Zigzag,
    /// Spiral across the MCLs in every cell (paper, section 2.4).
    Spiral,
    /// A Cartesian raster fill with perimeters, as ordinary slicers do (the baseline).
    Raster,
}

impl Pattern {
    /// The pattern's name in files and on the command line.
    pub const fn name(self) -> &'static str {
        match self {
            Pattern::Zigzag => "zigzag",
            Pattern::Spiral => "spiral",
            Pattern::Raster => "raster",
        }
    }
}

/// One vertex of a layer's path.
///
/// ```
/// use hollowpath::toolpath::Vertex;
/// use hollowpath::geometry::Point;
/// let v = Vertex {
///     at: Point::new(1.0, 2.0),
///     material: [1.0, 0.0, 0.0, 0.0],
///     width: 0.4,
///     deposit: true,
/// };
/// assert!(v.deposit);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Vertex {
    /// Where the nozzle goes, mm.
    pub at: Point,
    /// The composition deposited at this vertex (blended linearly along the move into it).
    pub material: Material,
    /// The road width deposited at this vertex, mm (linear along the move into it, like the
    /// composition). Usually the slice's road width; a layer widens a road where its
    /// neighbours are farther apart than a road width and narrows it where they are nearer,
    /// within the slice's [`Settings::min_width`](crate::Settings::min_width) ..
    /// [`max_width`](crate::Settings::max_width), so the deposit fills the gap between them
    /// (the extrusion rate per millimetre follows the width). Never more than twice the
    /// vertex's clearance from the features (every layer's moves pass through a check that
    /// narrows, bends or drops a move that would not fit): a wide road does not spill.
    pub width: f32,
    /// Whether the move from the previous vertex into this one deposits a road; `false` is a
    /// travel move with the valves shut. The first vertex of a layer is always reached by
    /// travel.
    pub deposit: bool,
}

/// Where a layer's vertices go.
///
/// A full sink hands the vertex back, as `heapless::Vec::push` does; the planner turns that
/// into [`Error::Capacity`].
pub trait PathSink {
    /// Appends one vertex.
    fn push_vertex(&mut self, v: Vertex) -> Result<(), Vertex>;
    /// The last vertex appended, if any.
    fn last_vertex(&self) -> Option<Vertex>;
}

impl<const N: usize> PathSink for heapless::Vec<Vertex, N> {
    fn push_vertex(&mut self, v: Vertex) -> Result<(), Vertex> {
        self.push(v)
    }
    fn last_vertex(&self) -> Option<Vertex> {
        self.last().copied()
    }
}

/// A 64-bit FNV-1a digest of a path (positions, compositions and widths as IEEE bits, deposit
/// flags):
/// equal digests mean bit-identical layers, on the host and on the MCU.
pub fn digest(path: &[Vertex]) -> u64 {
    let mut sink = DigestSink::new();
    for &v in path {
        sink.add(v);
    }
    sink.digest()
}

/// A [`PathSink`] that keeps no path, only its [`digest`], its length and its last vertex:
/// a layer streamed through it (to the motion queue, or just to be fingerprinted) needs no
/// path buffer.
///
/// ```
/// use hollowpath::geometry::Point;
/// use hollowpath::toolpath::{digest, DigestSink, PathSink, Vertex};
/// let path = [
///     Vertex { at: Point::new(0.0, 0.0), material: [1.0, 0.0, 0.0, 0.0], width: 0.4, deposit: false },
///     Vertex { at: Point::new(1.0, 0.0), material: [0.5, 0.5, 0.0, 0.0], width: 0.5, deposit: true },
/// ];
/// let mut sink = DigestSink::new();
/// for &v in &path {
///     sink.push_vertex(v).unwrap();
/// }
/// assert_eq!((sink.len(), sink.digest()), (2, digest(&path)));
/// assert_eq!(sink.last_vertex(), Some(path[1]));
/// ```
#[derive(Clone, Copy, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DigestSink {
    fnv: crate::digest::Fnv,
    len: usize,
    last: Option<Vertex>,
}

impl Default for DigestSink {
    fn default() -> Self {
        Self::new()
    }
}

impl DigestSink {
    /// An empty path's sink.
    pub const fn new() -> DigestSink {
        DigestSink {
            fnv: crate::digest::Fnv::new(),
            len: 0,
            last: None,
        }
    }

    fn add(&mut self, v: Vertex) {
        self.fnv.point(v.at);
        for m in v.material {
            self.fnv.word(m.to_bits());
        }
        self.fnv.word(v.width.to_bits());
        self.fnv.word(v.deposit as u32);
        self.len += 1;
        self.last = Some(v);
    }

    /// The digest of the vertices so far, as [`digest`] gives for them.
    pub fn digest(&self) -> u64 {
        self.fnv.finish()
    }

    /// How many vertices passed.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether none did.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

impl PathSink for DigestSink {
    fn push_vertex(&mut self, v: Vertex) -> Result<(), Vertex> {
        self.add(v);
        Ok(())
    }
    fn last_vertex(&self) -> Option<Vertex> {
        self.last
    }
}

#[cfg(feature = "alloc")]
impl PathSink for alloc::vec::Vec<Vertex> {
    fn push_vertex(&mut self, v: Vertex) -> Result<(), Vertex> {
        self.push(v);
        Ok(())
    }
    fn last_vertex(&self) -> Option<Vertex> {
        self.last().copied()
    }
}

/// Appends `v` to `sink`, turning a full sink into a capacity error.
pub(crate) fn emit(sink: &mut impl PathSink, v: Vertex) -> Result<(), Error> {
    sink.push_vertex(v).map_err(|_| Error::Capacity {
        limit: Limit::PathVertices,
        feature: None,
    })
}

/// Appends `v` to `sink` as [`emit`] does, keeping a depositing move in the material: a vertex
/// with less room than its width is pushed out of the keep-out band (half its width from the
/// feature), or, in a pinch with no room for that but room for the slice's narrowest road,
/// narrowed to fit; where its straight chord would cut into a keep-out band (half the road's width from a feature:
/// the sagitta of a chord across a convex feature, or a chord across a whole feature) the move
/// is bent, point by point pushed out to exactly half the road's width, with the composition
/// and width blended along the move; a piece that still cannot be deposited inside the region
/// is travelled instead, so nothing is ever deposited inside a hollow feature or outside the
/// wall.
pub(crate) fn emit_move(slice: &Slice, sink: &mut impl PathSink, v: Vertex) -> Result<(), Error> {
    match (sink.last_vertex(), v.deposit) {
        (Some(prev), true) => {
            // Both ends must lie in the region (a keep-out curve can run through another
            // feature's band where features are closer than a road width).
            let mut v = v;
            if !slice.fits(v.at, v.width, 1e-4) {
                // Pushed out of the keep-out band; where that leaves no room (a pinch between
                // features) but there is room for the narrowest road, narrowed instead.
                let (pushed, _) = into_region(slice, v.at, 0.5 * v.width);
                let room = 2.0 * slice.clearance(v.at) - 2e-4;
                if slice.fits(pushed, v.width, 1e-4) {
                    v.at = pushed;
                } else if room >= slice.settings().min_width {
                    v.width = room;
                } else {
                    return emit(
                        sink,
                        Vertex {
                            deposit: false,
                            ..v
                        },
                    );
                }
            }
            // A depositing predecessor was checked when it was emitted; only the start of a
            // road (reached by travel) still needs it.
            if !prev.deposit && !slice.fits(prev.at, prev.width, 1e-4) {
                return emit(
                    sink,
                    Vertex {
                        deposit: false,
                        ..v
                    },
                );
            }
            bend(slice, sink, prev, v, Depth::FRESH, true)
        }
        _ => emit(sink, v),
    }
}

/// The longest detour round a feature that [`detour`] lays instead of a travel move, in road
/// widths: a longer one would double more of the feature's strip than an extrusion start
/// costs.
const DETOUR_ROADS: f32 = 24.0;

/// Where the depositing move from `a` to `b` (both in the material) crosses a feature, the road
/// goes round it instead: along the feature's keep-out curve from the point nearest `a` to the
/// point nearest `b`, the shorter way, at the narrower of the two widths and in the feature's
/// own material (the material of its keep-out curve), then on to `b`. Returns whether it did:
/// not where the move crosses several features, where the way round is longer than
/// [`DETOUR_ROADS`] road widths, or where a point of the way round does not fit (the move is
/// then bent or travelled as before).
fn detour(slice: &Slice, sink: &mut impl PathSink, a: Vertex, b: Vertex) -> Result<bool, Error> {
    let mut crossed = slice.features_crossed(a.at, b.at);
    let (Some(feature), None) = (crossed.next(), crossed.next()) else {
        return Ok(false);
    };
    let side = match feature.id() {
        FeatureId::Wall => Side::Inside,
        FeatureId::Hole(_) => Side::Outside,
    };
    let width = a.width.fmin(b.width);
    let curve = KeepOut::new(feature, 0.5 * width, side);
    let (s0, s1) = (curve.param_of(a.at), curve.param_of(b.at));
    let ahead = curve.wrap(s1 - s0);
    let forward = ahead <= 0.5 * curve.length();
    let span = if forward {
        ahead
    } else {
        curve.length() - ahead
    };
    if span > DETOUR_ROADS * slice.settings().road_width {
        return Ok(false);
    }
    // Every point of the way round must fit before any is laid.
    let mut fits = true;
    curve.arc(s0, s1, forward, |p, _| fits &= slice.fits(p, width, 1e-4));
    if !fits {
        return Ok(false);
    }
    let material = feature.material();
    let mut result = Ok(());
    curve.arc(s0, s1, forward, |p, _| {
        if result.is_ok() {
            let v = Vertex {
                at: p,
                material,
                width,
                deposit: true,
            };
            result = match sink.last_vertex() {
                Some(last) => bend(slice, sink, last, v, Depth::FRESH, false),
                None => emit(sink, v),
            };
        }
    });
    result?;
    let last = sink.last_vertex().unwrap_or(a);
    bend(slice, sink, last, b, Depth::FRESH, false)?;
    Ok(true)
}

/// How much narrower, as a share of its width, a move's far end may be laid where no bend
/// keeps the move out of a keep-out band (see [`bend`]): a chord between two points on the
/// band's edge sags a few micrometres into it, a road a few per cent narrower clears it.
pub(crate) const NARROWING: f32 = 0.1;

/// How many times [`bend`] halves a move: a move across a feature this many times, and each
/// piece of it that only sags into a keep-out band as many times again.
const BEND_DEPTH: u8 = 8;

/// [`bend`]'s halvings left: for a move across a feature, and for one that only sags into a
/// keep-out band. The pieces of a move across a feature start afresh on the second: a long
/// chord across a hole's tip spent every halving going round it, and the last piece, a chord
/// of the keep-out curve round the tip that only sagged into its band, was then travelled (a
/// start) where two more halvings lay it.
#[derive(Clone, Copy)]
struct Depth {
    across: u8,
    sag: u8,
}

impl Depth {
    const FRESH: Depth = Depth {
        across: BEND_DEPTH,
        sag: BEND_DEPTH,
    };
}

/// Emits `b` (a depositing move from `a`), bent as [`emit_move`] says; where no bend keeps
/// out of a feature the move crosses, round it ([`detour`]) if `route` (not on a detour).
fn bend(
    slice: &Slice,
    sink: &mut impl PathSink,
    a: Vertex,
    b: Vertex,
    depth: Depth,
    route: bool,
) -> Result<(), Error> {
    let half = 0.5 * a.width.fmax(b.width);
    let crossing = slice.segment_crosses_feature(a.at, b.at);
    let dip = if crossing { None } else { dip(slice, a, b) };
    if !crossing && dip.is_none() {
        return emit(sink, b);
    }
    let left = if crossing { depth.across } else { depth.sag };
    if left == 0 || a.at.dist(b.at) < 0.02 * half {
        // Halving found no bend that keeps the road out, and a break in the road here would
        // be an extrusion start. A move across a feature goes round it ([`detour`]); a move
        // that only sags into a keep-out band (both ends sit on its edge) is laid with its far
        // end narrower, as much as it then clears the band ([`narrowed`]).
        if route && crossing && a.deposit && detour(slice, sink, a, b)? {
            return Ok(());
        }
        if !crossing {
            if let Some(narrowed) = narrowed(slice, a, b) {
                return emit(sink, narrowed);
            }
        }
        return emit(
            sink,
            Vertex {
                deposit: false,
                ..b
            },
        );
    }
    let (t, c) = dip.unwrap_or((0.5, a.at.lerp(b.at, 0.5)));
    let width = a.width + (b.width - a.width) * t;
    // Pushed out half the wider end's width from the feature; where that leaves no room (a
    // pinch) but there is room for the narrowest road, the move narrows there instead.
    let (pushed, onto) = into_region(slice, c, half);
    let room = 2.0 * slice.clearance(c) - 2e-4;
    let (pushed, onto, width) =
        if slice.fits(pushed, width, 1e-4) || crossing || room < slice.settings().min_width {
            (pushed, onto, width)
        } else {
            (c, None, width.fmin(room))
        };
    // A point put on a feature's keep-out curve deposits at that feature: its material.
    let material = match onto {
        Some(FeatureId::Hole(i)) => slice.holes()[i as usize].material(),
        Some(FeatureId::Wall) => slice.wall().material(),
        None => composition::blend(&a.material, &b.material, t),
    };
    let mid = Vertex {
        at: pushed,
        material,
        width,
        deposit: true,
    };
    if pushed.dist(a.at) < 1e-6 || pushed.dist(b.at) < 1e-6 || !slice.fits(pushed, mid.width, 1e-4)
    {
        if route && crossing && a.deposit && detour(slice, sink, a, b)? {
            return Ok(());
        }
        return emit(
            sink,
            Vertex {
                deposit: false,
                ..b
            },
        );
    }
    // Each piece lexicographically less (across, sag) than the move, so the halving ends.
    let depth = if crossing {
        Depth {
            across: depth.across - 1,
            sag: BEND_DEPTH,
        }
    } else {
        Depth {
            sag: depth.sag - 1,
            ..depth
        }
    };
    bend(slice, sink, a, mid, depth, route)?;
    let mid_emitted = sink.last_vertex().unwrap_or(mid);
    bend(slice, sink, mid_emitted, b, depth, route)
}

/// `b` narrowed so that the depositing move from `a` keeps out of every keep-out band (as
/// [`dip`] finds none), if a width within [`NARROWING`] of its own and at least `min_width`
/// does: the widest such width, to within 1/4096 of `NARROWING` (bisection).
fn narrowed(slice: &Slice, a: Vertex, b: Vertex) -> Option<Vertex> {
    let least = (b.width * (1.0 - NARROWING)).fmax(slice.settings().min_width);
    if least > b.width {
        return None;
    }
    let mut probe = b;
    probe.width = least;
    if dip(slice, a, probe).is_some() {
        return None;
    }
    // The widest width that clears, found by bisection between `least` (clears) and `b`'s.
    let (mut lo, mut hi) = (least, b.width);
    for _ in 0..12 {
        let mid = 0.5 * (lo + hi);
        probe.width = mid;
        if dip(slice, a, probe).is_none() {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    probe.width = lo;
    Some(probe)
}

/// Where the depositing move `ab` comes nearer a feature than half its width there (the width
/// tapers linearly along it): its parameter and point, as [`Slice::segment_dip`] and
/// [`Slice::tapered_dip`] give them.
fn dip(slice: &Slice, a: Vertex, b: Vertex) -> Option<(f32, Point)> {
    let (ra, rb) = (0.5 * a.width - 1e-4, 0.5 * b.width - 1e-4);
    if ra == rb {
        slice.segment_dip(a.at, b.at, ra)
    } else {
        slice.tapered_dip(a.at, b.at, ra, rb)
    }
}

/// `p` moved out of any keep-out band onto its edge (half a road width from the feature),
/// and the feature it was moved off, if any.
pub(crate) fn into_region(slice: &Slice, mut p: Point, half: f32) -> (Point, Option<FeatureId>) {
    let mut onto = None;
    for _ in 0..2 {
        let (i, d, _, _) = slice.nearest_holes(p);
        if d < half {
            let near = slice.holes()[i].nearest(p);
            p = near.point + near.gradient(p) * half;
            onto = Some(FeatureId::Hole(i as u8));
        }
        let near = slice.wall().nearest(p);
        if -near.distance < half {
            // Inside the wall the gradient of the signed distance points out; go the other way.
            p = near.point - near.gradient(p) * half;
            onto = Some(FeatureId::Wall);
        }
    }
    (p, onto)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Feature, Settings};

    fn slice_with(hole: &[Point]) -> Slice {
        let wall = [(-10.0, -10.0), (10.0, -10.0), (10.0, 10.0), (-10.0, 10.0)]
            .map(|(x, y)| Point::new(x, y));
        let wall = Feature::new(FeatureId::Wall, &wall, [1.0, 0.0, 0.0, 0.0]).unwrap();
        let hole = Feature::new(FeatureId::Hole(0), hole, [0.0, 1.0, 0.0, 0.0]).unwrap();
        Slice::new(wall, &[hole], Settings::for_road_width(0.4)).unwrap()
    }

    fn vertex(x: f32, y: f32, deposit: bool) -> Vertex {
        Vertex {
            at: Point::new(x, y),
            material: [0.5, 0.5, 0.0, 0.0],
            width: 0.4,
            deposit,
        }
    }

    /// Every depositing move of `path` keeps out of the features: its ends fit at its width
    /// and it crosses no feature's boundary.
    fn all_in_the_material(slice: &Slice, path: &[Vertex]) -> bool {
        path.windows(2).all(|m| {
            !m[1].deposit
                || (slice.fits(m[1].at, m[1].width, 1e-4)
                    && !slice.segment_crosses_feature(m[0].at, m[1].at))
        })
    }

    #[test]
    fn a_move_across_a_thin_feature_goes_round_it_in_one_road() {
        // A sliver of a hole, 0.3 mm wide and 3 mm long: no bend of a straight move across
        // it keeps half a road off it, so before the detour the road broke here.
        let sliver =
            [(-0.15, -1.5), (0.15, -1.5), (0.15, 1.5), (-0.15, 1.5)].map(|(x, y)| Point::new(x, y));
        let slice = slice_with(&sliver);
        let mut path: heapless::Vec<Vertex, 512> = heapless::Vec::new();
        emit_move(&slice, &mut path, vertex(-1.0, 0.2, false)).unwrap();
        emit_move(&slice, &mut path, vertex(1.0, -0.1, true)).unwrap();
        assert!(path.len() > 3, "{path:?}");
        assert!(path.iter().skip(1).all(|v| v.deposit), "{path:?}");
        assert!(all_in_the_material(&slice, &path), "{path:?}");
        // Round the sliver's nearer end (the top), in the hole's material on its keep-out
        // curve.
        assert!(path.iter().any(|v| v.at.y > 1.5), "{path:?}");
        assert!(path.iter().all(|v| v.at.y < 2.1), "{path:?}");
        assert!(path
            .iter()
            .any(|v| v.material == [0.0, 1.0, 0.0, 0.0] && v.at.y > 1.6));
        assert_eq!(path.last().unwrap().at, Point::new(1.0, -0.1));
    }

    #[test]
    fn a_move_across_a_large_convex_feature_is_bent_round_it() {
        // A 10 mm square hole, farther round than a detour goes: the bends (midpoints pushed
        // out of the feature) go round it, and detours round the corners where a bend's
        // halves still cross it (before the detour, the road broke at the first corner).
        let square =
            [(-5.0, -5.0), (5.0, -5.0), (5.0, 5.0), (-5.0, 5.0)].map(|(x, y)| Point::new(x, y));
        let slice = slice_with(&square);
        let mut path: heapless::Vec<Vertex, 512> = heapless::Vec::new();
        emit_move(&slice, &mut path, vertex(-6.0, 0.0, false)).unwrap();
        emit_move(&slice, &mut path, vertex(6.0, 0.0, true)).unwrap();
        assert!(path.iter().skip(1).all(|v| v.deposit), "{path:?}");
        assert!(all_in_the_material(&slice, &path), "{path:?}");
    }
}
