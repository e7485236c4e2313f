//! Capacities and defaults, in one place.
//!
//! Every buffer of the core is fixed-capacity; its size is one of the constants below. Exceeding
//! one is an [`Error`](crate::Error) naming the limit ([`Error::Capacity`](crate::Error::Capacity)
//! with its [`Limit`](crate::Limit), or [`Error::SliceTooLarge`](crate::Error::SliceTooLarge)
//! for the grids), never a panic and never a silently truncated plan.
//!
//! ## Three sets of capacities, one plan
//!
//! The default sizes are the MCU build's: the whole [`Planner`](crate::Planner) is about
//! 270 KiB and is meant to live in a `static`, the offset spiral's working memory 97 KiB, a
//! [`Slice`](crate::Slice) 30 KiB; one layer's path buffer ([`PATH_VERTICES`]), where a
//! firmware keeps one, another 224 KiB. They hold 8 hollow features of up to 256 vertices in
//! about 75 x 75 mm at 0.4 mm roads. The QEMU firmware links in the 640 KiB of
//! `firmware/memory.x` (its bench needs 449 KiB with its stack, the link firmware 481 KiB),
//! while the BTT SKR 2's STM32F407 that the top-level `memory.x` describes has 192 KiB (128
//! KiB SRAM and 64 KiB CCM), a budget the core's working memory does not meet yet.
//!
//! The cargo feature `compact` (the SKR 2 image, `boards/skr2`, enables it) selects board
//! capacities: 4 hollow features of up to 192 vertices, 5 120 grid nodes, 192 MCL halves of
//! 12 points on average, 2 560 offset-spiral contour points, streamlines of 512 points. The
//! `Planner` is then 71 KiB, the offset spiral 29 KiB, a `Slice` 13 KiB, the link firmware's
//! whole application 112 KiB: with the link's session, the step side and a 40 KiB stack the
//! image takes 184 KiB of the STM32F407's 192 KiB (`host-sim/tests/mcu.rs` reads it from the
//! ELF). That holds the
//! reference slices at 1.0 mm roads (the same shapes 10-14 mm across at 0.4 mm roads), and
//! refuses larger slices with the capacity error naming what to change; where both builds
//! accept a slice the plans are the same bits. Until planning runs cell by cell, that is
//! the largest slice the F407 plans.
//!
//! The cargo feature `large` (host-sim enables it; the firmware does not) selects real-size
//! capacities: 64 hollow features of up to 4096 vertices, and a field grid of 65 536 nodes
//! (about 150 x 150 mm at 0.4 mm roads). The whole `Planner` is then about 3.6 MiB, the
//! offset spiral's working memory 1 MiB and a [`Slice`](crate::Slice) 3.3 MiB: keep them on
//! the heap, and build and run them on a thread with a large stack (host-sim's
//! `run_on_large_stack`), as the layers' working sets are on the stack too.
//!
//! The capacities only decide whether a slice is accepted: everything that shapes a plan (the
//! grid spacings, [`GRID_SPACING_NODES`], the per-polyline point budgets [`HALF_POINTS`] and
//! [`BISECTOR_POINTS`] that the simplification tolerances are searched against) is the same in
//! every set, so a slice two builds accept gets bit-identical plans (`host-sim/tests/mcu.rs`).
//!
//! RAM per unit of capacity (bytes; the `large` figures in brackets):
//!
//! | unit | where | bytes |
//! |------|-------|-------|
//! | hollow feature | `Slice` (vertices, arc lengths, chunk boxes) | 13 per vertex (3.3 KiB [52 KiB]) |
//! | feature's keep-out curve | a view of the feature | 24 (40 on a 64-bit host) |
//! | field grid node | `Planner` (label, `u`; lent to the offset spiral's distances and marks once the MCLs are traced) | 5 (80 KiB [320 KiB]) |
//! | boundary node | `Planner` | 8 (24 KiB [256 KiB]) |
//! | offset-spiral contour point | `OffsetSpiral` (point; a 16th of a run's box and of its first point's arc length) | 9.25 (74 KiB [592 KiB]) |
//! | MCL half | `Planner` (40, and 8 a point in the pool of [`HALF_POOL_POINTS`], 20 a half) | 200 (125 KiB [3.1 MiB]) |
//!
//! `tests/capacity.rs` in host-sim prints how full each buffer gets on the reference slices,
//! and the sizes of the working sets.

/// Whether the real-size capacities of the cargo feature `large` are compiled in.
pub const LARGE: bool = cfg!(feature = "large");
/// Whether the board capacities of the cargo feature `compact` are compiled in: what fits an
/// STM32F407's 192 KiB beside the link, the motion queue and the stack (`boards/skr2`).
pub const COMPACT: bool = cfg!(feature = "compact");

