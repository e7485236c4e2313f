//! The planner: from a validated slice to matched, relaxed MCLs.

use heapless::Vec;

use crate::cells::{Bisector, Cells};
use crate::config::{MAX_HALVES, MAX_MCLS, MCL_POINTS, TRACE_POINTS};
use crate::digest::Fnv;
use crate::field::{Field, GridMemory};
use crate::geometry::{primitives, Point};
use crate::mcl::matching::joined_points;
use crate::mcl::{insert, matching, relax, HalfEnd, Halves, Mcl, Target};
use crate::{Error, Limit, Slice};

use crate::stats::PlanStats;

/// A finished plan: the MCLs, the bisectors and the branch points.
#[derive(Clone, Debug, Default)]
pub struct Plan {
    /// The halves the MCLs are made of (see [`Mcl::first`], [`Mcl::second`]).
    pub halves: Halves,
    /// The MCLs, ordered by hole and position along it.
    pub mcls: Vec<Mcl, MAX_MCLS>,
    /// The cells' bisectors and branch points.
    pub cells: Cells,
    /// Counters of the run.
    pub stats: PlanStats,
}

impl Plan {
    /// The polyline of an MCL, from its `from` hole to the wall or through `p*` to its `to`
    /// hole.
    pub fn points(&self, mcl: &Mcl) -> Vec<Point, MCL_POINTS> {
        joined_points(
            &self.halves,
            mcl.first as usize,
            mcl.second.map(|s| s as usize),
        )
    }

    /// The box around an MCL's points, from its halves' without copying them: the box of
    /// [`points`](Self::points) (which leaves out the second half's copy of the joint, the same
    /// point as the first half's end), or one that also holds that copy where it differs: a
    /// bound for every search that skips MCLs by their box.
    pub fn mcl_box(&self, mcl: &Mcl) -> (Point, Point) {
        let first = primitives::bbox(self.halves.points(mcl.first as usize));
        mcl.second.map_or(first, |s| {
            primitives::union(first, primitives::bbox(self.halves.points(s as usize)))
        })
    }

    /// The first and last points of an MCL as [`points`](Self::points) gives them, without
    /// copying it: its start on the `from` hole, and its end on the wall or the `to` hole
    /// (the second half runs from that hole to the joint, so its first point).
    pub fn mcl_ends(&self, mcl: &Mcl) -> (Point, Point) {
        let first = self.halves.points(mcl.first as usize);
        let last = match mcl.second {
            Some(s) => self.halves.points(s as usize)[0],
            None => first[first.len() - 1],
        };
        (first[0], last)
    }

    /// The points of an MCL as [`points`](Self::points) gives them, without copying them.
    pub fn points_iter(&self, mcl: &Mcl) -> impl Iterator<Item = Point> + '_ {
        let first = self.halves.points(mcl.first as usize).iter();
        let second = mcl
            .second
            .map(|s| self.halves.points(s as usize).iter().rev().skip(1));
        first.chain(second.into_iter().flatten()).copied()
    }

    /// The bisector pieces.
    pub fn bisectors(&self) -> &[Bisector] {
        &self.cells.bisectors
    }

    /// A 64-bit FNV-1a digest of every MCL (ends, points as IEEE bits), bisector and branch
    /// point: equal digests mean bit-identical plans.
    pub fn digest(&self) -> u64 {
        let mut h = Fnv::new();
        for m in self.mcls.iter() {
            h.word(m.from as u32);
            h.word(match m.to {
                Target::Wall => u32::MAX,
                Target::Hole(j) => j as u32,
            });
            for &p in self.points(m).iter() {
                h.point(p);
            }
        }
        for b in self.cells.bisectors.iter() {
            for &p in b.points.iter() {
                h.point(p);
            }
        }
        for &p in self.cells.branch_points.iter() {
            h.point(p);
        }
        h.finish()
    }
}

