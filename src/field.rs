//! The cell labels and the harmonic field that MCLs follow.
//!
//! One grid covers the slice. Every node is labelled: outside the printable region of the wall,
//! in the keep-out band of hole `i` (within half a road width of it), or free in the Voronoi
//! cell of hole `i` (nearest to hole `i` among the holes). In every cell the field `u` solves
//! Laplace's equation with `u = 0` on the hole's keep-out boundary and `u = 1` on the cell
//! boundary (the bisectors and the wall's keep-out boundary). Boundaries that fall between
//! nodes are placed exactly (Shortley-Weller arms, from the signed distances), so the field is
//! second-order accurate up to the boundary.
//!
//! The streamlines of `u` (its gradient lines) run from the hole to the cell boundary, never
//! cross each other, fan out into concave pockets and reach the boundary at right angles: they
//! are the material changing lines before matching.

use heapless::Vec;

use crate::config::{
    BOUNDARY_NODES, FIELD_MAX_SWEEPS, FIELD_OMEGA, FIELD_TOLERANCE, GRID_NODES, GRID_SPACING_NODES,
    GRID_SPACING_PER_ROAD, MAX_GRID_SPACING_PER_ROAD, MAX_VERTICES,
};
use crate::geometry::primitives::MinMax;
use crate::geometry::{polygon, Grid, Point};
use crate::{Error, Feature, Limit, Slice};

/// Label of a node outside the wall's printable region.
pub const OUTSIDE: u8 = 0xFF;
/// Flag of a node in a hole's keep-out band (the low bits give the hole).
pub const KEEP_OUT: u8 = 0x40;

// `BoundaryNode::node` is a `u16` node index.
const _: () = assert!(GRID_NODES <= u16::MAX as usize + 1);

/// Arms of a node: +x, -x, +y, -y.
const ARMS: [(isize, isize); 4] = [(1, 0), (-1, 0), (0, 1), (0, -1)];

/// A node next to a boundary: the fraction of each arm up to the boundary (0 = a regular arm),
/// quantised to 1/255, and which boundaries hold `u = 1`.
#[derive(Clone, Copy, Debug, Default)]
struct BoundaryNode {
    node: u16,
    theta: [u8; 4],
    one: u8,
}

/// The memory of one grid's nodes: a value and a byte a node ([`GRID_NODES`] of each, 80 KiB
/// in the MCU build). The planner's [`Field`] keeps its `u` and labels in it; once a plan is
/// made, the field lends it to the offset spiral for its distances and marks
/// ([`Planner::plan_and_grid`](crate::Planner::plan_and_grid)), so that two grids are never
/// alive at once.
pub struct GridMemory {
    pub(crate) values: Vec<f32, GRID_NODES>,
    pub(crate) tags: Vec<u8, GRID_NODES>,
}

impl GridMemory {
    /// Empty memory (no allocation: the buffers are inline).
    pub const fn new() -> GridMemory {
        GridMemory {
            values: Vec::new(),
            tags: Vec::new(),
        }
    }

    /// Forgets every node.
    pub(crate) fn clear(&mut self) {
        self.values.clear();
        self.tags.clear();
    }
}

impl Default for GridMemory {
    fn default() -> Self {
        Self::new()
    }
}

/// Labels and harmonic field over the slice.
pub struct Field {
    grid: Grid,
    /// `u` in `values`, the labels in `tags`.
    mem: GridMemory,
    boundary: Vec<BoundaryNode, BOUNDARY_NODES>,
    sweeps: u32,
    residual: f32,
}

impl Default for Field {
    fn default() -> Self {
        Self::new()
    }
}

impl Field {
    /// An empty field (no allocation: the buffers are inline).
    pub const fn new() -> Field {
        Field {
            grid: Grid {
                origin: Point::new(0.0, 0.0),
                h: 0.0,
                nx: 0,
                ny: 0,
            },
            mem: GridMemory::new(),
            boundary: Vec::new(),
            sweeps: 0,
            residual: 0.0,
        }
    }

    /// The grid.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }
    /// Label of node `k`: a hole index for a free node, [`KEEP_OUT`]` | i`, or [`OUTSIDE`].
    pub fn label(&self, k: usize) -> u8 {
        self.mem.tags[k]
    }
    /// Empties the field and lends its node memory to another grid's user (the offset
    /// spiral); the field is planned afresh by the next [`label_nodes`](Self::label_nodes).
    pub fn lend(&mut self) -> &mut GridMemory {
        self.grid = Grid::default();
        self.boundary.clear();
        self.sweeps = 0;
        self.residual = 0.0;
        self.mem.clear();
        &mut self.mem
    }