#[cfg(all(feature = "large", feature = "compact"))]
compile_error!(
    "the cargo features `large` (the host's real-size capacities) and `compact` (a board's) \
     choose different capacities: enable one of them"
);

/// A capacity in each build: `large`, the default (the QEMU firmware's), `compact`.
const fn by_build(large: usize, default: usize, compact: usize) -> usize {
    if LARGE {
        large
    } else if COMPACT {
        compact
    } else {
        default
    }
}

/// Most hollow features in one slice (8; 64 with `large`).
pub const MAX_HOLES: usize = by_build(64, 8, 4);
/// Most vertices of one polygon, the wall or a hollow feature (256; 4096 with `large`).
pub const MAX_VERTICES: usize = by_build(4_096, 256, 192);
/// Material channels (reservoirs / valves) per composition.
pub const CHANNELS: usize = 4;
/// Contours with more distinct vertices than this are simplified within the slice's
/// `simplify_tolerance` ([`Slice::from_contours`](crate::Slice::from_contours)); contours with
/// fewer are kept exactly as given. A rule constant, the same in every build (not a capacity),
/// so both builds store the same polygons.
pub const SIMPLIFY_ABOVE_VERTICES: usize = 256;
/// Largest absolute coordinate accepted, in millimetres.
pub const MAX_COORD_MM: f32 = 1000.0;
/// Largest road width accepted, in millimetres.
pub const MAX_ROAD_WIDTH_MM: f32 = 10.0;
/// Smallest road width accepted, in millimetres (finer than any extrusion nozzle).
pub const MIN_ROAD_WIDTH_MM: f32 = 0.01;
/// Most relaxation sweeps a slice may ask for.
pub const MAX_RELAX_ITERATIONS: u8 = 64;

/// Nodes of the grid that carries the cell labels and the harmonic field (16 384; 65 536
/// with `large`). Also the capacity of the offset spiral's distance grid.
pub const GRID_NODES: usize = by_build(65_536, 16_384, 5_120);
/// Grid nodes next to a boundary, the Shortley-Weller table (3072; 32 768 with `large`).
pub const BOUNDARY_NODES: usize = by_build(32_768, 3_072, 640);
/// Preferred grid spacing as a fraction of the road width.
pub const GRID_SPACING_PER_ROAD: f32 = 0.6;
/// The spacing rule's node budget, the same in every build (not a capacity): from the
/// preferred spacing, a grid is coarsened in steps of 3 % while it has more nodes than this,
/// up to [`MAX_GRID_SPACING_PER_ROAD`]. A grid that then has more nodes than its capacity
/// ([`GRID_NODES`]) is refused.
pub const GRID_SPACING_NODES: usize = 16_384;
/// The coarsest grid spacing, as a multiple of the road width: coarser would not resolve the
/// cells (at this spacing [`GRID_NODES`] cover about 75 x 75 mm at 0.4 mm roads; 150 x 150
/// mm with `large`).
pub const MAX_GRID_SPACING_PER_ROAD: f32 = 1.5;
/// Most Gauss-Seidel/SOR sweeps of the field solve.
pub const FIELD_MAX_SWEEPS: u32 = 4_000;
/// The field solve stops when no node moves more than this in a sweep.
pub const FIELD_TOLERANCE: f32 = 2.0e-6;
/// Over-relaxation factor of the field solve.
pub const FIELD_OMEGA: f32 = 1.9;

/// Most bisector pieces (one per adjacent pair of cells, more where the wall splits one).
pub const MAX_BISECTORS: usize = by_build(256, 20, 8);
/// Most points of one stored bisector polyline, the same in every build: a traced bisector is
/// simplified with the finest tolerance (from 2 µm, doubling) that fits it, so this shapes
/// the plan.
pub const BISECTOR_POINTS: usize = 128;
/// Most branch points.
pub const MAX_BRANCH_POINTS: usize = by_build(512, 48, 16);
/// Grid edges where two cells meet, used as seeds for tracing bisectors.
pub const BISECTOR_SEEDS: usize = by_build(16_384, 2_048, 768);

/// Most MCL halves (feature to cell boundary) traced in one slice.
pub const MAX_HALVES: usize = by_build(16_384, 640, 192);
/// Most points of one traced half after simplification, the same in every build: a half is
/// simplified with the finest tolerance (from 0.5 % of a road, doubling) that fits it, so this
/// shapes the plan.
pub const HALF_POINTS: usize = 24;
/// Points of all the MCL halves of one plan together (12 800; 327 680 with `large`): 20 a
/// half on average. Measured points per traced half: 5-14 on the reference slices; on 200
/// random slices (host-sim's `random_slice`, seeds 1..) median 9.5, p90 15.2, max 18.4.
pub const HALF_POOL_POINTS: usize = by_build(20, 20, 12) * MAX_HALVES;
/// Most points of one output MCL (a matched pair is two halves).
pub const MCL_POINTS: usize = 2 * HALF_POINTS;
/// Most MCLs in a plan.
pub const MAX_MCLS: usize = by_build(8_192, 512, 160);
/// Raw streamline points before simplification.
pub const TRACE_POINTS: usize = by_build(4_096, 1_024, 512);
/// How often the MCL density may be doubled where MCLs diverge. The least start gaps
/// (`mcl::insert`) are what bind: at the default [`mcl_spacing`](crate::Settings::mcl_spacing)
/// and `min_width` a strong fan's halves reach theirs (a tenth of the narrowest road) after
/// five halvings, regular halves after one; the sixth serves a coarser `mcl_spacing` (up to
/// 1.6 roads).
pub const MAX_REFINE_DEPTH: u32 = 6;

