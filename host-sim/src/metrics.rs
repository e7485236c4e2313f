//! Measuring a toolpath layer as a printer lays it (`DESIGN.md`, "Measuring a toolpath").
//!
//! The deposition model: a printer executes each G-code move at one extrusion rate, so a move
//! lays one width along its whole length, and its nozzle is round, so the move deposits every
//! point within half that width of its segment (round caps and joins). A layer's path is first
//! split into such constant-width moves ([`planned_moves`], the same split the G-code exporter
//! writes: no move's width differs from the road's by more than 5 %), and the moves are
//! deposited onto a [`Raster`] of the slice (0.025 mm cells by default). G-code read back
//! ([`crate::gcode::printed_moves`]) is measured by the same [`Meter::measure_moves`], so the
//! figures of a layer and of its exported G-code agree. The layer is scored by what the moves
//! cover:
//!
//! - `starts`: extrusion starts (a travel move followed by a depositing move; the first vertex
//!   of a layer is reached by travel, so a path that deposits at once starts there);
//! - `travel_mm` / `extruded_mm`: lengths of the travel and depositing moves;
//! - `coverage`: share of the printable region's cells covered at least once;
//! - `overfill`: cells of the material region (inside the wall, outside the holes) covered two
//!   or more times, over the printable region's cell count. A road (a maximal run of depositing
//!   moves) counts a cell once while it moves on along itself, and again only where it comes
//!   back to the cell after moving on more than one road width along itself (a hairpin, the
//!   next spiral turn, a crossing), as two roads would; another road counts again anywhere
//!   ([`Options::revisit`]; [`Revisit::Once`] counts each cell once per road instead, which
//!   makes a single-start layer's overfill zero by construction);
//! - `spill`: cells inside a hollow feature or outside the wall covered at least once, over the
//!   printable region's cell count;
//! - `composition_error`: the mean, over deposited printable cells, of half the L1 distance
//!   between the deposited composition and the blended field at the cell centre. A cell's
//!   deposited composition is the mix of the nearest move (one mix per move, as `M165` sets
//!   it). The field is sampled on every [`Options::composition_stride`]-th cell in each
//!   direction (0.1 mm by default), because a blended field is costly to evaluate; cells where
//!   it is `None` are skipped;
//! - `feature_composition_error`: the largest half-L1 deviation between the mix of a
//!   depositing move starting or ending on a feature's keep-out curve (half a road width from the feature, within
//!   [`Options::keep_out_tol`]) and that feature's material. Where features are closer than
//!   a road their keep-out bands overlap: a point on one's curve within another's band (on
//!   both curves, or inside the other's) can hold only one material, and deviates by the
//!   smaller of theirs.

use std::ops::Range;

use hollowpath::config::CHANNELS;
use hollowpath::geometry::{polygon, Point};
use hollowpath::toolpath::moves::{path_moves, Move};
use hollowpath::toolpath::{Pattern, Vertex};
use hollowpath::{Material, Slice};
use serde::Serialize;

pub use crate::raster::Revisit;
use crate::raster::{Hit, Raster, Region};

/// The raster cell size of [`measure`], mm.
pub const CELL_MM: f32 = 0.025;
/// Cells between composition samples, in each direction, for [`measure`].
pub const COMPOSITION_STRIDE: usize = 4;
/// How near half a road width from a feature a vertex must be to lie on its keep-out curve, mm.
pub const KEEP_OUT_TOL: f32 = 1e-3;

/// How finely to measure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// Raster cell size, mm.
    pub cell: f32,
    /// The composition error samples every `composition_stride`-th cell in x and in y (1: all).
    pub composition_stride: usize,
    /// Tolerance of "on a feature's keep-out curve", mm.
    pub keep_out_tol: f32,
    /// How a road that comes back over a cell it had left counts there (default
    /// [`Revisit::Again`]: as overfill).
    pub revisit: Revisit,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            cell: CELL_MM,
            composition_stride: COMPOSITION_STRIDE,
            keep_out_tol: KEEP_OUT_TOL,
            revisit: Revisit::Again,
        }
    }
}

