use super::primitives::MinMax;
use super::Point;

/// A regular grid of nodes over a box: `nx * ny` nodes `h` apart, node `(i, j)` at
/// `origin + (i h, j h)`, stored row by row (`k = j * nx + i`).
///
/// ```
/// use hollowpath::geometry::{Grid, Point};
/// let g = Grid { origin: Point::new(0.0, 0.0), h: 0.5, nx: 4, ny: 3 };
/// assert_eq!(g.node(g.index(2, 1)), Point::new(1.0, 0.5));
/// assert_eq!(g.locate(Point::new(0.6, 0.3)), Some((1, 0, 0.20000005, 0.6)));
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Grid {
    /// Position of node (0, 0).
    pub origin: Point,
    /// Node spacing, mm.
    pub h: f32,
    /// Nodes along x.
    pub nx: usize,
    /// Nodes along y.
    pub ny: usize,
}

impl Grid {
    /// The spacing rule: from `h_min` (> 0), coarsened in steps of 3 % while the grid over the
    /// box `lo..hi` would have more than `budget` nodes, but never beyond `h_max` (the last
    /// step not beyond it is kept, however many nodes it needs). A function of the box and
    /// the arguments only: a capacity decides whether the grid is accepted, not its spacing.
    pub fn spacing(lo: Point, hi: Point, h_min: f32, budget: usize, h_max: f32) -> f32 {
        let mut h = h_min;
        loop {
            if Self::nodes(lo, hi, h).is_some_and(|n| n <= budget as f32) {
                return h;
            }
            let next = h * 1.03;
            if next.is_nan() || next > h_max || h_max.is_nan() {
                return h;
            }
            h = next;
        }
    }

    /// Nodes of the grid `h` apart over the box `lo..hi` with one spare node all round, counted
    /// in f32 (no integer overflow, the same on 32- and 64-bit targets); `None` if not finite.
    fn nodes(lo: Point, hi: Point, h: f32) -> Option<f32> {
        let (fx, fy) = Self::counts(lo, hi, h);
        let n = fx * fy;
        n.is_finite().then_some(n)
    }

    fn counts(lo: Point, hi: Point, h: f32) -> (f32, f32) {
        (
            libm::ceilf((hi.x - lo.x) / h) + 3.0,
            libm::ceilf((hi.y - lo.y) / h) + 3.0,
        )
    }

    /// The grid `h` apart covering the box `lo..hi` with one spare node all round, centred on
    /// the box; `None` if it would have more than `max_nodes` nodes.
    ///
    /// ```
    /// use hollowpath::geometry::{Grid, Point};
    /// let (lo, hi) = (Point::new(0.0, 0.0), Point::new(10.0, 5.0));
    /// let g = Grid::with_spacing(lo, hi, 1.0, 1000).unwrap();
    /// assert_eq!((g.nx, g.ny), (13, 8));
    /// assert!(Grid::with_spacing(lo, hi, 1.0, 100).is_none());
    /// ```
    pub fn with_spacing(lo: Point, hi: Point, h: f32, max_nodes: usize) -> Option<Grid> {
        let (fx, fy) = Self::counts(lo, hi, h);
        if !Self::nodes(lo, hi, h).is_some_and(|n| n <= max_nodes as f32) {
            return None;
        }
        let (nx, ny) = (fx as usize, fy as usize);
        if nx * ny > max_nodes {
            return None;
        }
        let origin = Point::new(
            (lo.x + hi.x) * 0.5 - (nx - 1) as f32 * h * 0.5,
            (lo.y + hi.y) * 0.5 - (ny - 1) as f32 * h * 0.5,
        );
        Some(Grid { origin, h, nx, ny })
    }

    /// The largest square (side, mm) a grid `h` apart with at most `max_nodes` nodes covers.
    pub fn square_side(h: f32, max_nodes: usize) -> f32 {
        (libm::floorf(hollowpath_fpu::sqrtf(max_nodes as f32)) - 3.0).fmax(0.0) * h
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.nx * self.ny
    }
    /// Whether the grid has no node.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Index of node `(i, j)`.
    pub fn index(&self, i: usize, j: usize) -> usize {
        j * self.nx + i
    }
    /// Position of node `k`.
    pub fn node(&self, k: usize) -> Point {
        let (i, j) = (k % self.nx, k / self.nx);
        Point::new(
            self.origin.x + i as f32 * self.h,
            self.origin.y + j as f32 * self.h,
        )
    }
    /// The grid square holding `p`: its lower-left node `(i, j)` and the fractions `(fx, fy)`
    /// of `p` across it; `None` outside the grid.
    pub fn locate(&self, p: Point) -> Option<(usize, usize, f32, f32)> {
        let gx = (p.x - self.origin.x) / self.h;
        let gy = (p.y - self.origin.y) / self.h;
        if !(gx >= 0.0 && gy >= 0.0) {
            return None;
        }
        let (i, j) = (libm::floorf(gx) as usize, libm::floorf(gy) as usize);
        if i + 1 >= self.nx || j + 1 >= self.ny {
            return None;
        }
        Some((i, j, gx - i as f32, gy - j as f32))
    }
}
