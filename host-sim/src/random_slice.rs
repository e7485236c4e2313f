//! Random scaffold slices, drawn the way a lab's slices vary: the benchmark of distributions
//! (`cargo bench -p host-sim --bench random`) and the property tests plan them, so no constant
//! is tuned on the four reference slices alone.
//!
//! A slice is drawn from a seed (the same seed, the same slice, on every machine): a road width
//! of 0.2-0.8 mm, a wall 40-120 road widths across, convex (circle, ellipse, rounded rectangle)
//! or concave (a lobed blob), and 1 to `max_holes` hollow features of random shape (circles,
//! ellipses, rounded rectangles, stars, concave blobs), 2-12 road widths in radius, rotated,
//! placed at random at least [`Draw::gap`] road widths from the wall and from each other (a
//! hole that does not fit is drawn again, a few times, then left out). Contours have a vertex
//! every quarter road width or so (at least 16, at most [`MAX_VERTICES`]).

use hollowpath::config::{CHANNELS, MAX_HOLES, MAX_VERTICES};
use hollowpath::geometry::Point;
use hollowpath::{Feature, FeatureId, Material, Settings, Slice};

/// A small, fast, seedable generator (SplitMix64): the same seed gives the same slice
/// everywhere.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator from `seed`.
    pub fn new(seed: u64) -> Rng {
        Rng(seed ^ 0x9E37_79B9_7F4A_7C15)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        let u = (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32;
        lo + (hi - lo) * u
    }

    /// Uniform in `lo..=hi`.
    pub fn int(&mut self, lo: usize, hi: usize) -> usize {
        lo + (self.next_u64() % (hi - lo + 1) as u64) as usize
    }
}

/// The shapes a feature is drawn from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// A circle.
    Circle,
    /// An ellipse of aspect up to 3.
    Ellipse,
    /// A rounded rectangle of aspect up to 3.
    RoundedRect,
    /// A star of 4-8 points.
    Star,
    /// A concave blob (a few harmonics on a circle).
    Blob,
}

const HOLE_SHAPES: [Shape; 5] = [
    Shape::Circle,
    Shape::Ellipse,
    Shape::RoundedRect,
    Shape::Star,
    Shape::Blob,
];

/// How slices are drawn.
#[derive(Clone, Copy, Debug)]
pub struct Draw {
    /// Most hollow features (at most the core's [`MAX_HOLES`]).
    pub max_holes: usize,
    /// Road width range, mm.
    pub road_width: (f32, f32),
    /// Least distance between features (hole to hole, hole to wall), in road widths.
    pub gap: f32,
}

impl Default for Draw {
    fn default() -> Self {
        Draw {
            max_holes: 64.min(MAX_HOLES),
            road_width: (0.2, 0.8),
            gap: 1.5,
        }
    }
}

/// A random slice and what it was drawn as.
#[derive(Clone, Debug)]
pub struct RandomSlice {
    /// The seed it was drawn from.
    pub seed: u64,
    /// The slice.
    pub slice: Slice,
    /// A line describing it (wall shape, holes and their shapes, road width).
    pub description: String,
}

/// The outline of `shape` around `c`: radius `r`, aspect `aspect` (x over y), rotated by `rot`,
/// with `n` vertices; `k`, `depth` shape the star's points and the blob's lobes.
#[allow(clippy::too_many_arguments)]
fn outline(
    shape: Shape,
    c: Point,
    r: f32,
    aspect: f32,
    rot: f32,
    k: u32,
    depth: f32,
    phase: f32,
    n: usize,
) -> Vec<Point> {
    let (sx, sy) = (r * aspect.sqrt(), r / aspect.sqrt());
    let (s, co) = rot.sin_cos();
    (0..n)
        .map(|i| {
            let t = i as f32 / n as f32 * core::f32::consts::TAU;
            let (x, y) = match shape {
                Shape::Circle => (r * t.cos(), r * t.sin()),
                Shape::Ellipse => (sx * t.cos(), sy * t.sin()),
                Shape::RoundedRect => {
                    // A superellipse of exponent 6: flat sides, round corners.
                    let f = |v: f32| v.signum() * v.abs().powf(1.0 / 3.0);
                    (sx * f(t.cos()), sy * f(t.sin()))
                }
                Shape::Star => {
                    // Radius between depth r and r, a smooth-ish point every 1/k turn.
                    let m = 0.5 + 0.5 * (k as f32 * t + phase).cos();
                    let rr = r * (depth + (1.0 - depth) * m * m);
                    (rr * t.cos(), rr * t.sin())
                }
                Shape::Blob => {
                    let rr = r
                        * (1.0
                            + depth * (k as f32 * t + phase).cos()
                            + 0.5 * depth * ((k + 1) as f32 * t + 2.0 * phase).sin());
                    (sx / r * rr * t.cos(), sy / r * rr * t.sin())
                }
            };
            Point::new(c.x + co * x - s * y, c.y + s * x + co * y)
        })
        .collect()
}

