//! Spikes out of a layer: a depositing move that turns straight back on the move before it.
//!
//! The layers' construction (bends around keep-out bands, chords refined onto a level, stroke
//! ends trimmed off a feature) now and then leaves a vertex a few micrometres to a fraction of
//! a road past where the road goes on, so the road runs out to it and straight back. A printer
//! has to stop dead for that reversal (the look-ahead's corner speed of a reversal is 0), the
//! valves shut and reopen there, and the bead swells on the doubled piece. [`Despike`] sits
//! between a layer and its sink, one vertex behind, and drops such a vertex: where the moves
//! `a -> b -> c` both deposit, turn by more than [`SPIKE_COS`] and the shorter of the two is
//! under [`SPIKE_SHARE`] of the road width, `b` goes and the road runs `a -> c`, along the
//! line it had already covered. A chain of spikes goes one vertex at a time, and a move of no
//! length at the width and mix of the move before goes at once (it lays nothing new, and
//! would hide the spike behind it). Measuring the legs against a wide road's own width
//! instead (a reversal inside a wide road laps a ring over it) took 0.009 and 0.020 of
//! coverage from the four_holes and three_holes zigzags: it also dropped turns that fill.
//!
//! The move `a -> c` is new: it tapers from `a`'s width to `c`'s where `a -> b` was laid at
//! `b`'s, and it cuts the corner `b` turned. Next to a feature's corner that can bring it
//! nearer the feature than half its width (a meander's tip beside a hole's sharp corner), so
//! `b` goes only where `a -> c` keeps out of every feature as [`emit_move`](super::emit_move)
//! keeps a move (no boundary crossed, no keep-out band entered).

use super::{dip, PathSink, Vertex};
use crate::geometry::primitives::MinMax;
use crate::{Error, Limit, Slice};

/// A turn counts as a reversal below this cosine (about 172 degrees).
pub const SPIKE_COS: f32 = -0.99;
/// A reversal is a spike where its shorter leg is under this share of the road width.
pub const SPIKE_SHARE: f32 = 0.5;

/// A [`PathSink`] that drops spikes before they reach `inner` (the module's essay); call
/// [`finish`](Self::finish) at the end of the layer.
pub struct Despike<'a, S: PathSink> {
    inner: &'a mut S,
    pending: Option<Vertex>,
    slice: &'a Slice,
    /// Vertices dropped.
    pub dropped: u32,
}

impl<'a, S: PathSink> Despike<'a, S> {
    /// In front of `inner`, for the layers of `slice`.
    pub fn new(inner: &'a mut S, slice: &'a Slice) -> Despike<'a, S> {
        Despike {
            inner,
            pending: None,
            slice,
            dropped: 0,
        }
    }

    /// Passes on the vertex held back; a full sink hands it back.
    pub fn finish(&mut self) -> Result<(), Vertex> {
        match self.pending.take() {
            Some(v) => self.inner.push_vertex(v),
            None => Ok(()),
        }
    }

    fn is_spike(&self, a: &Vertex, b: &Vertex, c: &Vertex) -> bool {
        if !(b.deposit && c.deposit) {
            return false;
        }
        let (u, v) = (b.at - a.at, c.at - b.at);
        let (lu, lv) = (u.norm(), v.norm());
        if lu <= 0.0 || lv <= 0.0 {
            return false;
        }
        u.dot(v) < SPIKE_COS * lu * lv
            && lu.fmin(lv) < SPIKE_SHARE * self.slice.settings().road_width
            && !self.slice.segment_crosses_feature(a.at, c.at)
            && dip(self.slice, *a, *c).is_none()
    }
}

impl<S: PathSink> PathSink for Despike<'_, S> {
    fn push_vertex(&mut self, c: Vertex) -> Result<(), Vertex> {
        if let Some(b) = self.pending {
            if c.deposit
                && b.deposit
                && c.at == b.at
                && c.width == b.width
                && c.material == b.material
            {
                // A move of no length at the width and mix of the move before: it lays
                // nothing that move's end did not, and would hide a spike behind it.
                self.dropped += 1;
                return Ok(());
            }
            if let Some(a) = self.inner.last_vertex() {
                if self.is_spike(&a, &b, &c) {
                    self.dropped += 1;
                    // A spike that ran out and straight back to `a` leaves `a -> c` a move
                    // of no length: wider than `a`, a disc over the roads beside it (a
                    // splice's arc ending on a narrow MCL end, random slice 7). It keeps
                    // `a`'s width.
                    let mut c = c;
                    if c.at == a.at && c.width > a.width {
                        c.width = a.width;
                    }
                    self.pending = Some(c);
                    return Ok(());
                }
            }
            self.inner.push_vertex(b)?;
        }
        self.pending = Some(c);
        Ok(())
    }

    fn last_vertex(&self) -> Option<Vertex> {
        self.pending.or_else(|| self.inner.last_vertex())
    }
}

