//! From a layer's vertices to the moves a printer executes.
//!
//! A [`Vertex`] carries a road width, linear along the move into it, so a layer can taper a
//! road. A printer cannot: a G-code move, or a block of the motion planner, is laid at one
//! extrusion rate per millimetre, so it deposits one width along its whole length (with a round
//! nozzle, the capsule of half that width around the segment). [`split`] turns each move of a
//! layer into [`Move`]s of constant width: where the width changes along a move, into pieces
//! whose widths stay within [`WIDTH_TOLERANCE`] of the road's at every point (and whose mixes,
//! one per move as a printer holds it, within [`MIX_TOLERANCE`] of the road's).
//!
//! Each piece takes the *narrowest* width the road has along it. So a piece lies inside the
//! tapered road the layer planned (the hull of the discs of half the road's width along the
//! move), and a layer whose tapered roads keep out of the hollow features keeps out of them as
//! printed too; the piece is at most [`WIDTH_TOLERANCE`] narrower than the road anywhere.
//!
//! Everything downstream of a layer consumes these moves: the G-code exporter writes one `G1`
//! per move, the metrics deposit them, and the motion planner will turn them into blocks.

use crate::geometry::primitives::MinMax;
use crate::geometry::Point;
use crate::toolpath::composition::blend;
use crate::toolpath::Vertex;
use crate::Material;

/// How much a piece's width may differ from the road's anywhere along it, as a fraction of the
/// road's width there.
pub const WIDTH_TOLERANCE: f32 = 0.05;

/// How much the mix may change along one move (half the L1 distance between its ends'
/// compositions): a printer holds one mix per move (Marlin's `M165`), so a road blending from
/// one feature's material to another's is laid in steps of at most this.
pub const MIX_TOLERANCE: f32 = 0.02;

/// Most pieces one move is split into. With the default settings a road's width ratio along
/// one move is at most `max_width / min_width` = 3.2 (44 pieces) and a mix changes by at most 1
/// (50 pieces); only extreme settings reach the cap, and then each piece is still the
/// narrowest width along it (never wider than planned), just more than [`WIDTH_TOLERANCE`]
/// narrower in places.
pub const MAX_PIECES: u32 = 128;

/// One straight move at one width, as a printer lays it.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Move {
    /// Where the move starts, mm.
    pub from: Point,
    /// Where it ends, mm.
    pub to: Point,
    /// The road width laid along the whole move, mm (for a travel move, the road width of the
    /// vertex it goes to; nothing is laid).
    pub width: f32,
    /// The composition laid along the whole move (the mix the printer holds while it moves):
    /// the road's composition at one of the move's ends (see [`split`]).
    pub material: Material,
    /// Whether it deposits (valves open) or travels.
    pub deposit: bool,
}

impl Move {
    /// The move's length, mm.
    pub fn length(&self) -> f32 {
        self.from.dist(self.to)
    }
}

/// How many equal pieces the move from `a` to `b` needs: so that each piece's narrowest width
/// is within [`WIDTH_TOLERANCE`] of the road's width all along it (the width is linear along
/// the move, so the piece at the narrow end is the tightest), and its mix within
/// [`MIX_TOLERANCE`] of the road's.
pub fn pieces(a: &Vertex, b: &Vertex) -> u32 {
    let (lo, hi) = if a.width <= b.width {
        (a.width, b.width)
    } else {
        (b.width, a.width)
    };
    let by_width = if lo > 0.0 {
        (hi - lo) / (lo * WIDTH_TOLERANCE)
    } else {
        0.0
    };
    let mut mix = 0.0;
    for (x, y) in a.material.iter().zip(&b.material) {
        mix += libm::fabsf(x - y);
    }
    // A move whose mix changes at all is laid in two pieces at least, so that each end's
    // exact mix is laid at that end (a feature's material on its keep-out curve).
    let by_mix = if mix > 0.0 {
        (0.5 * mix / MIX_TOLERANCE).fmax(2.0)
    } else {
        0.0
    };
    // Not a number (a degenerate width or mix) fails the comparison: one piece.
    let n = libm::ceilf(by_width.fmax(by_mix));
    if n >= MAX_PIECES as f32 {
        MAX_PIECES
    } else if n >= 1.0 {
        n as u32
    } else {
        1
    }
}

/// Calls `out` with the constant-width moves that lay the move from `a` to `b` (`b.deposit`
/// says whether it deposits; a travel move is one move): [`pieces`] equal pieces, each at the
/// narrowest width along it and the mix of its end nearer the move's end it lies nearer (so
/// the first piece starts with `a`'s exact mix and the last ends with `b`'s).
pub fn split(a: &Vertex, b: &Vertex, mut out: impl FnMut(Move)) {
    if !b.deposit {
        out(Move {
            from: a.at,
            to: b.at,
            width: b.width,
            material: b.material,
            deposit: false,
        });
        return;
    }
    let n = pieces(a, b);
    let at = |k: u32| -> (Point, f32, Material) {
        if k == n {
            return (b.at, b.width, b.material);
        }
        let t = k as f32 / n as f32;
        (
            a.at.lerp(b.at, t),
            a.width + (b.width - a.width) * t,
            blend(&a.material, &b.material, t),
        )
    };
    let mut prev = at(0);
    for k in 1..=n {
        let next = at(k);
        // The first half of the pieces holds the mix where each starts, the second half the
        // mix where each ends: the move's ends get exactly their vertices' mixes.
        let material = if 2 * k <= n { prev.2 } else { next.2 };
        out(Move {
            from: prev.0,
            to: next.0,
            width: prev.1.fmin(next.1),
            material,
            deposit: true,
        });
        prev = next;
    }
}

/// Calls `out` with every constant-width move of a path (see [`split`]); the first vertex is
/// reached by travel and yields no move.
pub fn path_moves(path: &[Vertex], mut out: impl FnMut(Move)) {
    for w in path.windows(2) {
        split(&w[0], &w[1], &mut out);
    }
}
