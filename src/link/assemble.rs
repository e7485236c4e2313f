//! The receiving side's slice assembler: contour chunks in, a validated [`Slice`] out.

use heapless::Vec;

use super::contour::{from_um, ChunkDecoder};
use super::error::LinkError;
use super::message::ContourChunk;
use crate::config::{MAX_HOLES, MAX_VERTICES};
use crate::error::{Error, FeatureId};
use crate::geometry::Point;
use crate::slice::{Material, Settings, Slice, SliceStore};

/// The assembler of the default capacities: [`MAX_HOLES`] holes and room for every
/// polygon at [`MAX_VERTICES`] (18 KiB of points in the MCU build).
pub type DefaultAssembler = SliceAssembler<MAX_HOLES, { (MAX_HOLES + 1) * MAX_VERTICES }>;

#[derive(Clone, Copy, Debug, PartialEq)]
struct Span {
    feature: FeatureId,
    material: Material,
    start: usize,
    declared: usize,
}

/// Collects one slice's contours (up to `HOLES` holes, `POINTS` vertices in all) in fixed
/// memory, and builds the [`Slice`] only when it arrived whole, through the core's own
/// validation ([`Slice::from_contours`]).
///
/// Messages in order: [`begin`](Self::begin) (the job), then per feature (the wall, then
/// holes 0, 1, ...) [`feature`](Self::feature) and its [`chunk`](Self::chunk)s, then
/// [`end`](Self::end); then [`build`](Self::build). The first refusal discards the slice
/// (and is the only one reported: what follows up to the next `begin` is ignored). `const fn
/// new`: it may live in a `static`, and it needs no stack beyond a chunk's.
#[derive(Debug)]
pub struct SliceAssembler<const HOLES: usize, const POINTS: usize> {
    points: Vec<Point, POINTS>,
    /// The wall first, then the holes.
    features: Vec<Span, HOLES>,
    wall: Option<Span>,
    settings: Option<Settings>,
    layers: u16,
    complete: bool,
    failed: bool,
}

impl<const HOLES: usize, const POINTS: usize> Default for SliceAssembler<HOLES, POINTS> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const HOLES: usize, const POINTS: usize> SliceAssembler<HOLES, POINTS> {
    // Hole indices are `u8` (`FeatureId::Hole`); vertex counts (at most POINTS) `u32` on the
    // wire: every `as u32` of a count below is bounded by this.
    const FITS: () = assert!(HOLES <= MAX_HOLES && POINTS <= u32::MAX as usize);

