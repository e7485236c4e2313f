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
    /// The grid with spacing at least `h_min` (> 0) covering the box `lo..hi` with one spare
    /// node all round and at most `max_nodes` nodes, centred on the box.
    pub fn covering(lo: Point, hi: Point, h_min: f32, max_nodes: usize) -> Grid {
        let (w, ht) = (hi.x - lo.x, hi.y - lo.y);
        let mut h = h_min;
        loop {
            // Counted in f32 first: no integer overflow, the same on 32- and 64-bit targets.
            let (fx, fy) = (libm::ceilf(w / h) + 3.0, libm::ceilf(ht / h) + 3.0);
            if fx.is_nan() || fy.is_nan() || fx * fy > max_nodes as f32 {
                h *= 1.03;
                continue;
            }
            let (nx, ny) = (fx as usize, fy as usize);
            if nx * ny <= max_nodes {
                let origin = Point::new(
                    (lo.x + hi.x) * 0.5 - (nx - 1) as f32 * h * 0.5,
                    (lo.y + hi.y) * 0.5 - (ny - 1) as f32 * h * 0.5,
                );
                return Grid { origin, h, nx, ny };
            }
            h *= 1.03;
        }
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
