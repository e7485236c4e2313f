//! Capacities and defaults, in one place.
//!
//! Every buffer of the core is fixed-capacity; its size is one of the constants below. Exceeding
//! one is an [`Error::Capacity`](crate::Error::Capacity) naming the [`Limit`](crate::Limit), never
//! a panic and never a silently truncated plan.
//!
//! The sizes fit an STM32L4R5-class Cortex-M4F controller (2 MiB flash, 640 KiB RAM; the
//! firmware's `memory.x` clips QEMU's memory to that): the whole [`Planner`](crate::Planner)
//! is about 290 KiB and is meant to live in a `static`; one layer's path buffer
//! ([`PATH_VERTICES`]) another 224 KiB. `tests/capacity.rs` in host-sim prints
//! how full each buffer gets on the reference slices.

/// Most hollow features in one slice.
pub const MAX_HOLES: usize = 8;
/// Most vertices of one polygon (the wall or a hollow feature).
pub const MAX_VERTICES: usize = 256;
/// Material channels (reservoirs / valves) per composition.
pub const CHANNELS: usize = 4;
/// Largest absolute coordinate accepted, in millimetres.
pub const MAX_COORD_MM: f32 = 1000.0;
/// Largest road width accepted, in millimetres.
pub const MAX_ROAD_WIDTH_MM: f32 = 10.0;
/// Smallest road width accepted, in millimetres (finer than any extrusion nozzle).
pub const MIN_ROAD_WIDTH_MM: f32 = 0.01;
/// Most relaxation sweeps a slice may ask for.
pub const MAX_RELAX_ITERATIONS: u8 = 64;

/// Nodes of the grid that carries the cell labels and the harmonic field.
pub const GRID_NODES: usize = 16_384;
/// Grid nodes next to a boundary (the Shortley-Weller table).
pub const BOUNDARY_NODES: usize = 3_072;
/// Preferred grid spacing as a fraction of the road width (coarsened to fit [`GRID_NODES`]).
pub const GRID_SPACING_PER_ROAD: f32 = 0.6;
/// The coarsest grid accepted, as a multiple of the road width: a slice that would need a
/// coarser grid to fit [`GRID_NODES`] is refused (about 75 x 75 mm at 0.4 mm roads).
pub const MAX_GRID_SPACING_PER_ROAD: f32 = 1.5;
/// Most Gauss-Seidel/SOR sweeps of the field solve.
pub const FIELD_MAX_SWEEPS: u32 = 4_000;
/// The field solve stops when no node moves more than this in a sweep.
pub const FIELD_TOLERANCE: f32 = 2.0e-6;
/// Over-relaxation factor of the field solve.
pub const FIELD_OMEGA: f32 = 1.9;

/// Most bisector pieces (one per adjacent pair of cells, more where the wall splits one).
pub const MAX_BISECTORS: usize = 20;
/// Most points of one stored bisector polyline.
pub const BISECTOR_POINTS: usize = 128;
/// Most branch points.
pub const MAX_BRANCH_POINTS: usize = 48;
/// Grid edges where two cells meet, used as seeds for tracing bisectors.
pub const BISECTOR_SEEDS: usize = 2_048;

/// Most MCL halves (feature to cell boundary) traced in one slice.
pub const MAX_HALVES: usize = 640;
/// Most points of one traced half after simplification.
pub const HALF_POINTS: usize = 24;
/// Most points of one output MCL (a matched pair is two halves).
pub const MCL_POINTS: usize = 2 * HALF_POINTS;
/// Most MCLs in a plan.
pub const MAX_MCLS: usize = 512;
/// Raw streamline points before simplification.
pub const TRACE_POINTS: usize = 1_024;
/// How often the MCL density may be doubled where MCLs diverge.
pub const MAX_REFINE_DEPTH: u32 = 3;

/// Points of all the offset spiral's traced loops together
/// ([`OffsetSpiral`](crate::toolpath::offset::OffsetSpiral)).
pub const CONTOUR_POINTS: usize = 8_192;
/// Most loops of one offset-spiral layer.
pub const MAX_LOOPS: usize = 256;
/// Most pairs of loops running side by side (and joins) in one offset-spiral layer.
pub const MAX_SITES: usize = 512;

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
    /// The narrowest road, as a multiple of the road width.
    pub const MIN_WIDTH_PER_ROAD: f32 = 0.5;
    /// The widest road, as a multiple of the road width.
    pub const MAX_WIDTH_PER_ROAD: f32 = 1.6;
}
