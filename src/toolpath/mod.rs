//! Toolpaths: what the nozzle does on one layer, as a sequence of [`Vertex`]es.
//!
//! A layer is written vertex by vertex into a [`PathSink`] (a fixed-capacity buffer on the
//! MCU, a growable one on the host), so nothing here needs an allocator and a long layer can be
//! streamed to the motion planner. Each vertex says where the nozzle goes, the composition it
//! deposits there, and whether the move into it deposits (a road) or travels (valves shut).

pub mod composition;
pub mod despike;
mod meander;
pub mod moves;
pub mod offset;
pub mod raster;
pub mod spiral;
pub mod zigzag;

use crate::geometry::Point;
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
            bend(slice, sink, prev, v, 8)
        }
        _ => emit(sink, v),
    }
}

/// Emits `b` (a depositing move from `a`), bent as [`emit_move`] says.
fn bend(
    slice: &Slice,
    sink: &mut impl PathSink,
    a: Vertex,
    b: Vertex,
    depth: u8,
) -> Result<(), Error> {
    let half = 0.5 * a.width.max(b.width);
    let crossing = slice.segment_crosses_feature(a.at, b.at);
    let dip = if crossing { None } else { dip(slice, a, b) };
    if !crossing && dip.is_none() {
        return emit(sink, b);
    }
    if depth == 0 || a.at.dist(b.at) < 0.02 * half {
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
            (c, None, width.min(room))
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
        return emit(
            sink,
            Vertex {
                deposit: false,
                ..b
            },
        );
    }
    bend(slice, sink, a, mid, depth - 1)?;
    let mid_emitted = sink.last_vertex().unwrap_or(mid);
    bend(slice, sink, mid_emitted, b, depth - 1)
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