impl Options {
    /// The default options with cells of `cell` mm.
    pub fn with_cell(cell: f32) -> Options {
        Options {
            cell,
            ..Options::default()
        }
    }
}

/// The measures of one layer (see the module documentation).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LayerMetrics {
    /// The layer's pattern name.
    pub pattern: String,
    /// Extrusion starts (valve openings).
    pub starts: u32,
    /// Length moved without depositing, mm.
    pub travel_mm: f64,
    /// Length moved depositing, mm.
    pub extruded_mm: f64,
    /// Share of the printable region covered at least once.
    pub coverage: f64,
    /// Material-region area covered two or more times, over the printable region's area.
    pub overfill: f64,
    /// Area covered inside hollow features or outside the wall, over the printable region's
    /// area.
    pub spill: f64,
    /// Mean half-L1 distance between deposited composition and the blended field.
    pub composition_error: f64,
    /// Largest half-L1 deviation from a feature's material on its keep-out curve.
    pub feature_composition_error: f64,
}

/// The roads of a path: each a range of vertex indices, from the vertex the road starts at
/// (reached by travel) to its last vertex, over a maximal run of depositing moves. The first
/// vertex is reached by travel whatever its `deposit` flag says.
pub fn road_runs(path: &[Vertex]) -> Vec<Range<usize>> {
    let mut runs = Vec::new();
    let mut k = 1;
    while k < path.len() {
        if !path[k].deposit {
            k += 1;
            continue;
        }
        let start = k - 1;
        while k < path.len() && path[k].deposit {
            k += 1;
        }
        runs.push(start..k);
    }
    runs
}

/// Half the L1 distance between two compositions (0: equal, 1: disjoint).
pub fn half_l1(a: &Material, b: &Material) -> f64 {
    0.5 * a
        .iter()
        .zip(b)
        .map(|(x, y)| (*x as f64 - *y as f64).abs())
        .sum::<f64>()
}

/// Length of segment `ab` in f64.
fn length(a: Point, b: Point) -> f64 {
    (b.x as f64 - a.x as f64).hypot(b.y as f64 - a.y as f64)
}

/// A slice's raster, kept to measure many layers of the same slice.
pub struct Meter<'s> {
    slice: &'s Slice,
    options: Options,
    raster: Raster,
    printable: usize,
    /// Composition samples: (squared distance to the nearest road, its composition there).
    samples: Vec<(f32, Material)>,
    sx: usize,
}