/// Vertices for a contour of radius `r` at road width `w`: one every quarter road or so.
fn vertices_for(r: f32, w: f32) -> usize {
    ((core::f32::consts::TAU * r / (0.25 * w)) as usize).clamp(16, MAX_VERTICES)
}

/// The material of hole `k`: one of the channels other than the wall's, in turn.
fn hole_material(k: usize) -> Material {
    let mut m = [0.0; CHANNELS];
    m[1 + k % (CHANNELS - 1)] = 1.0;
    m
}

/// Draws the slice of `seed`. `None` when no hole fitted or the core refused the drawing (a
/// drawn contour that crosses itself, say): draw the next seed.
pub fn draw(seed: u64, how: &Draw) -> Option<RandomSlice> {
    let mut rng = Rng::new(seed);
    let w = rng.range(how.road_width.0, how.road_width.1);
    let radius = 0.5 * w * rng.range(40.0, 120.0);
    let wall_shape = [
        Shape::Circle,
        Shape::Ellipse,
        Shape::RoundedRect,
        Shape::Blob,
    ][rng.int(0, 3)];
    let wall_pts = outline(
        wall_shape,
        Point::new(0.0, 0.0),
        radius,
        rng.range(1.0, 1.8),
        rng.range(0.0, 3.2),
        rng.int(2, 4) as u32,
        rng.range(0.08, 0.2),
        rng.range(0.0, 6.3),
        vertices_for(radius, w),
    );
    let mut wall_material = [0.0; CHANNELS];
    wall_material[0] = 1.0;
    let wall = Feature::new(FeatureId::Wall, &wall_pts, wall_material).ok()?;
    let want = rng.int(1, how.max_holes.clamp(1, MAX_HOLES));
    let gap = how.gap * w;
    let mut holes: Vec<Feature> = Vec::new();
    let mut shapes = Vec::new();
    for _ in 0..want {
        for _try in 0..12 {
            let shape = HOLE_SHAPES[rng.int(0, HOLE_SHAPES.len() - 1)];
            let r = w * rng.range(2.0, 12.0).min(0.4 * radius / w);
            let c = Point::new(rng.range(-0.9, 0.9) * radius, rng.range(-0.9, 0.9) * radius);
            let depth = match shape {
                Shape::Star => rng.range(0.45, 0.8),
                _ => rng.range(0.1, 0.25),
            };
            let pts = outline(
                shape,
                c,
                r,
                rng.range(1.0, 3.0),
                rng.range(0.0, 3.2),
                rng.int(3, 8) as u32,
                depth,
                rng.range(0.0, 6.3),
                vertices_for(r, w),
            );
            let inside = pts.iter().all(|&p| wall.signed_distance(p) < -gap);
            let apart = holes.iter().all(|o| {
                pts.iter().all(|&p| o.signed_distance(p) > gap)
                    && o.points()
                        .iter()
                        .all(|&q| pts.iter().all(|&p| p.dist(q) > gap))
            });
            if !(inside && apart) {
                continue;
            }
            let id = FeatureId::Hole(u8::try_from(holes.len()).ok()?);
            let Ok(f) = Feature::new(id, &pts, hole_material(holes.len())) else {
                continue;
            };
            holes.push(f);
            shapes.push(shape);
            break;
        }
    }
    if holes.is_empty() {
        return None;
    }
    let slice = Slice::new(wall, &holes, Settings::for_road_width(w)).ok()?;
    let description = format!(
        "seed {seed}: road {w:.3} mm, {wall_shape:?} wall {:.1} mm across, {} holes {:?}",
        2.0 * radius,
        holes.len(),
        shapes
    );
    Some(RandomSlice {
        seed,
        slice,
        description,
    })
}

