//! # hollowpath: continuous multi-material toolpaths for scaffolds with hollow features
//!
//! This is the `no_std` core that runs on the printer's Cortex-M4F. It implements, and goes
//! beyond, Ozbolat & Koc, *A continuous multi-material toolpath planning for tissue scaffolds
//! with hollowed features* (2011). It has no allocator: every buffer is fixed-capacity, sized
//! in [`config`], and a full buffer is an [`Error::Capacity`] naming the [`Limit`]. Nothing here
//! reads a clock, a global or a peripheral, and all math goes through `libm` (square roots
//! through `hollowpath_fpu::sqrtf`: the FPU's correctly rounded instruction on the Cortex-M4F,
//! libm's elsewhere, the same bits; the smaller and larger of two numbers through
//! [`geometry::primitives::fmin`]/[`fmax`](geometry::primitives::fmax), comparisons inline,
//! because the M4F has no `VMINNM` and `f32::min` there is a call), so the host and the MCU
//! compute bit-identical plans ([`Plan::digest`]).
//!
//! ## The data's journey
//!
//! ```text
//! slice ──► field + cells ──► MCLs: insert ──► match (Algorithm I) ──► relax ──► Plan
//!                                                                      │
//!                 layers of Vertex (position, composition, road width) ◄┘ toolpath
//!                                      │ moves
//!        blocks ─► look-ahead ─► segments ─► step/dir edges + valve duties    motion
//! ```
//!
//! * [`slice`](mod@slice): the validated [`Slice`] (wall, hollow features, materials, [`Settings`]).
//!   [`Slice::new`] refuses every invalid slice with an [`Error`] that names the feature and
//!   the reason; nothing downstream re-checks.
//! * [`field`]: one grid over the slice. Each node is labelled by the Voronoi cell of the
//!   hollow feature nearest to it, or as keep-out (within half a road width of a feature or the
//!   wall, where no road centre may go). In every cell a harmonic field `u` runs from 0 on the
//!   feature to 1 on the cell boundary.
//! * [`cells`]: the [`Bisector`](cells::Bisector)s where two cells meet, traced exactly on
//!   `d_i = d_j` from the grid's seeds, and the branch points where three cells meet or a
//!   bisector meets the wall.
//! * [`mcl`]: material changing lines. [`mcl::insert`] traces *halves* along the gradient of
//!   `u` from each feature to its cell boundary (they cannot cross, and they bend into concave
//!   pockets). [`mcl::matching`] is Algorithm I: objective (2.1), greedy order, bound `delta`,
//!   weighted point `p*` (2.3), unmatched halves removed. [`mcl::relax`] spreads the ends that
//!   crowd near branch points (section 2.2).
//! * [`verify`]: the properties every plan must have, checked from the slice and the plan
//!   alone.
//! * [`plan`]: the [`Planner`] that runs the journey with its working memory inline, and the
//!   resulting [`Plan`].
//! * [`toolpath`]: the layers drawn from a plan, vertex by vertex into a
//!   [`PathSink`](toolpath::PathSink): the zigzag along the MCLs, the spirals across them (the
//!   paper's, and the offset spiral with turns a road width apart), the raster baseline. Every
//!   vertex carries its composition (blended along the MCLs) and its road width: a layer
//!   widens or narrows its roads, within [`Settings::min_width`] .. [`Settings::max_width`], so
//!   that neighbouring roads meet without gap or overlap where MCLs fan out or turns leave a
//!   sliver, and never wider than twice the clearance from the features. The default
//!   layers pass through [`Despike`](toolpath::despike::Despike), which drops a vertex where
//!   the road would run a fraction of a road past and straight back (a dead stop for a
//!   printer); then through [`Lining`](toolpath::lining::Lining), which lays every
//!   stretch of road nearer a feature than its keep-out curve (and a hair beyond) in that
//!   feature's material, so each channel is lined with its own.
//!
//! * [`motion`]: a layer's moves on the printer. Blocks in whole steps (absolute targets,
//!   so a path moves exactly its displacement) enter a look-ahead ring that replans corner
//!   speeds (junction deviation) and trapezoids as they arrive; the trapezoids are cut into
//!   ~1 ms constant-rate segments that a small integer Bresenham routine, called from the
//!   step timer's interrupt, turns into step and direction edges through `embedded-hal`
//!   pins. The same segments carry the flow each valve channel must deliver (road width x
//!   layer height x actual speed, split by the composition), turned into PWM duty through
//!   the channel's calibration curve and commanded ahead of the motion by the valve's dead
//!   time with its lag inverted; depositing blocks brake no faster than the valves shed
//!   flow, and a dip mid-road holds a valve at its dead band's edge rather than shutting it.
//!   The machine counts what it drove ([`Counters`](motion::machine::Counters)): the
//!   telemetry of a layer. Homing, emergency stop, pause/resume and one shutdown path
//!   sit on top, generic over a [`Board`](motion::Board) of pins and a
//!   [`StepTimer`](motion::StepTimer), so a host's virtual printer runs the same code.
//!
//! * [`link`]: the serial link to the host, with no I/O of its own (bytes and the time go
//!   in, frames come out, `poll(now)` returns the next deadline). postcard messages, one enum
//!   per direction, travel in COBS frames with a CRC-32, sequence numbers and cumulative acks;
//!   a gap is naked and a silence retransmitted (go-back-N over a small window, Klipper's
//!   scheme), so both ends deliver every message once and in order over a line that drops,
//!   corrupts, repeats or reorders. Contours go up in integer micrometres as zigzag delta
//!   varints, into a fixed-capacity slice assembler that builds the [`Slice`] (as
//!   [`Slice::from_contours`] does) only once it arrived whole, in place, into the
//!   application's [`SliceStore`](slice::SliceStore); errors go down as the core's own
//!   typed values, the ones the host prints. A watchdog reports the host gone silent, for
//!   the application to close the valves.
//!
//! Below them, [`geometry`] holds points, polygons, polylines (both on
//! [`geometry::primitives`]) and the grid; [`error`] the one error type; [`stats`] the
//! planner's counters, which the phases below the planner count into. Logging goes through the
//! private `fmt` macros: `defmt` with the `defmt` feature, nothing otherwise.
//!
//! ## Memory
//!
//! No allocator: working memory is either in the caller's statics (the [`Planner`], the
//! offset spiral, the [`SliceStore`](slice::SliceStore), the machine; on a controller all of
//! them in the application's one static) or in the frames of the phase that uses it, which
//! the phases' turns on the stack then share. Nothing large travels by value: a slice is built
//! in place, a plan and a slice are borrowed, an MCL's points are read where they lie
//! ([`Plan::points_iter`]). What is alive at once is kept small:
//!
//! * the field's node memory ([`GridMemory`](field::GridMemory), 80 KiB on a controller) is
//!   lent to the offset spiral once the MCLs are traced ([`Planner::plan_and_grid`]): the
//!   spiral's distance grid is the same memory, never a second grid;
//! * the MCL halves keep their points in one pool ([`mcl::Halves`]), a half taking the points
//!   it has, not room for the most a half may have;
//! * the keep-out curves are views of their features (the arc lengths are the feature's), and
//!   the offset spiral keeps one arc length per run of 16 loop points, not one per point;
//! * the phases' larger working sets (the bisector seeds, matching, relaxation; the zigzag's
//!   ends, the spiral's walk) sit in frames of their own, which the phases then share on the
//!   stack instead of adding them up.
//!
//! The capacities (and so the RAM) still grow with the slice, not with its largest cell: the
//! field, the halves and the spiral's loops are the whole slice's. Planning cell by cell is
//! the next step (issue 12); the figures are in README.
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]

#[cfg(test)]
extern crate std;

#[cfg(feature = "alloc")]
extern crate alloc;

#[macro_use]
mod fmt;

pub mod app;
pub mod cells;
pub mod config;
mod digest;
pub mod error;
pub mod field;
pub mod geometry;
pub mod keep_out;
pub mod link;
pub mod mcl;
pub mod motion;
pub mod plan;
pub mod slice;
pub mod stats;
pub mod toolpath;
pub mod verify;

pub use error::{Error, FeatureId, Limit, SettingId};
/// The fixed-capacity collections the public types are made of.
pub use heapless;
pub use mcl::{Mcl, Target};
pub use plan::{Plan, Planner};
pub use slice::{Feature, Material, Settings, Slice};
pub use stats::PlanStats;
