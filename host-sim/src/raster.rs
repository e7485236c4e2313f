//! A fine raster of a slice onto which roads are deposited, to measure what they cover.
//!
//! Cell `(i, j)` is the point `origin + (i, j) * cell` (a cell is its centre). The grid spans the
//! wall's bounding box grown by one road width on every side, so a road that slips just past the
//! wall still lands on it; cells a road covers beyond the grid are all outside the wall and are
//! kept, deduplicated, in a small set ([`Raster::outside_cells`]).
//!
//! Every cell is classified once, when the raster is built, as [`Region::Printable`] (the
//! printable region: inside the wall and outside every hole by half a road width),
//! [`Region::Margin`] (still material, but within half a road width of a feature) or
//! [`Region::Void`] (inside a hollow feature or outside the wall). The signed distances are
//! 1-Lipschitz, so a block of cells whose centre is farther from every class boundary than the
//! block's radius takes the centre's class without looking at each cell.

use std::collections::HashSet;

use hollowpath::geometry::Point;
use hollowpath::Slice;

/// What a raster cell is part of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Region {
    /// Inside the wall and outside every hole by at least half a road width.
    Printable,
    /// Inside the wall and outside every hole, but nearer than half a road width to one.
    Margin,
    /// Inside a hollow feature or outside the wall: no material belongs here.
    Void,
}

impl Region {
    /// Whether material belongs here (printable or margin).
    pub fn is_material(self) -> bool {
        self != Region::Void
    }
}

/// A grid cell a segment's capsule covers (see [`Raster::stamp_segment`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Index of the cell, `j * nx + i`.
    pub k: usize,
    /// Column.
    pub i: usize,
    /// Row.
    pub j: usize,
    /// The cell's region.
    pub region: Region,
    /// Parameter in [0, 1] of the segment point closest to the cell centre.
    pub t: f32,
    /// Squared distance from the cell centre to the segment, mm^2.
    pub d2: f32,
}

/// Cells per side of a classification block.
const BLOCK: usize = 8;

/// A raster over the wall's bounding box: the region of each cell, and how many strokes cover
/// each.
pub struct Raster {
    /// Centre of cell (0, 0).
    pub origin: Point,
    /// Cell size, mm.
    pub cell: f32,
    /// Cells along x.
    pub nx: usize,
    /// Cells along y.
    pub ny: usize,
    /// Whether the cell centre is in the printable region (`region[k] == Region::Printable`).
    pub printable: Vec<bool>,
    /// The region of each cell centre.
    pub region: Vec<Region>,
    /// How many strokes cover the cell centre.
    pub count: Vec<u16>,
    /// Cells beyond the grid that some stroke covered (all outside the wall).
    outside: HashSet<(i64, i64)>,
    /// Where along the strokes (arc length, mm, counted on across strokes) each cell was last
    /// covered (`-inf`: never).
    last_s: Vec<f32>,
    /// Arc length at the start of the next segment.
    s: f32,
    /// Arc length at the start of the current stroke.
    stroke_start: f32,
    /// How far a stroke must move on along itself before a cell it covers again counts again:
    /// the slice's road width.
    revisit_after: f32,
    revisit: Revisit,
}

/// How a stroke that comes back over a cell counts there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Revisit {
    /// Once per stroke, however the stroke folds over itself.
    Once,
    /// Again where the stroke comes back to the cell after moving on more than one road width
    /// along itself (a hairpin, the next spiral turn, a crossing): while it passes along, at a
    /// joint or round a corner, the cell counts once (`../shared/DESIGN.md`).
    Again,
}

/// The class of a point from its wall clearance `c` and nearest-hole distance `h`.
fn classify(c: f32, h: f32, half: f32) -> Region {
    if c >= half && h >= half {
        Region::Printable
    } else if c >= 0.0 && h >= 0.0 {
        Region::Margin
    } else {
        Region::Void
    }
}