/// The planner with all its working memory, inline: about 290 KiB, meant for a `static` on the
/// MCU (or a `Box` on the host).
///
/// ```
/// # // The host build's capacities take megabytes: run on a large stack.
/// # std::thread::Builder::new().stack_size(256 << 20).spawn(|| {
/// # use hollowpath::{Feature, FeatureId, Planner, Settings, Slice, geometry::Point};
/// # let circle = |cx: f32, r: f32, n: usize| -> Vec<Point> {
/// #     (0..n).map(|k| {
/// #         let a = k as f32 / n as f32 * std::f32::consts::TAU;
/// #         Point::new(cx + r * a.cos(), r * a.sin())
/// #     }).collect()
/// # };
/// let wall = Feature::new(FeatureId::Wall, &circle(0.0, 8.0, 64), [1.0, 0.0, 0.0, 0.0]).unwrap();
/// let hole = Feature::new(FeatureId::Hole(0), &circle(0.0, 4.0, 48), [0.0, 1.0, 0.0, 0.0]).unwrap();
/// let slice = Slice::new(wall, &[hole], Settings::default()).unwrap();
/// let mut planner = Box::new(Planner::new());
/// let plan = planner.plan(&slice).unwrap();
/// assert!(plan.mcls.len() > 50);
/// # }).unwrap().join().unwrap();
/// ```
pub struct Planner {
    field: Field,
    scratch: Vec<Point, TRACE_POINTS>,
    plan: Plan,
}

impl Default for Planner {
    fn default() -> Self {
        Self::new()
    }
}

impl Planner {
    /// A planner with empty buffers.
    pub const fn new() -> Planner {
        Planner {
            field: Field::new(),
            scratch: Vec::new(),
            plan: Plan {
                halves: Halves::new(),
                mcls: Vec::new(),
                cells: Cells::new(),
                stats: PlanStats {
                    grid_nodes: 0,
                    grid_h: 0.0,
                    boundary_nodes: 0,
                    sweeps: 0,
                    residual: 0.0,
                    traced: 0,
                    half_points: 0,
                    failed_traces: 0,
                    dropped_crossing: 0,
                    dropped_crowded: 0,
                    off_bisector: 0,
                    matched_pairs: 0,
                    removed_unmatched: 0,
                    relax_moves: 0,
                    thinned: 0,
                    removed_invalid: 0,
                },
            },
        }
    }

    /// The plan of the last successful run (empty after a failed one).
    pub fn last_plan(&self) -> &Plan {
        &self.plan
    }

    /// The field of the last run (labels and harmonic values); empty once its memory was
    /// lent ([`plan_and_grid`](Self::plan_and_grid)).
    pub fn field(&self) -> &Field {
        &self.field
    }

    /// The plan of the last successful run, and the field's node memory lent for another
    /// grid (the offset spiral's distances: [`OffsetSpiral::prepare`]): the field is not
    /// needed once the MCLs are traced, and this way the planner and the spiral never hold
    /// two grids at once. The field is empty afterwards.
    ///
    /// [`OffsetSpiral::prepare`]: crate::toolpath::offset::OffsetSpiral::prepare
    pub fn plan_and_grid(&mut self) -> (&Plan, &mut GridMemory) {
        (&self.plan, self.field.lend())
    }

    /// Plans the MCLs of `slice`: cells, insertion, matching, relaxation. On error the previous
    /// plan is gone and no partial plan is returned.
    pub fn plan(&mut self, slice: &Slice) -> Result<&Plan, Error> {
        let result = self.run(slice);
        if result.is_err() {
            self.plan.halves.clear();
            self.plan.mcls.clear();
            self.plan.cells.bisectors.clear();
            self.plan.cells.branch_points.clear();
        }
        result.map(|()| &self.plan)
    }