    /// Number of nodes next to a boundary.
    pub fn boundary_nodes(&self) -> usize {
        self.boundary.len()
    }
    /// Sweeps the last solve took and the largest change in its last sweep.
    pub fn convergence(&self) -> (u32, f32) {
        (self.sweeps, self.residual)
    }

    /// Labels every node and precomputes the boundary arms; sets a first guess of `u` from the
    /// distances (the solve then needs far fewer sweeps).
    pub fn label_nodes(&mut self, slice: &Slice) -> Result<(), Error> {
        let w = slice.settings().road_width;
        let (lo, hi) = slice.wall().bbox();
        self.mem.tags.clear();
        self.mem.values.clear();
        self.boundary.clear();
        // The spacing depends on the slice and the road only; the capacity only decides
        // whether the grid fits.
        self.grid = fitted_grid(lo, hi, w * GRID_SPACING_PER_ROAD, w, false)?;
        let half = 0.5 * w;
        // Where the wall crosses the current row of nodes: each node's containment from them
        // (the crossing test's answer, one pass over the wall's edges a row).
        let mut crossings: Vec<f32, MAX_VERTICES> = Vec::new();
        for k in 0..self.grid.len() {
            let p = self.grid.node(k);
            if k % self.grid.nx == 0 {
                slice.wall().row_crossings(p.y, &mut crossings);
            }
            let inside = Feature::inside_by_crossings(&crossings, p.x);
            debug_assert_eq!(inside, slice.wall().contains(p), "containment at {p:?}");
            // Outside the wall the node is outside whatever its distances (the containment
            // test is the sign of the wall's distance).
            let (label, u0) = if !inside {
                (OUTSIDE, 1.0)
            } else {
                let (i, di, _, dj) = slice.nearest_holes(p);
                // Inside, the wall's clearance decides the node only below half a road, or
                // below half a road more than half the gap between the two nearest holes
                // (where it bounds `u0`); farther, it is not measured and stands at infinity,
                // which `min` passes over as it would the measured value.
                let cap = if di < half {
                    half
                } else {
                    half + (0.5 * (dj - di)).fmax(0.0)
                };
                // Every box of the wall's chunks farther than `cap` (plus rounding): its
                // clearance is larger still (the node is inside the wall).
                let reach = cap + polygon::rounding_slack(p, slice.wall().bbox());
                // (`cap` is at least half a road: `reach` is positive.)
                let wc = if slice.wall().nearest_box2(p) > reach * reach {
                    f32::INFINITY
                } else {
                    slice.wall_clearance(p) - half
                };
                if wc < 0.0 {
                    (OUTSIDE, 1.0)
                } else if di < half {
                    (KEEP_OUT | i as u8, 0.0)
                } else {
                    let a = di - half;
                    let b = wc.fmin(0.5 * (dj - di));
                    (i as u8, a / (a + b).fmax(1e-6))
                }
            };
            self.mem
                .tags
                .push(label)
                .map_err(|_| Limit::GridNodes.error())?;
            self.mem
                .values
                .push(u0)
                .map_err(|_| Limit::GridNodes.error())?;
        }
        for k in 0..self.grid.len() {
            let i = self.mem.tags[k];
            if i >= KEEP_OUT {
                continue;
            }
            let mut entry = BoundaryNode {
                node: k as u16,
                ..BoundaryNode::default()
            };
            let mut irregular = false;
            for (a, &(dx, dy)) in ARMS.iter().enumerate() {
                let nb = self.neighbour(k, dx, dy);
                let l = self.mem.tags[nb];
                if l == i {
                    continue;
                }
                irregular = true;
                let (p, q) = (self.grid.node(k), self.grid.node(nb));
                let (phi_p, phi_q, one) = boundary_levels(slice, i as usize, l, p, q, half);
                let theta = if phi_p - phi_q > 0.0 {
                    phi_p / (phi_p - phi_q)
                } else {
                    1.0
                };
                // In 13..=255 after the clamp: fits the `u8`.
                entry.theta[a] = (libm::roundf(theta.clamp(0.05, 1.0) * 255.0) as u8).max(1);
                if one {
                    entry.one |= 1 << a;
                }
            }
            if irregular {
                self.boundary.push(entry).map_err(|_| Error::Capacity {
                    limit: Limit::BoundaryNodes,
                    feature: None,
                })?;
            }
        }
        Ok(())
    }

