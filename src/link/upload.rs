//! The sender's side of a slice and of a printer configuration: the messages that carry
//! them, in order.

use super::contour::{chunks, Chunks};
use super::error::LinkError;
use super::message::{HostMsg, PrinterChunk, CHUNK_BYTES, PRINTER_BYTES};
use crate::config::MAX_VERTICES;
use crate::error::{Error, FeatureId};
use crate::geometry::Point;
use crate::motion::config::PrinterConfig;
use crate::slice::{Feature, Material, Settings, Slice};

// A stored polygon's vertex count goes out as a `u32`.
const _: () = assert!(MAX_VERTICES <= u32::MAX as usize);

/// Where an upload's holes come from.
#[derive(Clone, Copy, Debug)]
enum Holes<'a> {
    /// A validated slice's.
    Slice(&'a [Feature]),
    /// Raw contours, not validated on this side.
    Raw(&'a [(&'a [Point], Material)]),
}

/// The messages of a slice upload: [`HostMsg::Job`], then per feature (the wall, then the
/// holes) [`HostMsg::Feature`] and its [`HostMsg::Contour`] chunks, then
/// [`HostMsg::EndSlice`]. An iterator: nothing is buffered.
///
/// The controller rebuilds the contours in whole micrometres
/// ([`quantize`](super::contour::quantize)).
#[derive(Clone, Debug)]
pub struct Upload<'a> {
    settings: Settings,
    wall: (&'a [Point], Material),
    holes: Holes<'a>,
    layers: u16,
    /// 0: the job; 1: the wall; 2 + i: hole i; then the end; then done.
    stage: usize,
    chunks: Option<Chunks<'a>>,
}

/// The upload of `slice`, to be printed in `layers` layers.
pub fn upload(slice: &Slice, layers: u16) -> Upload<'_> {
    Upload {
        settings: *slice.settings(),
        wall: (slice.wall().points(), slice.wall().material()),
        holes: Holes::Slice(slice.holes()),
        layers,
        stage: 0,
        chunks: None,
    }
}

/// The upload of raw contours (a wall and `(points, material)` per hole), validated by the
/// controller only: what a host sends to see the controller's own refusal of a slice it
/// would refuse itself. More than 256 holes are sent as 256 (the controller refuses more
/// than [`MAX_HOLES`](crate::config::MAX_HOLES) anyway).
pub fn upload_contours<'a>(
    wall: &'a [Point],
    wall_material: Material,
    holes: &'a [(&'a [Point], Material)],
    settings: Settings,
    layers: u16,
) -> Upload<'a> {
    Upload {
        settings,
        wall: (wall, wall_material),
        holes: Holes::Raw(&holes[..holes.len().min(u8::MAX as usize + 1)]),
        layers,
        stage: 0,
        chunks: None,
    }
}

impl<'a> Upload<'a> {
    fn hole_count(&self) -> usize {
        match self.holes {
            Holes::Slice(h) => h.len(),
            Holes::Raw(h) => h.len(),
        }
    }

    /// Feature `stage - 1` (the wall at stage 1): its id, points and material.
    fn feature(&self, stage: usize) -> Option<(FeatureId, &'a [Point], Material)> {
        if stage == 1 {
            return Some((FeatureId::Wall, self.wall.0, self.wall.1));
        }
        let i = stage.checked_sub(2)?;
        // At most 256 holes (`upload_contours` cuts them there; a slice holds MAX_HOLES).
        let id = FeatureId::Hole(u8::try_from(i).ok()?);
        match self.holes {
            Holes::Slice(h) => h.get(i).map(|f| (id, f.points(), f.material())),
            Holes::Raw(h) => h.get(i).map(|&(p, m)| (id, p, m)),
        }
    }
}

impl Iterator for Upload<'_> {
    type Item = Result<HostMsg, Error>;

    fn next(&mut self) -> Option<Self::Item> {
        if let Some(c) = self.chunks.as_mut() {
            match c.next() {
                Some(r) => return Some(r.map(HostMsg::Contour)),
                None => self.chunks = None,
            }
        }
        let stage = self.stage;
        self.stage += 1;
        if stage == 0 {
            return Some(Ok(HostMsg::Job {
                settings: self.settings,
                layers: self.layers,
            }));
        }
        if let Some((id, points, material)) = self.feature(stage) {
            if points.len() > u32::MAX as usize {
                return Some(Err(Error::TooManyVertices {
                    feature: id,
                    vertices: u32::MAX,
                    simplified: false,
                }));
            }
            self.chunks = Some(chunks(id, points));
            return Some(Ok(HostMsg::Feature {
                feature: id,
                material,
                vertices: points.len() as u32,
            }));
        }
        if stage == 2 + self.hole_count() {
            return Some(Ok(HostMsg::EndSlice {
                // At most 256 holes: 256 goes out as 255 (refused either way).
                holes: self.hole_count().min(u8::MAX as usize) as u8,
            }));
        }
        None
    }
}

/// The [`HostMsg::Printer`] chunks of a printer configuration, in order.
#[derive(Clone, Debug)]
pub struct PrinterUpload {
    bytes: [u8; PRINTER_BYTES],
    len: usize,
    next: usize,
}

/// The chunks of `cfg`; [`LinkError::MessageTooLarge`] if its encoding exceeds
/// [`PRINTER_BYTES`].
pub fn printer(cfg: &PrinterConfig) -> Result<PrinterUpload, LinkError> {
    let mut bytes = [0u8; PRINTER_BYTES];
    let len = postcard::to_slice(cfg, &mut bytes)
        .map_err(|_| LinkError::MessageTooLarge)?
        .len();
    Ok(PrinterUpload {
        bytes,
        len,
        next: 0,
    })
}

impl PrinterUpload {
    /// Bytes of the configuration's encoding.
    pub fn encoded_len(&self) -> usize {
        self.len
    }
}

impl Iterator for PrinterUpload {
    type Item = HostMsg;

    fn next(&mut self) -> Option<HostMsg> {
        if self.next >= self.len {
            return None;
        }
        let end = (self.next + CHUNK_BYTES).min(self.len);
        let mut data = heapless::Vec::new();
        // `end - next <= CHUNK_BYTES`, the vector's capacity: cannot fail.
        data.extend_from_slice(&self.bytes[self.next..end]).ok()?;
        // Offsets and lengths are at most PRINTER_BYTES <= u16::MAX (asserted in `message`).
        let chunk = PrinterChunk {
            offset: self.next as u16,
            total: self.len as u16,
            data,
        };
        self.next = end;
        Some(HostMsg::Printer(chunk))
    }
}
