//! The counters of one planning run ([`PlanStats`]): defined below the phases that count
//! into them (field, cells, `mcl/*`), so that none of them imports the planner above it.

/// Counters of one planning run, for the curious and for tests.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PlanStats {
    /// Grid nodes of the field.
    pub grid_nodes: u32,
    /// Grid spacing, mm.
    pub grid_h: f32,
    /// Grid nodes next to a boundary (of [`BOUNDARY_NODES`](crate::config::BOUNDARY_NODES)).
    pub boundary_nodes: u32,
    /// Sweeps of the field solve.
    pub sweeps: u32,
    /// Largest change in the last sweep.
    pub residual: f32,
    /// Halves traced.
    pub traced: u32,
    /// Points of the traced halves together, at their most (of
    /// [`HALF_POOL_POINTS`](crate::config::HALF_POOL_POINTS)).
    pub half_points: u32,
    /// Starts that gave no half (not printable, or the line did not reach the boundary).
    pub failed_traces: u32,
    /// Halves dropped because they crossed a neighbour.
    pub dropped_crossing: u32,
    /// Halves of a strong fan dropped because they ran too close to a neighbour for too long
    /// (`mcl::insert`).
    pub dropped_crowded: u32,
    /// Bisector halves whose end lay on no traced bisector piece (removed).
    pub off_bisector: u32,
    /// Matched pairs.
    pub matched_pairs: u32,
    /// Halves removed for want of a match.
    pub removed_unmatched: u32,
    /// Relaxation moves made.
    pub relax_moves: u32,
    /// Ends removed because they still crowded after relaxation.
    pub thinned: u32,
    /// MCLs removed by the final check: a segment leaving the printable region or crossing
    /// another MCL after matching and relaxation reshaped it.
    pub removed_invalid: u32,
}