    fn neighbour(&self, k: usize, dx: isize, dy: isize) -> usize {
        (k as isize + dx + dy * self.grid.nx as isize) as usize
    }

    /// Solves Laplace's equation by successive over-relaxation until no node moves more than
    /// [`FIELD_TOLERANCE`] or [`FIELD_MAX_SWEEPS`] have run.
    ///
    /// Each sweep visits the free nodes in node order (Gauss-Seidel). Between two boundary
    /// nodes (in node order) the nodes are all free and regular, or all outside the cells: a
    /// free node beside a node of another label is a boundary node itself, and the grid's
    /// border nodes lie outside the wall. So a sweep runs from one boundary node to the next,
    /// each stretch between them either skipped whole or relaxed with the plain five-point
    /// stencil ([`relax_run`]), and never asks a node's label.
    pub fn solve(&mut self) {
        let nx = self.grid.nx;
        let n = self.grid.len();
        // The grid's own slices, borrowed once: each sweep reads and writes them by index
        // without reaching through `self` (the Cortex-M4F reloaded their addresses, large
        // offsets into the static, at every node).
        let (tags, values) = (&self.mem.tags[..n], &mut self.mem.values[..n]);
        let boundary = &self.boundary[..];
        let mut sweeps = 0;
        let mut residual = f32::INFINITY;
        while sweeps < FIELD_MAX_SWEEPS && residual > FIELD_TOLERANCE {
            residual = 0.0;
            let mut k = 0;
            // Every boundary node, then the end of the grid as a last stop.
            for stop in boundary.iter().map(Some).chain(core::iter::once(None)) {
                let end = stop.map_or(n, |b| b.node as usize);
                if k < end && tags[k] < KEEP_OUT {
                    residual = relax_run(values, nx, k, end, residual);
                }
                if let Some(b) = stop {
                    let target = weighted_average(values, nx, end, b);
                    residual = over_relax(&mut values[end], target, residual);
                    k = end + 1;
                }
            }
            sweeps += 1;
        }
        self.sweeps = sweeps;
        self.residual = residual;
    }

    /// Arm lengths (in grid spacings) and end values of node `k`.
    fn arms(&self, k: usize, b: Option<&BoundaryNode>) -> [(f32, f32); 4] {
        arms(&self.mem.values, self.grid.nx, k, b)
    }

    fn boundary_entry(&self, k: usize) -> Option<&BoundaryNode> {
        // A free node (never on the grid's border: those lie outside the wall) whose four
        // neighbours carry its label is regular (only a free node beside another label has
        // an entry): no search.
        let tags = &self.mem.tags;
        let l = tags[k];
        if l < KEEP_OUT
            && ARMS
                .iter()
                .all(|&(dx, dy)| tags[self.neighbour(k, dx, dy)] == l)
        {
            return None;
        }
        self.boundary
            .binary_search_by_key(&(k as u16), |b| b.node)
            .ok()
            .map(|i| &self.boundary[i])
    }

    /// Gradient of `u` at free node `k` (central differences over the arms).
    fn node_gradient(&self, k: usize) -> Point {
        let arms = self.arms(k, self.boundary_entry(k));
        let h = self.grid.h;
        Point::new(
            (arms[0].1 - arms[1].1) / ((arms[0].0 + arms[1].0) * h),
            (arms[2].1 - arms[3].1) / ((arms[2].0 + arms[3].0) * h),
        )
    }

    /// The field's gradient at `p` in the cell of hole `cell`, interpolated from the free nodes
    /// of that cell around `p`; `None` where no such node is near.
    pub fn gradient(&self, p: Point, cell: usize) -> Option<Point> {
        let (i, j, fx, fy) = self.grid.locate(p)?;
        let corners = [
            (self.grid.index(i, j), (1.0 - fx) * (1.0 - fy)),
            (self.grid.index(i + 1, j), fx * (1.0 - fy)),
            (self.grid.index(i, j + 1), (1.0 - fx) * fy),
            (self.grid.index(i + 1, j + 1), fx * fy),
        ];
        let mut g = Point::default();
        let mut wsum = 0.0;
        for (k, wk) in corners {
            if self.mem.tags[k] as usize == cell && wk > 0.0 {
                g = g + self.node_gradient(k) * wk;
                wsum += wk;
            }
        }
        if wsum < 1e-3 {
            None
        } else {
            Some(g * (1.0 / wsum))
        }
    }
}