impl Raster {
    /// The raster of `slice` with cells of `cell` mm.
    pub fn new(slice: &Slice, cell: f32) -> Raster {
        assert!(cell > 0.0, "raster cell size must be positive");
        let half = slice.settings().road_width * 0.5;
        let margin = 2.0 * half;
        let (lo, hi) = slice.wall().bbox();
        let nx = ((hi.x - lo.x + 2.0 * margin) / cell).ceil() as usize + 1;
        let ny = ((hi.y - lo.y + 2.0 * margin) / cell).ceil() as usize + 1;
        let origin = Point::new(lo.x - margin, lo.y - margin);
        let distances = |p: Point| (slice.wall_clearance(p), slice.nearest_holes(p).1);
        let mut region = vec![Region::Void; nx * ny];
        // Half the diagonal of a block's cell centres: every centre is this close to the
        // block's middle.
        let radius = core::f32::consts::SQRT_2 * 0.5 * (BLOCK - 1) as f32 * cell;
        for bj in (0..ny).step_by(BLOCK) {
            for bi in (0..nx).step_by(BLOCK) {
                let (i1, j1) = ((bi + BLOCK).min(nx), (bj + BLOCK).min(ny));
                let mid = Point::new(
                    origin.x + (bi + BLOCK / 2) as f32 * cell - 0.5 * cell,
                    origin.y + (bj + BLOCK / 2) as f32 * cell - 0.5 * cell,
                );
                let (c, h) = distances(mid);
                let clear = |d: f32| (d - half).abs() > radius && d.abs() > radius;
                if clear(c) && clear(h) {
                    let r = classify(c, h, half);
                    for j in bj..j1 {
                        region[j * nx + bi..j * nx + i1].fill(r);
                    }
                    continue;
                }
                for j in bj..j1 {
                    for i in bi..i1 {
                        let p = Point::new(origin.x + i as f32 * cell, origin.y + j as f32 * cell);
                        let (c, h) = distances(p);
                        region[j * nx + i] = classify(c, h, half);
                    }
                }
            }
        }
        let printable = region.iter().map(|&r| r == Region::Printable).collect();
        Raster {
            origin,
            cell,
            nx,
            ny,
            printable,
            region,
            count: vec![0; nx * ny],
            outside: HashSet::new(),
            last_s: vec![f32::NEG_INFINITY; nx * ny],
            s: 0.0,
            stroke_start: 0.0,
            revisit_after: slice.settings().road_width,
            revisit: Revisit::Once,
        }
    }

    /// The centre of cell `(i, j)`.
    pub fn centre(&self, i: usize, j: usize) -> Point {
        Point::new(
            self.origin.x + i as f32 * self.cell,
            self.origin.y + j as f32 * self.cell,
        )
    }

    /// Number of printable cells.
    pub fn printable_cells(&self) -> usize {
        self.printable.iter().filter(|&&p| p).count()
    }

    /// Cells beyond the grid covered by some stroke (all outside the wall).
    pub fn outside_cells(&self) -> usize {
        self.outside.len()
    }

    /// Forgets every stroke.
    pub fn clear(&mut self) {
        self.count.fill(0);
        self.outside.clear();
        self.last_s.fill(f32::NEG_INFINITY);
        self.s = 0.0;
        self.stroke_start = 0.0;
    }

    /// Starts a new stroke, a continuous road: the segments stamped until the next call are
    /// its consecutive pieces, and `revisit` says how it counts where it comes back over
    /// itself.
    pub fn begin_stroke(&mut self, revisit: Revisit) {
        // A gap wider than the revisit length between strokes: another stroke always counts.
        self.s += 2.0 * self.revisit_after + 1.0;
        self.stroke_start = self.s;
        self.revisit = revisit;
    }