/// Points of all the offset spiral's traced loops together
/// ([`OffsetSpiral`](crate::toolpath::offset::OffsetSpiral)).
pub const CONTOUR_POINTS: usize = by_build(65_535, 8_192, 2_560);
/// Most loops of one offset-spiral layer.
pub const MAX_LOOPS: usize = by_build(4_096, 256, 64);
/// Most pairs of loops running side by side (and joins) in one offset-spiral layer.
pub const MAX_SITES: usize = by_build(8_192, 512, 128);

/// Vertices of one layer's path in the firmware's buffer (a host sink may hold more).
pub const PATH_VERTICES: usize = 8_192;

// The core stores indices in narrow integers; every `as u8` / `as u16` cast of an index is
// bounded by one of these (a capacity too large for its index type does not compile):
// hole indices (`FeatureId::Hole`, `Half::hole`, `Mcl::from`, `Bisector::a`) are `u8`, and a
// field label holds a hole index below `field::KEEP_OUT` (0x40) with the wall's curve after them;
const _: () = assert!(MAX_HOLES <= 64);
// vertex and edge indices in errors are `u16`;
const _: () = assert!(MAX_VERTICES <= u16::MAX as usize);
// half and MCL indices are `u16`, with `u16::MAX` spare as "none";
const _: () = assert!(MAX_HALVES < u16::MAX as usize);
const _: () = assert!(MAX_MCLS < u16::MAX as usize);
// the bisector a half ends on (`Half::on_bisector`) is a `u8`;
const _: () = assert!(MAX_BISECTORS <= u8::MAX as usize + 1);
// offset-spiral loop and site indices are `u16`, with `u16::MAX` spare as "none";
const _: () = assert!(MAX_LOOPS < u16::MAX as usize);
const _: () = assert!(MAX_SITES < u16::MAX as usize);
// material channels are `u8`.
const _: () = assert!(CHANNELS <= u8::MAX as usize);

/// Default settings (see [`Settings`](crate::Settings)).
pub mod defaults {
    /// Deposited road width, mm.
    pub const ROAD_WIDTH: f32 = 0.4;
    /// Layer height, mm.
    pub const LAYER_HEIGHT: f32 = 0.3;
    /// Contour simplification tolerance, mm (at most a tenth of the road width).
    pub const SIMPLIFY_TOLERANCE: f32 = 0.005;
    /// Weight `w_n` of the normal term of the matching objective (2.1).
    pub const W_N: f32 = 1.0;
    /// Weight `w_d` of the distance term of the matching objective (2.1).
    pub const W_D: f32 = 1.0;
    /// Proximity bound `delta` of Algorithm I, as a multiple of the road width.
    pub const DELTA_PER_ROAD: f32 = 2.0;
    /// Relaxation sweeps (section 2.2).
    pub const RELAX_ITERATIONS: u8 = 8;
    /// Spacing between MCLs along a feature, as a multiple of the road width.
    pub const MCL_SPACING_PER_ROAD: f32 = 1.0;
    /// The least distance between MCL ends after relaxation, as a multiple of the road width.
    /// Ends this close still carry a road each (the zigzag narrows its roads to their band,
    /// down to [`MIN_WIDTH_PER_ROAD`]); at a whole road width the relaxation thinned out
    /// (removed) one MCL in fifteen on the random bench's worst slices, each leaving a band
    /// twice as wide as its neighbours'. Measured on the random bench's 200 slices (zigzags
    /// meeting the bar): 1.0, 137; 0.85, 163; 0.75, 168; 0.65, 168; 0.5, 165 (16 sweeps
    /// instead of 8 at 0.75: 165; at 1.0, fewer on the first 40 slices, 25 against 27).
    pub const RELAX_SPACING_PER_ROAD: f32 = 0.75;
    /// The narrowest road, as a multiple of the road width.
    pub const MIN_WIDTH_PER_ROAD: f32 = 0.5;
    /// The widest road, as a multiple of the road width.
    pub const MAX_WIDTH_PER_ROAD: f32 = 1.6;
}