/// Level values at `p` (inside the cell of hole `i`) and at its neighbour `q` (labelled
/// `l`) of the function that vanishes on the boundary between them, and whether `u = 1` there.
fn boundary_levels(
    slice: &Slice,
    i: usize,
    l: u8,
    p: Point,
    q: Point,
    half: f32,
) -> (f32, f32, bool) {
    let hole = |k: usize, x: Point| slice.holes()[k].signed_distance(x);
    if l == OUTSIDE {
        (
            slice.wall_clearance(p) - half,
            slice.wall_clearance(q) - half,
            true,
        )
    } else if l == KEEP_OUT | i as u8 {
        (hole(i, p) - half, hole(i, q) - half, false)
    } else {
        let j = (l & !KEEP_OUT) as usize;
        (hole(j, p) - hole(i, p), hole(j, q) - hole(i, q), true)
    }
}

/// The grid over the box `lo..hi` (a slice's wall) at the spacing [`Grid::spacing`] picks from
/// `preferred` for a slice of road width `w` (from the slice and the road alone, so host and
/// MCU grid a slice alike), or the error saying the slice is too large for [`GRID_NODES`]
/// (`spiral`: the offset spiral's grid).
pub(crate) fn fitted_grid(
    lo: Point,
    hi: Point,
    preferred: f32,
    w: f32,
    spiral: bool,
) -> Result<Grid, Error> {
    let h = Grid::spacing(
        lo,
        hi,
        preferred,
        GRID_SPACING_NODES,
        MAX_GRID_SPACING_PER_ROAD * w,
    );
    Grid::with_spacing(lo, hi, h, GRID_NODES).ok_or(Error::SliceTooLarge {
        width: hi.x - lo.x,
        height: hi.y - lo.y,
        road_width: w,
        holds: Grid::square_side(h, GRID_NODES),
        spiral,
    })
}

/// Arm lengths (in grid spacings) and end values of node `k` of a grid `nx` nodes wide whose
/// values are `values`.
fn arms(values: &[f32], nx: usize, k: usize, b: Option<&BoundaryNode>) -> [(f32, f32); 4] {
    let mut out = [(1.0, 0.0); 4];
    for (a, &(dx, dy)) in ARMS.iter().enumerate() {
        out[a] = match b {
            Some(b) if b.theta[a] != 0 => (
                b.theta[a] as f32 / 255.0,
                if b.one & (1 << a) != 0 { 1.0 } else { 0.0 },
            ),
            _ => (1.0, values[(k as isize + dx + dy * nx as isize) as usize]),
        };
    }
    out
}

/// The value at boundary node `k` (`b`) that the Laplacian's unequal-arm stencil asks for.
fn weighted_average(values: &[f32], nx: usize, k: usize, b: &BoundaryNode) -> f32 {
    let arms = arms(values, nx, k, Some(b));
    let mut num = 0.0;
    let mut den = 0.0;
    for pair in [(0, 1), (2, 3)] {
        let (tp, vp) = arms[pair.0];
        let (tm, vm) = arms[pair.1];
        let ap = 2.0 / (tp * (tp + tm));
        let am = 2.0 / (tm * (tp + tm));
        num += ap * vp + am * vm;
        den += ap + am;
    }
    num / den
}

/// Moves `value` towards `target` by [`FIELD_OMEGA`]; the larger of `residual` and the change.
fn over_relax(value: &mut f32, target: f32, residual: f32) -> f32 {
    let old = *value;
    let new = old + FIELD_OMEGA * (target - old);
    *value = new;
    // A plain comparison, `fmax`'s answer for the change (never NaN).
    let change = libm::fabsf(new - old);
    if change > residual {
        change
    } else {
        residual
    }
}

/// One Gauss-Seidel pass of the five-point stencil over nodes `start..end` of a grid `nx`
/// nodes wide (free, regular nodes of one row: their row neighbours and the rows above and
/// below exist); the larger of `residual` and the largest change.
fn relax_run(values: &mut [f32], nx: usize, start: usize, end: usize, residual: f32) -> f32 {
    let len = end - start;
    // The row above, the run with a node either side, and the row below, as three slices
    // (the run lies within one row: `len + 2 <= nx`).
    let (before, rest) = values.split_at_mut(start);
    let (run, after) = rest.split_at_mut(nx);
    let up = &before[start - nx..start - nx + len];
    let down = &after[..len];
    let run = &mut run[..len + 1];
    let mut left = before[start - 1];
    let mut residual = residual;
    for i in 0..len {
        // The sum in the order of the stencil over every node: +x, -x, +y, -y.
        let target = 0.25 * (run[i + 1] + left + down[i] + up[i]);
        residual = over_relax(&mut run[i], target, residual);
        left = run[i];
    }
    residual
}