    /// Deposits the road around segment `ab`, the next piece of the current stroke: the hull
    /// of the discs of radius `ra` at `a` and `rb` at `b` (a capsule when they are equal; the
    /// radius tapers linearly along the move). Every grid cell whose centre is in it counts
    /// once more, unless the stroke already covered it ([`Revisit::Once`]) or covered it
    /// less than a road width back along itself ([`Revisit::Again`]; measured at the point of
    /// the segment nearest the cell). `visit` is called for every such grid cell (counted
    /// or not; see [`Hit`]). Cells beyond the grid are recorded in the outside set.
    pub fn stamp_segment(
        &mut self,
        a: Point,
        b: Point,
        ra: f32,
        rb: f32,
        mut visit: impl FnMut(Hit),
    ) {
        // Not both radii a number >= 0 (NaN fails every comparison), or nothing wide.
        if !(ra >= 0.0 && rb >= 0.0) || ra.max(rb) <= 0.0 {
            return;
        }
        let radius = ra.max(rb);
        if !a.is_finite() || !b.is_finite() {
            return;
        }
        let (revisit, stroke_start, s0) = (self.revisit, self.stroke_start, self.s);
        let after = self.revisit_after;
        let cell = self.cell;
        let (ox, oy) = (self.origin.x, self.origin.y);
        let ab = b - a;
        let l2 = ab.norm2();
        let len = l2.sqrt();
        // The taper's slope dr/ds: the point of the move nearest a cell in the sense of the
        // hull lies off the plain projection by `k h / sqrt(1 - k^2)` (h: distance off the
        // line), where the derivative of |p - s| - r(s) vanishes.
        let k = if len > 0.0 { (rb - ra) / len } else { 0.0 };
        let slope = if k.abs() < 1.0 {
            k / (1.0 - k * k).sqrt()
        } else {
            0.0
        };
        let ylo = a.y.min(b.y) - radius;
        let yhi = a.y.max(b.y) + radius;
        let j0 = ((ylo - oy) / cell).floor() as i64;
        let j1 = ((yhi - oy) / cell).ceil() as i64;
        for j in j0..=j1 {
            let y = oy + j as f32 * cell;
            // The capsule of the larger radius holds the hull: a superset of the row.
            let Some((xl, xr)) = capsule_row(a, b, radius, y) else {
                continue;
            };
            // One cell of slack each side; the exact test below decides.
            let i0 = ((xl - ox) / cell).floor() as i64 - 1;
            let i1 = ((xr - ox) / cell).ceil() as i64 + 1;
            let row_on_grid = j >= 0 && (j as usize) < self.ny;
            for i in i0..=i1 {
                let p = Point::new(ox + i as f32 * cell, y);
                let (t, d2, r) = if len > 0.0 && k.abs() >= 1.0 {
                    // One disc holds the other: the larger one is the road.
                    let (c, t) = if rb > ra { (b, 1.0) } else { (a, 0.0) };
                    (t, (c - p).norm2(), radius)
                } else {
                    let t = if len > 0.0 {
                        let u = (p - a).dot(ab) / len;
                        let shift = slope * (p - a).cross(ab).abs() / len;
                        ((u + shift) / len).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    (t, (a + ab * t - p).norm2(), ra + (rb - ra) * t)
                };
                if d2 > r * r {
                    continue;
                }
                if row_on_grid && i >= 0 && (i as usize) < self.nx {
                    let (iu, ju) = (i as usize, j as usize);
                    let k = ju * self.nx + iu;
                    let s = s0 + t * len;
                    let last = self.last_s[k];
                    let again = match revisit {
                        Revisit::Once => last < stroke_start,
                        Revisit::Again => s - last > after,
                    };
                    if again {
                        self.count[k] = self.count[k].saturating_add(1);
                    }
                    self.last_s[k] = s;
                    visit(Hit {
                        k,
                        i: iu,
                        j: ju,
                        region: self.region[k],
                        t,
                        d2,
                    });
                } else {
                    self.outside.insert((i, j));
                }
            }
        }
        self.s = s0 + len;
    }

    /// Deposits one stroke: every cell whose centre is within `radius` of the polyline counts
    /// once more (once per stroke, however the polyline folds).
    pub fn stamp_polyline(&mut self, pts: &[Point], radius: f32) {
        self.begin_stroke(Revisit::Once);
        if pts.len() == 1 {
            self.stamp_segment(pts[0], pts[0], radius, radius, |_| {});
        }
        for w in pts.windows(2) {
            self.stamp_segment(w[0], w[1], radius, radius, |_| {});
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

/// The x-interval where the horizontal line at `y` meets the capsule of radius `r` around
/// segment `ab`, if it does. The capsule is the union of the discs at both ends and the
/// rectangle between them, and it is convex, so its section is the hull of theirs.
fn capsule_row(a: Point, b: Point, r: f32, y: f32) -> Option<(f32, f32)> {
    let mut lo = f32::INFINITY;
    let mut hi = f32::NEG_INFINITY;
    let mut disc = |c: Point| {
        let dy = y - c.y;
        let s = r * r - dy * dy;
        if s >= 0.0 {
            let h = s.sqrt();
            lo = lo.min(c.x - h);
            hi = hi.max(c.x + h);
        }
    };
    disc(a);
    disc(b);
    let d = b - a;
    let len = d.norm();
    if len > 0.0 {
        let n = Point::new(-d.y / len, d.x / len) * r;
        let q = [a + n, b + n, b - n, a - n];
        for k in 0..4 {
            let (p0, p1) = (q[k], q[(k + 1) % 4]);
            if (p0.y - y) * (p1.y - y) > 0.0 {
                continue;
            }
            if p0.y == p1.y {
                lo = lo.min(p0.x.min(p1.x));
                hi = hi.max(p0.x.max(p1.x));
            } else {
                let x = p0.x + (y - p0.y) / (p1.y - p0.y) * (p1.x - p0.x);
                lo = lo.min(x);
                hi = hi.max(x);
            }
        }
    }
    (lo <= hi).then_some((lo, hi))
}