impl<'s> Meter<'s> {
    /// Rasterises `slice` for measuring.
    pub fn new(slice: &'s Slice, options: Options) -> Meter<'s> {
        let raster = Raster::new(slice, options.cell);
        let printable = raster.printable_cells();
        let s = options.composition_stride.max(1);
        let sx = raster.nx.div_ceil(s);
        let sy = raster.ny.div_ceil(s);
        Meter {
            slice,
            options,
            printable,
            samples: vec![(f32::INFINITY, [0.0; CHANNELS]); sx * sy],
            sx,
            raster,
        }
    }

    /// The raster (with the counts of the last layer measured).
    pub fn raster(&self) -> &Raster {
        &self.raster
    }

    /// Area of the printable region as rasterised, mm^2.
    pub fn printable_area(&self) -> f64 {
        self.printable as f64 * (self.options.cell as f64).powi(2)
    }

    /// Measures one layer's path as a printer lays it: its moves split to constant width
    /// ([`planned_moves`]); `field` gives the blended composition wanted at a point.
    pub fn measure(
        &mut self,
        pattern: Pattern,
        path: &[Vertex],
        field: &dyn Fn(Point) -> Option<Material>,
    ) -> LayerMetrics {
        self.measure_moves(pattern, &planned_moves(path), field)
    }

    /// Measures one layer's moves, each deposited at its one width (the capsule of half the
    /// width around it) and its one composition.
    pub fn measure_moves(
        &mut self,
        pattern: Pattern,
        moves: &[Move],
        field: &dyn Fn(Point) -> Option<Material>,
    ) -> LayerMetrics {
        let slice = self.slice;
        let stride = self.options.composition_stride.max(1);
        let sx = self.sx;
        self.raster.clear();
        self.samples.fill((f32::INFINITY, [0.0; CHANNELS]));

        let mut starts = 0u32;
        let mut travel_mm = 0.0;
        let mut extruded_mm = 0.0;
        let mut depositing = false;
        for m in moves {
            let len = length(m.from, m.to);
            if !m.deposit {
                travel_mm += len;
                depositing = false;
                continue;
            }
            if !depositing {
                starts += 1;
                self.raster.begin_stroke(self.options.revisit);
                depositing = true;
            }
            extruded_mm += len;
            let samples = &mut self.samples;
            let r = 0.5 * m.width;
            self.raster.stamp_segment(m.from, m.to, r, r, |h: Hit| {
                if h.region != Region::Printable || h.i % stride != 0 || h.j % stride != 0 {
                    return;
                }
                let s = &mut samples[(h.j / stride) * sx + h.i / stride];
                if h.d2 < s.0 {
                    *s = (h.d2, m.material);
                }
            });
        }

        let (mut covered, mut twice, mut spilt) = (0usize, 0usize, 0usize);
        for (&region, &count) in self.raster.region.iter().zip(&self.raster.count) {
            match region {
                Region::Printable => {
                    covered += usize::from(count >= 1);
                    twice += usize::from(count >= 2);
                }
                Region::Margin => twice += usize::from(count >= 2),
                Region::Void => spilt += usize::from(count >= 1),
            }
        }
        spilt += self.raster.outside_cells();
        let region = self.printable.max(1) as f64;

        let (mut err, mut sampled) = (0.0, 0usize);
        for (q, (d2, m)) in self.samples.iter().enumerate() {
            if !d2.is_finite() {
                continue;
            }
            let p = self.raster.centre((q % sx) * stride, (q / sx) * stride);
            if let Some(f) = field(p) {
                err += half_l1(m, &f);
                sampled += 1;
            }
        }

        LayerMetrics {
            pattern: pattern.name().to_string(),
            starts,
            travel_mm,
            extruded_mm,
            coverage: covered as f64 / region,
            overfill: twice as f64 / region,
            spill: spilt as f64 / region,
            composition_error: if sampled > 0 {
                err / sampled as f64
            } else {
                0.0
            },
            feature_composition_error: feature_error(slice, moves, self.options.keep_out_tol),
        }
    }
}

/// The moves a printer lays for `path`: each move split into pieces of constant width
/// ([`hollowpath::toolpath::moves::split`]), as the G-code exporter writes them.
pub fn planned_moves(path: &[Vertex]) -> Vec<Move> {
    let mut moves = Vec::with_capacity(path.len() + path.len() / 4);
    path_moves(path, |m| moves.push(m));
    moves
}

/// The largest half-L1 deviation between the mix laid where a depositing move starts or ends
/// on a feature's keep-out curve and that feature's material (or, within another feature's
/// keep-out band too, either material: the smaller deviation).
fn feature_error(slice: &Slice, moves: &[Move], tol: f32) -> f64 {
    let half = 0.5 * slice.settings().road_width;
    let mut worst = 0.0f64;
    for (k, m) in moves.iter().enumerate() {
        let deposited = m.deposit || moves.get(k + 1).is_some_and(|next| next.deposit);
        if !deposited {
            continue;
        }
        let ends = if m.deposit {
            &[m.from, m.to][..]
        } else {
            &[m.to][..]
        };
        let mix = if m.deposit {
            m.material
        } else {
            // The mix laid at a road's start is its first move's.
            moves[k + 1].material
        };
        for &p in ends {
            // Judged where `p` lies on a feature's keep-out curve, against the material of
            // each feature it lies on the curve of or within: where features are closer than
            // a road their bands overlap, a road through the pinch touches both, and a point
            // there can hold only one material: the smallest deviation from theirs counts.
            let (mut on_curve, mut here) = (false, f64::INFINITY);
            let mut judge = |d: f32, material: &Material| {
                on_curve |= (d - half).abs() < tol;
                if d < half + tol {
                    here = here.min(half_l1(&mix, material));
                }
            };
            for h in slice.holes() {
                if polygon::bbox_distance(h.bbox(), p) > half + tol {
                    continue;
                }
                judge(h.signed_distance(p), &h.material());
            }
            judge(slice.wall_clearance(p), &slice.wall().material());
            if on_curve {
                worst = worst.max(here);
            }
        }
    }
    worst
}

/// Measures one layer of `slice` on a 0.025 mm raster ([`Options::default`]).
pub fn measure(
    slice: &Slice,
    pattern: Pattern,
    path: &[Vertex],
    field: &dyn Fn(Point) -> Option<Material>,
) -> LayerMetrics {
    measure_with(slice, pattern, path, field, &Options::default())
}

/// [`measure`] with other options (a coarser raster for quick checks, say).
pub fn measure_with(
    slice: &Slice,
    pattern: Pattern,
    path: &[Vertex],
    field: &dyn Fn(Point) -> Option<Material>,
    options: &Options,
) -> LayerMetrics {
    Meter::new(slice, *options).measure(pattern, path, field)
}

/// Why a layer's road starts again: one per extrusion start after the first
/// ([`explain_starts`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StartNote {
    /// Where the road starts again, mm.
    pub at: [f32; 2],
    /// The travel that leads there, mm.
    pub travel_mm: f64,
    /// Why, in the lab's terms.
    pub why: String,
}

