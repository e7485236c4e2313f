//! The sender's side of a slice: the messages that carry it, in order.

use super::contour::{chunks, Chunks};
use super::message::HostMsg;
use crate::config::MAX_VERTICES;
use crate::error::{Error, FeatureId};
use crate::slice::{Feature, Slice};

// A stored polygon's vertex count goes out as a `u32`.
const _: () = assert!(MAX_VERTICES <= u32::MAX as usize);

/// The messages of a slice upload: [`HostMsg::Job`], then per feature (the wall, then the
/// holes) [`HostMsg::Feature`] and its [`HostMsg::Contour`] chunks, then
/// [`HostMsg::EndSlice`]. An iterator: nothing is buffered.
///
/// The controller rebuilds the contours in whole micrometres
/// ([`quantize`](super::contour::quantize)).
#[derive(Clone, Debug)]
pub struct Upload<'a> {
    slice: &'a Slice,
    layers: u16,
    /// 0: the job; 1: the wall; 2 + i: hole i; then the end; then done.
    stage: usize,
    chunks: Option<Chunks<'a>>,
}

/// The upload of `slice`, to be printed in `layers` layers.
pub fn upload(slice: &Slice, layers: u16) -> Upload<'_> {
    Upload {
        slice,
        layers,
        stage: 0,
        chunks: None,
    }
}

impl<'a> Upload<'a> {
    fn feature(&self, stage: usize) -> Option<&'a Feature> {
        match stage {
            1 => Some(self.slice.wall()),
            s => self.slice.holes().get(s.checked_sub(2)?),
        }
    }
}

impl<'a> Iterator for Upload<'a> {
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
                settings: *self.slice.settings(),
                layers: self.layers,
            }));
        }
        if let Some(f) = self.feature(stage) {
            // The feature's own id (`Slice::new` numbers the holes 0, 1, ... in order).
            let id: FeatureId = f.id();
            self.chunks = Some(chunks(id, f.points()));
            return Some(Ok(HostMsg::Feature {
                feature: id,
                material: f.material(),
                // At most MAX_VERTICES (asserted below).
                vertices: f.points().len() as u32,
            }));
        }
        if stage == 2 + self.slice.holes().len() {
            return Some(Ok(HostMsg::EndSlice {
                // At most MAX_HOLES (<= 64) holes.
                holes: self.slice.holes().len() as u8,
            }));
        }
        None
    }
}
