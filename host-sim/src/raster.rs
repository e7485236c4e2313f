//! A fine raster of a slice onto which roads are deposited, to measure what they cover.

use hollowpath::geometry::Point;
use hollowpath::Slice;

/// A raster over the wall's bounding box: which cells are printable, and how many strokes
/// cover each.
pub struct Raster {
    /// Centre of cell (0, 0).
    pub origin: Point,
    /// Cell size, mm.
    pub cell: f32,
    /// Cells along x.
    pub nx: usize,
    /// Cells along y.
    pub ny: usize,
    /// Whether the cell centre is in the printable region.
    pub printable: Vec<bool>,
    /// How many strokes cover the cell centre.
    pub count: Vec<u16>,
    last_stroke: Vec<u32>,
    stroke: u32,
}

impl Raster {
    /// The raster of `slice` with cells of `cell` mm.
    pub fn new(slice: &Slice, cell: f32) -> Raster {
        let (lo, hi) = slice.wall().bbox();
        let nx = ((hi.x - lo.x) / cell).ceil() as usize + 1;
        let ny = ((hi.y - lo.y) / cell).ceil() as usize + 1;
        let origin = lo;
        let mut printable = vec![false; nx * ny];
        for j in 0..ny {
            for i in 0..nx {
                let p = Point::new(origin.x + i as f32 * cell, origin.y + j as f32 * cell);
                printable[j * nx + i] = slice.is_printable(p, 0.0);
            }
        }
        Raster {
            origin,
            cell,
            nx,
            ny,
            printable,
            count: vec![0; nx * ny],
            last_stroke: vec![u32::MAX; nx * ny],
            stroke: 0,
        }
    }

    /// Number of printable cells.
    pub fn printable_cells(&self) -> usize {
        self.printable.iter().filter(|&&p| p).count()
    }

    /// Deposits one stroke: every cell whose centre is within `radius` of the polyline counts
    /// once more (once per stroke, however the polyline folds).
    pub fn stamp_polyline(&mut self, pts: &[Point], radius: f32) {
        let stroke = self.stroke;
        self.stroke += 1;
        for w in pts.windows(2) {
            let (a, b) = (w[0], w[1]);
            let lo = Point::new(a.x.min(b.x) - radius, a.y.min(b.y) - radius);
            let hi = Point::new(a.x.max(b.x) + radius, a.y.max(b.y) + radius);
            let i0 = (((lo.x - self.origin.x) / self.cell).floor().max(0.0)) as usize;
            let j0 = (((lo.y - self.origin.y) / self.cell).floor().max(0.0)) as usize;
            let i1 = (((hi.x - self.origin.x) / self.cell).ceil() as usize).min(self.nx - 1);
            let j1 = (((hi.y - self.origin.y) / self.cell).ceil() as usize).min(self.ny - 1);
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let k = j * self.nx + i;
                    if self.last_stroke[k] == stroke {
                        continue;
                    }
                    let p = Point::new(
                        self.origin.x + i as f32 * self.cell,
                        self.origin.y + j as f32 * self.cell,
                    );
                    let (c, _) = hollowpath::geometry::polyline::closest_on_segment(a, b, p);
                    if c.dist(p) <= radius {
                        self.last_stroke[k] = stroke;
                        self.count[k] = self.count[k].saturating_add(1);
                    }
                }
            }
        }
    }

    /// Share of the printable cells covered by no stroke.
    pub fn uncovered_fraction(&self) -> f64 {
        let total = self.printable_cells();
        let bare = self
            .printable
            .iter()
            .zip(&self.count)
            .filter(|(&p, &c)| p && c == 0)
            .count();
        bare as f64 / total.max(1) as f64
    }
}