/// Explains every extrusion start of `path` after the first, in `metrics.json`: a break
/// shorter than two road widths is a move that could not be laid (its straight line crosses a
/// feature, or a pinch narrower than `min_width`, measured across at the narrowest point of
/// the break, or a move that did not fit at its width and was left out); a longer travel reaches a separate piece, for the layer's reason `note` (the
/// generator's account of its pieces and jumps).
pub fn explain_starts(slice: &Slice, path: &[Vertex], note: &str) -> Vec<StartNote> {
    let s = slice.settings();
    let runs = road_runs(path);
    let mut notes = Vec::new();
    for pair in runs.windows(2) {
        let (end, start) = (path[pair[0].end - 1].at, path[pair[1].start].at);
        // The travel into a road runs from the previous road's end to the road's first vertex.
        let travel: f64 = (pair[0].end..=pair[1].start)
            .map(|k| length(path[k - 1].at, path[k].at))
            .sum();
        // The narrowest room along the break (the straight line the road would have taken).
        let clearance = |p: Point| slice.wall_clearance(p).min(slice.nearest_holes(p).1);
        let steps = ((end.dist(start) / (0.25 * s.road_width)).ceil() as usize).max(1);
        let (mid, room) = (0..=steps)
            .map(|k| {
                let p = end.lerp(start, k as f32 / steps as f32);
                (p, clearance(p))
            })
            .fold((end, f32::INFINITY), |a, b| if b.1 < a.1 { b } else { a });
        let across = 2.0 * room;
        let why = if travel <= 2.0 * s.road_width as f64 {
            if room < 0.0 {
                format!(
                    "the road's straight line crosses a feature at ({:.2}, {:.2}) and was not \
                     bent round it",
                    mid.x, mid.y
                )
            } else if across < s.min_width {
                format!(
                    "a pinch {across:.3} mm across at ({:.2}, {:.2}), narrower than min_width \
                     {:.3} mm: no road fits there",
                    mid.x, mid.y, s.min_width
                )
            } else {
                format!(
                    "a move at ({:.2}, {:.2}) did not fit at its width ({across:.3} mm across) \
                     and was left out",
                    mid.x, mid.y
                )
            }
        } else {
            format!("a separate piece, reached by travel: {note}")
        };
        notes.push(StartNote {
            at: [start.x, start.y],
            travel_mm: travel,
            why,
        });
    }
    notes
}