    fn run(&mut self, slice: &Slice) -> Result<(), Error> {
        let plan = &mut self.plan;
        plan.stats = PlanStats::default();
        plan.mcls.clear();
        if slice.holes().is_empty() {
            // No feature to decompose around: no cells, no MCLs (the plan is empty and
            // verifies; the offset spiral lays the slice from the wall inwards).
            plan.halves.clear();
            plan.cells.bisectors.clear();
            plan.cells.branch_points.clear();
            return Ok(());
        }
        self.field.label_nodes(slice)?;
        plan.cells.build(slice, &self.field, &mut self.scratch)?;
        self.field.solve();
        let (sweeps, residual) = self.field.convergence();
        plan.stats.grid_nodes = self.field.grid().len() as u32;
        plan.stats.grid_h = self.field.grid().h;
        plan.stats.boundary_nodes = self.field.boundary_nodes() as u32;
        plan.stats.sweeps = sweeps;
        plan.stats.residual = residual;
        debug!("field: {} sweeps, residual {}", sweeps, residual);
        insert::insert(
            slice,
            &self.field,
            &mut plan.halves,
            &mut self.scratch,
            &mut plan.stats,
        )?;
        matching::match_all(slice, &plan.cells, &mut plan.halves, &mut plan.stats)?;
        relax::relax(slice, &plan.cells, &mut plan.halves, &mut plan.stats)?;
        sanitize(slice, &mut plan.halves, &mut plan.stats)?;
        // Compact the halves (remapping partners), then list the MCLs.
        let mut remap: Vec<u16, MAX_HALVES> = Vec::new();
        let mut next = 0u16;
        for h in plan.halves.iter() {
            remap.push(next).map_err(|_| Limit::Halves.error())?;
            if h.alive {
                next += 1;
            }
        }
        plan.halves.retain_alive();
        for h in plan.halves.iter_mut() {
            h.partner = h.partner.map(|p| remap[p as usize]);
        }
        let order = insert::sorted_all(&plan.halves);
        for &k in order.iter() {
            let h = &plan.halves[k as usize];
            let end_point = plan.halves.end_point(k as usize);
            let mcl = match (h.end, h.partner) {
                (HalfEnd::Wall, _) => Mcl {
                    from: h.hole,
                    to: Target::Wall,
                    first: k,
                    second: None,
                    joint: end_point,
                },
                (HalfEnd::Bisector(j), Some(p)) if h.hole < j => Mcl {
                    from: h.hole,
                    to: Target::Hole(j),
                    first: k,
                    second: Some(p),
                    joint: end_point,
                },
                _ => continue,
            };
            plan.mcls.push(mcl).map_err(|_| Error::Capacity {
                limit: Limit::Mcls,
                feature: None,
            })?;
        }
        for i in 0..slice.holes().len() {
            if !plan.halves.iter().any(|h| h.hole as usize == i) {
                return Err(Error::NoRoom { hole: i as u8 });
            }
        }
        debug!("mcls: {}", plan.mcls.len());
        Ok(())
    }
}

/// The final check on the halves: a half (with its partner) is removed if, after matching and
/// relaxation dragged it, a segment leaves the printable region or it crosses another half of
/// its cell. Whatever survives has the properties [`verify`](crate::verify::verify) checks.
// Not inlined: its boxes stay in a frame of its own, which the planner's other phases share.
#[inline(never)]
fn sanitize(slice: &Slice, halves: &mut Halves, stats: &mut PlanStats) -> Result<(), Error> {
    use crate::geometry::polyline;
    let remove = |halves: &mut Halves, k: usize, stats: &mut PlanStats| {
        halves[k].alive = false;
        if let Some(p) = halves[k].partner {
            halves[p as usize].alive = false;
        }
        stats.removed_invalid += 1;
    };
    for k in 0..halves.len() {
        if !halves[k].alive {
            continue;
        }
        let inside = slice.polyline_is_printable(halves.points(k), 1e-3);
        if !inside {
            remove(halves, k, stats);
        }
    }
    // Every half's box, measured once for all the pairs it is in.
    let mut boxes: Vec<(Point, Point), MAX_HALVES> = Vec::new();
    halves.boxes(&mut boxes)?;
    for a in 0..halves.len() {
        let box_a = boxes[a];
        for b in (a + 1)..halves.len() {
            let (ha, hb) = (&halves[a], &halves[b]);
            if !ha.alive || !hb.alive || ha.partner == Some(b as u16) {
                continue;
            }
            let related = ha.hole == hb.hole
                || ha.end == HalfEnd::Bisector(hb.hole)
                || hb.end == HalfEnd::Bisector(ha.hole);
            if related
                && polyline::boxes_overlap(box_a, boxes[b], 1e-4)
                && polyline::polylines_cross(halves.points(a), halves.points(b))
            {
                remove(halves, b, stats);
            }
        }
    }
    Ok(())
}