/// Passes on the vertex `d` holds back, a full sink as [`Error::Capacity`] (as
/// [`emit`](super::emit) does).
pub(crate) fn finish<S: PathSink>(d: &mut Despike<'_, S>) -> Result<(), Error> {
    d.finish().map_err(|_| Error::Capacity {
        limit: Limit::PathVertices,
        feature: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Point;
    use crate::{Feature, FeatureId, Settings};

    /// A 20 mm square wall with the hole `hole` in it, roads 0.4 mm.
    fn slice_with(hole: &[(f32, f32)]) -> Slice {
        let wall = [(-10.0, -10.0), (10.0, -10.0), (10.0, 10.0), (-10.0, 10.0)]
            .map(|(x, y)| Point::new(x, y));
        let wall = Feature::new(FeatureId::Wall, &wall, [1.0, 0.0, 0.0, 0.0]).unwrap();
        let hole: std::vec::Vec<Point> = hole.iter().map(|&(x, y)| Point::new(x, y)).collect();
        let hole = Feature::new(FeatureId::Hole(0), &hole, [0.0, 1.0, 0.0, 0.0]).unwrap();
        Slice::new(wall, &[hole], Settings::for_road_width(0.4)).unwrap()
    }

    /// A hole far from the roads of the tests.
    const FAR: [(f32, f32); 3] = [(5.0, 5.0), (6.0, 5.0), (5.0, 6.0)];

    fn v(x: f32, y: f32) -> Vertex {
        Vertex {
            at: Point::new(x, y),
            material: [1.0, 0.0, 0.0, 0.0],
            width: 0.4,
            deposit: true,
        }
    }

    fn run(pts: &[(f32, f32)]) -> (heapless::Vec<Vertex, 16>, u32) {
        let vs: std::vec::Vec<Vertex> = pts.iter().map(|&(x, y)| v(x, y)).collect();
        run_on(&slice_with(&FAR), &vs)
    }

    fn run_on(slice: &Slice, vs: &[Vertex]) -> (heapless::Vec<Vertex, 16>, u32) {
        let mut out: heapless::Vec<Vertex, 16> = heapless::Vec::new();
        let mut d = Despike::new(&mut out, slice);
        for &x in vs {
            d.push_vertex(x).unwrap();
        }
        d.finish().unwrap();
        let n = d.dropped;
        (out, n)
    }

    #[test]
    fn a_short_reversal_goes_and_a_corner_or_a_long_hairpin_stays() {
        // Out 1 mm, 0.05 mm past, back: the spike's tip goes.
        let (out, n) = run(&[(0.0, 0.0), (1.05, 0.0), (1.0, 0.001), (1.0, 1.0)]);
        assert_eq!(n, 1);
        assert_eq!(out.len(), 3);
        assert_eq!(out[1].at, Point::new(1.0, 0.001));
        // A right angle and a hairpin of two long legs stay.
        let (out, n) = run(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]);
        assert_eq!((out.len(), n), (4, 0));
        let (out, n) = run(&[(0.0, 0.0), (1.0, 0.0), (0.0, 0.01)]);
        assert_eq!((out.len(), n), (3, 0));
        // A chain of spikes goes vertex by vertex: with the first tip gone the road runs on
        // along the line, and a second reversal there goes too.
        let (out, n) = run(&[(0.0, 0.0), (1.0, 0.0), (0.9, 0.0), (1.02, 0.0), (1.0, 1.0)]);
        assert_eq!(n, 1, "{out:?}");
        let (out, n) = run(&[
            (0.0, 0.0),
            (1.0, 0.0),
            (0.95, 0.0),
            (1.1, 0.0),
            (1.0, 0.0),
            (1.0, 1.0),
        ]);
        assert_eq!(n, 2, "{out:?}");
        assert_eq!(out.len(), 4, "{out:?}");
        // A travel into the next vertex is never merged away.
        let slice = slice_with(&FAR);
        let mut out: heapless::Vec<Vertex, 16> = heapless::Vec::new();
        let mut d = Despike::new(&mut out, &slice);
        for (k, p) in [(0.0, 0.0), (1.05, 0.0), (1.0, 0.0)]
            .into_iter()
            .enumerate()
        {
            let mut x = v(p.0, p.1);
            x.deposit = k != 2;
            d.push_vertex(x).unwrap();
        }
        d.finish().unwrap();
        assert_eq!(out.len(), 3);
    }

    #[test]
    fn a_spike_stays_where_the_move_past_it_would_enter_a_keep_out_band() {
        // A road widening from 0.2 mm to 0.4 mm runs 1.1 mm out and 0.1 mm back. Laid
        // without the spike's tip, it widens over 1 mm instead of 1.1: at x = 0.9 it is half
        // 0.19 mm wide where it was 0.182, and a hole's corner 0.187 mm off the line is then
        // inside it.
        let corner = [(0.9, 0.187), (1.5, 1.0), (0.3, 1.0)];
        let widths = [0.2, 0.4, 0.4];
        let vs: std::vec::Vec<Vertex> = [(0.0, 0.0), (1.1, 0.0), (1.0, 0.0)]
            .iter()
            .zip(widths)
            .map(|(&(x, y), width)| Vertex { width, ..v(x, y) })
            .collect();
        let slice = slice_with(&corner);
        assert!(dip(&slice, vs[0], vs[2]).is_some());
        assert!(dip(&slice, vs[0], vs[1]).is_none() && dip(&slice, vs[1], vs[2]).is_none());
        let (out, n) = run_on(&slice, &vs);
        assert_eq!((out.len(), n), (3, 0), "{out:?}");
        // Away from the corner the same spike goes.
        let (out, n) = run_on(&slice_with(&FAR), &vs);
        assert_eq!((out.len(), n), (2, 1), "{out:?}");
    }
}