    /// An empty assembler, waiting for a job.
    pub const fn new() -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::FITS;
        SliceAssembler {
            points: Vec::new(),
            features: Vec::new(),
            wall: None,
            settings: None,
            layers: 0,
            complete: false,
            failed: false,
        }
    }

    /// Starts a slice (discarding any other).
    pub fn begin(&mut self, settings: Settings, layers: u16) {
        self.points.clear();
        self.features.clear();
        self.wall = None;
        self.settings = Some(settings);
        self.layers = layers;
        self.complete = false;
        self.failed = false;
    }

    /// Whether a whole slice waits for [`build`](Self::build).
    pub fn is_complete(&self) -> bool {
        self.complete
    }

    /// The job's layer count.
    pub fn layers(&self) -> u16 {
        self.layers
    }

    /// Vertices received so far.
    pub fn vertices(&self) -> usize {
        self.points.len()
    }

    fn fail(&mut self, e: LinkError) -> Result<(), LinkError> {
        self.failed = true;
        self.complete = false;
        Err(e)
    }

    fn current(&self) -> Option<Span> {
        self.features.last().copied().or(self.wall)
    }

    /// The current feature has all the vertices it declared.
    fn finish_current(&self) -> Result<(), LinkError> {
        match self.current() {
            Some(s) if self.points.len() - s.start != s.declared => Err(LinkError::VertexCount {
                feature: s.feature,
                declared: s.declared as u32,
                received: (self.points.len() - s.start) as u32,
            }),
            _ => Ok(()),
        }
    }

    /// Starts the contour of `feature` (the wall first, then holes in order) of `vertices`
    /// vertices.
    pub fn feature(
        &mut self,
        feature: FeatureId,
        material: Material,
        vertices: u32,
    ) -> Result<(), LinkError> {
        if self.failed {
            return Ok(());
        }
        if self.settings.is_none() || self.complete {
            return self.fail(LinkError::UnexpectedMessage);
        }
        if let Err(e) = self.finish_current() {
            return self.fail(e);
        }
        let expected = if self.wall.is_none() {
            FeatureId::Wall
        } else {
            // At most HOLES <= MAX_HOLES <= 64 holes: the cast cannot truncate.
            FeatureId::Hole(self.features.len() as u8)
        };
        if feature != expected {
            return self.fail(LinkError::FeatureOrder {
                expected,
                got: feature,
            });
        }
        let needed = self.points.len() as u64 + u64::from(vertices);
        if needed > POINTS as u64 {
            return self.fail(LinkError::AssemblerPoints {
                capacity: POINTS as u32,
                needed: needed.min(u32::MAX as u64) as u32,
            });
        }
        let span = Span {
            feature,
            material,
            start: self.points.len(),
            declared: vertices as usize,
        };
        if feature == FeatureId::Wall {
            self.wall = Some(span);
        } else if self.features.push(span).is_err() {
            return self.fail(LinkError::AssemblerHoles {
                capacity: HOLES as u32,
            });
        }
        Ok(())
    }

    /// Adds a chunk of the current contour.
    pub fn chunk(&mut self, chunk: &ContourChunk) -> Result<(), LinkError> {
        if self.failed {
            return Ok(());
        }
        let Some(span) = self.current().filter(|_| !self.complete) else {
            return self.fail(LinkError::UnexpectedMessage);
        };
        if chunk.feature != span.feature {
            return self.fail(LinkError::FeatureOrder {
                expected: span.feature,
                got: chunk.feature,
            });
        }
        let received = self.points.len() - span.start;
        if chunk.start as usize != received {
            return self.fail(LinkError::ChunkOrder {
                feature: span.feature,
                expected: received as u32,
                got: chunk.start,
            });
        }
        for q in ChunkDecoder::new(&chunk.data) {
            let Ok(q) = q else {
                return self.fail(LinkError::ContourData {
                    feature: span.feature,
                });
            };
            let received = self.points.len() - span.start;
            if received >= span.declared || self.points.push(from_um(q)).is_err() {
                return self.fail(LinkError::VertexCount {
                    feature: span.feature,
                    declared: span.declared as u32,
                    received: received as u32 + 1,
                });
            }
        }
        Ok(())
    }

    /// Ends the slice of `holes` holes. `Ok(true)`: it is whole; `Ok(false)`: it had been
    /// discarded by an earlier refusal.
    pub fn end(&mut self, holes: u8) -> Result<bool, LinkError> {
        if self.failed {
            return Ok(false);
        }
        if self.settings.is_none() || self.complete || self.wall.is_none() {
            self.fail(LinkError::UnexpectedMessage)?;
        }
        if let Err(e) = self.finish_current() {
            self.fail(e)?;
        }
        if usize::from(holes) != self.features.len() {
            self.fail(LinkError::HoleCount {
                declared: holes.into(),
                received: self.features.len() as u32,
            })?;
        }
        self.complete = true;
        Ok(true)
    }

    /// The slice, built and validated by [`Slice::from_contours`] (contours beyond
    /// [`MAX_VERTICES`] simplified within its `simplify_tolerance`); `None` unless a whole
    /// slice arrived ([`end`](Self::end) returned `Ok(true)`).
    pub fn build(&self) -> Option<Result<Slice, Error>> {
        self.with_contours(Slice::from_contours)
    }

    /// [`build`](Self::build) into `out` ([`SliceStore::build_from_contours`]), with no
    /// slice-sized temporary: how a controller takes the slice.
    pub fn build_into<'s>(&self, out: &'s mut SliceStore) -> Option<Result<&'s Slice, Error>> {
        out.clear();
        self.with_contours(|wall, material, holes, settings| {
            out.build_from_contours(wall, material, holes, settings)
        })
    }

    /// Calls `f` with the received contours (the wall, its material, the holes with theirs)
    /// and settings; `None` unless a whole slice arrived.
    fn with_contours<R>(
        &self,
        f: impl FnOnce(&[Point], Material, &[(&[Point], Material)], Settings) -> Result<R, Error>,
    ) -> Option<Result<R, Error>> {
        if !self.complete {
            return None;
        }
        let (wall, settings) = (self.wall?, self.settings?);
        let pts = |s: &Span| &self.points[s.start..s.start + s.declared];
        let mut holes: Vec<(&[Point], Material), HOLES> = Vec::new();
        for s in self.features.iter() {
            // One per span, of the same capacity: cannot fail.
            if holes.push((pts(s), s.material)).is_err() {
                return Some(Err(Error::TooManyHoles {
                    holes: self.features.len() as u32,
                }));
            }
        }
        Some(f(pts(&wall), wall.material, &holes, settings))
    }
}