/// Regular arrays of round channels in a square wall, as a scaffold's designer lays them out
/// (random slices place their holes at random, so the ties a lattice makes, cells of equal
/// size meeting four or three at a point, never occur there): square and hexagonal arrays of
/// 3 x 3, 4 x 4 and 6 x 6 channels of radius 0.25 and 0.5 mm, 2 and 3 mm apart, at 0.25 and
/// 0.4 mm roads, the wall a pitch beyond the outer channels; 48 slices, numbered from 1 in
/// `seed`.
pub fn lattices() -> Vec<RandomSlice> {
    let mut out = Vec::new();
    for w in [0.25f32, 0.4] {
        for radius in [0.25f32, 0.5] {
            for pitch in [2.0f32, 3.0] {
                for k in [3usize, 4, 6] {
                    for hex in [false, true] {
                        let seed = out.len() as u64 + 1;
                        if let Some(r) = lattice(seed, w, radius, pitch, k, hex) {
                            out.push(r);
                        }
                    }
                }
            }
        }
    }
    out
}

/// A `k` x `k` array of channels of radius `radius`, `pitch` apart (rows shifted by half a
/// pitch and `sqrt(3) / 2` pitch apart if `hex`), in a square wall a pitch beyond them.
fn lattice(seed: u64, w: f32, radius: f32, pitch: f32, k: usize, hex: bool) -> Option<RandomSlice> {
    let row = if hex { 0.866_025_4 * pitch } else { pitch };
    let centres: Vec<Point> = (0..k)
        .flat_map(|j| {
            let shift = if hex && j % 2 == 1 { 0.5 * pitch } else { 0.0 };
            (0..k).map(move |i| Point::new(i as f32 * pitch + shift, j as f32 * row))
        })
        .collect();
    let (x1, y1) = (
        (k - 1) as f32 * pitch + if hex { 0.5 * pitch } else { 0.0 },
        (k - 1) as f32 * row,
    );
    let wall_pts = [
        Point::new(-pitch, -pitch),
        Point::new(x1 + pitch, -pitch),
        Point::new(x1 + pitch, y1 + pitch),
        Point::new(-pitch, y1 + pitch),
    ];
    let mut wall_material = [0.0; CHANNELS];
    wall_material[0] = 1.0;
    let wall = Feature::new(FeatureId::Wall, &wall_pts, wall_material).ok()?;
    let mut holes = Vec::new();
    for (n, &c) in centres.iter().enumerate() {
        let pts = outline(
            Shape::Circle,
            c,
            radius,
            1.0,
            0.0,
            0,
            0.0,
            0.0,
            vertices_for(radius, w),
        );
        let id = FeatureId::Hole(u8::try_from(n).ok()?);
        holes.push(Feature::new(id, &pts, hole_material(n)).ok()?);
    }
    let slice = Slice::new(wall, &holes, Settings::for_road_width(w)).ok()?;
    let description = format!(
        "lattice {seed}: road {w:.3} mm, {} {k} x {k} channels of radius {radius} mm, {pitch} mm apart",
        if hex { "hexagonal" } else { "square" }
    );
    Some(RandomSlice {
        seed,
        slice,
        description,
    })
}

/// The first `count` slices drawn from seeds `first..` (seeds that draw nothing are skipped).
pub fn draw_many(first: u64, count: usize, how: &Draw) -> Vec<RandomSlice> {
    (first..).filter_map(|s| draw(s, how)).take(count).collect()
}

/// The slice as a slice file (`SLICE_FORMAT.md`), to look at or plan a drawn slice again.
pub fn to_json(slice: &Slice, name: &str) -> String {
    let pts = |f: &Feature| {
        f.points()
            .iter()
            .map(|p| serde_json::json!([p.x, p.y]))
            .collect::<Vec<_>>()
    };
    let feature = |f: &Feature| serde_json::json!({"points": pts(f), "material": f.material()});
    let s = slice.settings();
    serde_json::to_string_pretty(&serde_json::json!({
        "name": name,
        "units": "mm",
        "outer": feature(slice.wall()),
        "holes": slice.holes().iter().map(feature).collect::<Vec<_>>(),
        // A drawn slice's features are built as drawn; read back, contours of more than
        // `SIMPLIFY_ABOVE_VERTICES` vertices would be simplified within the default
        // tolerance and plan differently: a tolerance of 0 keeps them as drawn.
        "settings": {
            "road_width": s.road_width,
            "layer_height": s.layer_height,
            "simplify_tolerance": 0.0,
        },
    }))
    .expect("a slice is plain JSON")
}
