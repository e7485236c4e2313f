//! Layer metrics on hand-built paths whose answers are known in closed form (areas of capsules,
//! their overlaps, and polygons clipped to a road's band, computed here independently of the
//! raster).

mod common;

use common::{two_holes, A, B, C};
use std::f64::consts::PI;

use hollowpath::geometry::Point;
use hollowpath::toolpath::composition::blend;
use hollowpath::toolpath::{Pattern, Vertex};
use hollowpath::Material;
use host_sim::metrics::{half_l1, measure, measure_with, road_runs, Meter, Options, Revisit};

fn p(x: f64, y: f64) -> Point {
    Point::new(x as f32, y as f32)
}

fn travel(x: f64, y: f64) -> Vertex {
    Vertex {
        at: p(x, y),
        material: A,
        width: 0.4,
        deposit: false,
    }
}

fn dep(x: f64, y: f64) -> Vertex {
    Vertex {
        at: p(x, y),
        material: A,
        width: 0.4,
        deposit: true,
    }
}

fn dist(a: (f64, f64), b: (f64, f64)) -> f64 {
    (b.0 - a.0).hypot(b.1 - a.1)
}

fn no_field(_: Point) -> Option<Material> {
    None
}

/// Area of a capsule of radius `r` around a segment of length `l`.
fn capsule_area(l: f64, r: f64) -> f64 {
    2.0 * r * l + PI * r * r
}

/// Keeps the part of `poly` where `n . q <= c` (Sutherland-Hodgman, one half-plane).
fn clip(poly: &[(f64, f64)], n: (f64, f64), c: f64) -> Vec<(f64, f64)> {
    let inside = |q: (f64, f64)| n.0 * q.0 + n.1 * q.1 <= c;
    let mut out = Vec::new();
    for k in 0..poly.len() {
        let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
        let (fa, fb) = (n.0 * a.0 + n.1 * a.1 - c, n.0 * b.0 + n.1 * b.1 - c);
        if inside(a) {
            out.push(a);
        }
        if (fa < 0.0) != (fb < 0.0) && fa != fb {
            let t = fa / (fa - fb);
            out.push((a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1)));
        }
    }
    out
}

fn area(poly: &[(f64, f64)]) -> f64 {
    let mut s = 0.0;
    for k in 0..poly.len() {
        let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
        s += a.0 * b.1 - b.0 * a.1;
    }
    0.5 * s.abs()
}

/// `poly` clipped to the band of half-width `r` around the line through `a` and `b`.
fn band(poly: &[(f64, f64)], a: (f64, f64), b: (f64, f64), r: f64) -> Vec<(f64, f64)> {
    let l = dist(a, b);
    let n = (-(b.1 - a.1) / l, (b.0 - a.0) / l);
    let c = n.0 * a.0 + n.1 * a.1;
    let half = clip(poly, n, c + r);
    clip(&half, (-n.0, -n.1), -(c - r))
}

fn points(pts: &[Point]) -> Vec<(f64, f64)> {
    pts.iter().map(|q| (q.x as f64, q.y as f64)).collect()
}

fn assert_close(what: &str, got: f64, want: f64, rel: f64) {
    assert!(
        (got - want).abs() <= rel * want.abs(),
        "{what}: got {got:.5}, want {want:.5} (within {:.1} %)",
        rel * 100.0
    );
}

#[test]
fn a_single_straight_road_covers_its_capsule() {
    let slice = two_holes();
    let w = slice.settings().road_width as f64;
    let (a, b) = ((-2.0, -7.0), (3.0, -5.5));
    assert!(slice.is_printable(p(a.0, a.1), 0.0) && slice.is_printable(p(b.0, b.1), 0.0));
    let path = [travel(a.0, a.1), dep(b.0, b.1)];
    let m = measure(&slice, Pattern::Raster, &path, &no_field);
    let l = dist(a, b);
    assert_eq!(m.pattern, "raster");
    assert_eq!(m.starts, 1);
    assert_eq!(m.travel_mm, 0.0);
    assert_close("extruded", m.extruded_mm, l, 1e-6);
    assert_eq!(m.spill, 0.0);
    assert_eq!(m.overfill, 0.0);
    let region = Meter::new(&slice, Options::default()).printable_area();
    assert_close(
        "covered area",
        m.coverage * region,
        w * l + PI * w * w / 4.0,
        0.02,
    );
}

#[test]
fn a_tapered_road_covers_the_hull_of_its_end_discs() {
    // A road widening from 0.2 mm to 1.2 mm over 1 mm covers the hull of a disc of radius
    // 0.1 at one end and 0.6 at the other: the two tangent lines make an angle
    // phi = asin(dr / l) (30 degrees) with the axis, so the hull is the trapezoid between the
    // four tangent points plus the circular segment of each disc beyond it, in closed form.
    // (So steep a taper tells the hull from the union of discs along the plain projection.)
    let slice = two_holes();
    let (a, b) = ((-2.0, -7.0), (-1.0, -7.0));
    let (ra, rb) = (0.1f64, 0.6f64);
    let l = dist(a, b);
    let path = [
        Vertex {
            width: (2.0 * ra) as f32,
            ..travel(a.0, a.1)
        },
        Vertex {
            width: (2.0 * rb) as f32,
            ..dep(b.0, b.1)
        },
    ];
    let m = measure(&slice, Pattern::Raster, &path, &no_field);
    assert_eq!((m.spill, m.overfill), (0.0, 0.0));
    let phi = ((rb - ra) / l).asin();
    // Tangent points at pi/2 + phi from the axis on each disc: chords across them, arcs of
    // pi - 2 phi (the narrow end) and pi + 2 phi (the wide end) beyond.
    let trapezoid = (ra + rb) * phi.cos() * (l + (ra - rb) * phi.sin());
    let segment = |r: f64, arc: f64| r * r / 2.0 * (arc - arc.sin());
    let sectors = segment(ra, PI - 2.0 * phi) + segment(rb, PI + 2.0 * phi);
    let region = Meter::new(&slice, Options::default()).printable_area();
    assert_close(
        "covered area",
        m.coverage * region,
        trapezoid + sectors,
        0.02,
    );
    // Against a capsule of either width it is neither.
    let thin = 2.0 * ra * l + PI * ra * ra;
    assert!(m.coverage * region > 1.2 * thin);
}

#[test]
fn the_printable_area_matches_the_region_at_any_cell_size() {
    // The same region rasterised at 0.1 mm and at 0.025 mm has the same area, and a road the
    // same coverage.
    let slice = two_holes();
    let path = [travel(-2.0, -7.0), dep(3.0, -5.5)];
    let fine = Meter::new(&slice, Options::default()).printable_area();
    let coarse = Meter::new(&slice, Options::with_cell(0.1)).printable_area();
    assert_close("printable area", coarse, fine, 0.01);
    let m_fine = measure(&slice, Pattern::Zigzag, &path, &no_field);
    let m_coarse = measure_with(
        &slice,
        Pattern::Zigzag,
        &path,
        &no_field,
        &Options::with_cell(0.05),
    );
    assert_close("coverage", m_coarse.coverage, m_fine.coverage, 0.03);
}

/// `(x, y)` rotated by `th` about the origin and moved by `o`.
fn place(x: f64, y: f64, th: f64, o: (f64, f64)) -> (f64, f64) {
    let (s, c) = th.sin_cos();
    (o.0 + c * x - s * y, o.1 + s * x + c * y)
}

#[test]
fn two_parallel_roads_half_a_road_apart_overfill_their_overlap() {
    let slice = two_holes();
    let w = slice.settings().road_width as f64;
    let r = w / 2.0;
    let l = 5.0;
    let (th, o) = (0.37, (-1.5, -7.5));
    let (a0, a1) = (place(0.0, 0.0, th, o), place(l, 0.0, th, o));
    let (b0, b1) = (place(0.0, r, th, o), place(l, r, th, o));
    let path = [
        travel(a0.0, a0.1),
        dep(a1.0, a1.1),
        travel(b0.0, b0.1),
        dep(b1.0, b1.1),
    ];
    let opts = Options::default();
    let mut meter = Meter::new(&slice, opts);
    let region = meter.printable_area();
    let m = meter.measure(Pattern::Raster, &path, &no_field);
    assert_eq!(m.starts, 2);
    assert_close("travel", m.travel_mm, dist(a1, b0), 1e-6);
    assert_close("extruded", m.extruded_mm, 2.0 * l, 1e-6);
    // Band of width w/2 along the roads, plus half a lens of two discs r apart at each end.
    let lens = r * r * (2.0 * PI / 3.0 - 3f64.sqrt() / 2.0);
    let overlap = r * l + lens;
    assert_close("overfilled area", m.overfill * region, overlap, 0.03);
    assert_close(
        "covered area",
        m.coverage * region,
        2.0 * capsule_area(l, r) - overlap,
        0.02,
    );
    assert_eq!(m.spill, 0.0);
}

#[test]
fn a_road_overfills_nothing_at_its_own_joints_but_two_roads_do() {
    // An L: one continuous road round a right-angled corner covers the corner once; the same
    // two legs as two roads cover the corner's overlap twice.
    let slice = two_holes();
    let r = slice.settings().road_width as f64 / 2.0;
    let (l1, l2) = (3.0, 2.5);
    let (th, o) = (0.52, (1.0, -6.0));
    let start = place(-l1, 0.0, th, o);
    let corner = place(0.0, 0.0, th, o);
    let end = place(0.0, l2, th, o);
    let mut meter = Meter::new(&slice, Options::default());
    let region = meter.printable_area();
    // Union of the two capsules: the corner's overlap is its disc plus an r x r square, less the
    // quarter of the disc inside that square.
    let overlap = 0.75 * PI * r * r + r * r;
    let union = capsule_area(l1, r) + capsule_area(l2, r) - overlap;

    let one = [
        travel(start.0, start.1),
        dep(corner.0, corner.1),
        dep(end.0, end.1),
    ];
    let m = meter.measure(Pattern::Spiral, &one, &no_field);
    assert_eq!(m.starts, 1);
    assert_eq!(m.overfill, 0.0, "a road's own joint is not overfill");
    assert_close("covered area, one road", m.coverage * region, union, 0.02);

    let two = [
        travel(start.0, start.1),
        dep(corner.0, corner.1),
        travel(corner.0, corner.1),
        dep(end.0, end.1),
    ];
    let m = meter.measure(Pattern::Spiral, &two, &no_field);
    assert_eq!(m.starts, 2);
    assert_eq!(m.travel_mm, 0.0);
    assert_close("covered area, two roads", m.coverage * region, union, 0.02);
    assert_close("overfilled area", m.overfill * region, overlap, 0.06);
}

#[test]
fn a_road_folding_back_over_itself_overfills_where_it_returns() {
    // A hairpin: out along a leg, a connector of w/2, back along a leg w/2 from the first. The
    // legs overlap as two roads would, except within w/2 of the connector, which covers those
    // cells between the two legs' passes (contiguous coverage: the joints).
    let slice = two_holes();
    let r = slice.settings().road_width as f64 / 2.0;
    let l = 5.0;
    let (th, o) = (-0.41, (-2.0, -6.0));
    let corners = [(0.0, 0.0), (l, 0.0), (l, r), (0.0, r)].map(|(x, y)| place(x, y, th, o));
    let path: Vec<Vertex> = corners
        .iter()
        .enumerate()
        .map(|(k, c)| {
            if k == 0 {
                travel(c.0, c.1)
            } else {
                dep(c.0, c.1)
            }
        })
        .collect();
    let mut meter = Meter::new(&slice, Options::default());
    let region = meter.printable_area();
    let m = meter.measure(Pattern::Zigzag, &path, &no_field);
    assert_eq!(m.starts, 1);
    let lens = r * r * (2.0 * PI / 3.0 - 3f64.sqrt() / 2.0);
    assert_close(
        "overfilled area",
        m.overfill * region,
        r * (l - r) + lens / 2.0,
        0.03,
    );
    // Counting each cell once per road hides it.
    let once = Options {
        revisit: Revisit::Once,
        ..Options::default()
    };
    let m_once = measure_with(&slice, Pattern::Zigzag, &path, &no_field, &once);
    assert_eq!(m_once.overfill, 0.0);
    assert_eq!(m_once.coverage, m.coverage);
}

#[test]
fn a_road_through_a_hole_spills_the_hole_area_under_it() {
    let slice = two_holes();
    let r = slice.settings().road_width as f64 / 2.0;
    let (a, b) = ((-14.0, -1.0), (-2.0, 1.2));
    assert!(slice.is_printable(p(a.0, a.1), 0.0) && slice.is_printable(p(b.0, b.1), 0.0));
    // Both ends are farther than a road from the hole: only the band crosses it.
    let hole = points(slice.holes()[0].points());
    for e in [a, b] {
        assert!(slice.holes()[0].signed_distance(p(e.0, e.1)) > 1.0);
    }
    let path = [travel(a.0, a.1), dep(b.0, b.1)];
    let mut meter = Meter::new(&slice, Options::default());
    let region = meter.printable_area();
    let m = meter.measure(Pattern::Zigzag, &path, &no_field);
    let want = area(&band(&hole, a, b, r));
    assert!(want > 1.0, "the band crosses the hole ({want} mm^2)");
    assert!(m.spill > 0.0);
    assert_close("spilt area", m.spill * region, want, 0.02);
    assert_eq!(m.overfill, 0.0);
    assert!(m.coverage * region < capsule_area(dist(a, b), r) - want);
}

#[test]
fn a_road_out_through_the_wall_spills_what_lies_outside() {
    // The road ends 7 mm past the wall, beyond the raster: spill there is counted too.
    let slice = two_holes();
    let r = slice.settings().road_width as f64 / 2.0;
    let (a, b) = ((10.0, -3.0), (25.0, -1.0));
    assert!(slice.is_printable(p(a.0, a.1), 0.0));
    assert!(slice.wall_clearance(p(b.0, b.1)) < -5.0);
    let path = [travel(a.0, a.1), dep(b.0, b.1)];
    let mut meter = Meter::new(&slice, Options::default());
    let region = meter.printable_area();
    let m = meter.measure(Pattern::Raster, &path, &no_field);
    // The wall is convex and the start cap lies inside it: the road's part inside the wall is
    // the band inside the wall beyond the start, plus half the start cap.
    let wall = points(slice.wall().points());
    let l = dist(a, b);
    let d = ((b.0 - a.0) / l, (b.1 - a.1) / l);
    let beyond_start = clip(&wall, (-d.0, -d.1), -(d.0 * a.0 + d.1 * a.1));
    let inside = area(&band(&beyond_start, a, b, r)) + 0.5 * PI * r * r;
    let want = capsule_area(l, r) - inside;
    assert_close("spilt area", m.spill * region, want, 0.02);
}

#[test]
fn two_roads_joined_by_travel_start_twice_and_travel_the_gap() {
    let slice = two_holes();
    let r = slice.settings().road_width as f64 / 2.0;
    let home = (0.0, 0.0);
    let (a0, a1) = ((-2.0, -7.0), (3.0, -6.0));
    let (b0, b1) = ((-1.0, -9.0), (4.0, -8.5));
    let path = [
        travel(home.0, home.1),
        travel(a0.0, a0.1),
        dep(a1.0, a1.1),
        travel(b0.0, b0.1),
        dep(b1.0, b1.1),
    ];
    let mut meter = Meter::new(&slice, Options::default());
    let region = meter.printable_area();
    let m = meter.measure(Pattern::Raster, &path, &no_field);
    assert_eq!(m.starts, 2);
    assert_close("gap", dist(a1, b0), 5.0, 1e-12);
    assert_close("travel", m.travel_mm, dist(home, a0) + 5.0, 1e-6);
    assert_close("extruded", m.extruded_mm, dist(a0, a1) + dist(b0, b1), 1e-6);
    assert_eq!(m.overfill, 0.0);
    assert_eq!(m.spill, 0.0);
    assert_close(
        "covered area",
        m.coverage * region,
        capsule_area(dist(a0, a1), r) + capsule_area(dist(b0, b1), r),
        0.02,
    );
}

#[test]
fn starts_count_valve_openings_only() {
    let slice = two_holes();
    let opts = Options::with_cell(0.1);
    // The first vertex is reached by travel whatever its flag says.
    let path = [dep(-2.0, -7.0), dep(0.0, -7.0), dep(0.0, -6.0)];
    let m = measure_with(&slice, Pattern::Zigzag, &path, &no_field, &opts);
    assert_eq!(m.starts, 1);
    assert_close("extruded", m.extruded_mm, 3.0, 1e-6);
    assert_eq!(road_runs(&path), vec![0..3]);
    // Only travel: nothing deposited.
    let path = [travel(-2.0, -7.0), travel(0.0, -7.0), travel(0.0, -6.0)];
    let m = measure_with(&slice, Pattern::Zigzag, &path, &no_field, &opts);
    assert_eq!((m.starts, m.coverage, m.extruded_mm), (0, 0.0, 0.0));
    assert_close("travel", m.travel_mm, 3.0, 1e-6);
    assert!(road_runs(&path).is_empty());
    // Three roads with travel between them, and an empty path.
    let path = [
        travel(-2.0, -7.0),
        dep(-1.0, -7.0),
        travel(0.0, -7.0),
        dep(1.0, -7.0),
        dep(1.0, -6.0),
        travel(2.0, -6.0),
        dep(3.0, -6.0),
    ];
    let m = measure_with(&slice, Pattern::Zigzag, &path, &no_field, &opts);
    assert_eq!(m.starts, 3);
    assert_eq!(road_runs(&path), vec![0..2, 2..5, 5..7]);
    let m = measure_with(&slice, Pattern::Zigzag, &[], &no_field, &opts);
    assert_eq!((m.starts, m.travel_mm, m.coverage), (0, 0.0, 0.0));
}

#[test]
fn composition_error_compares_the_blend_along_the_road_with_the_field() {
    let slice = two_holes();
    let r = slice.settings().road_width as f64 / 2.0;
    let (a, b) = ((-2.0, -7.0), (3.0, -5.5));
    let path = [
        Vertex {
            at: p(a.0, a.1),
            material: A,
            width: 0.4,
            deposit: false,
        },
        Vertex {
            at: p(b.0, b.1),
            material: B,
            width: 0.4,
            deposit: true,
        },
    ];
    let l = dist(a, b);
    // Parameter along the road of the point nearest to q.
    let along = move |q: Point| {
        let t = ((q.x as f64 - a.0) * (b.0 - a.0) + (q.y as f64 - a.1) * (b.1 - a.1)) / (l * l);
        t.clamp(0.0, 1.0) as f32
    };
    let every_cell = Options {
        composition_stride: 1,
        ..Options::default()
    };
    let same = move |q: Point| Some(blend(&A, &B, along(q)));
    let m = measure_with(&slice, Pattern::Spiral, &path, &same, &every_cell);
    // As printed the mix steps along the road (one mix per move, each within MIX_TOLERANCE
    // of the blend): off by half a step on average, and not exactly the blend.
    let step = hollowpath::toolpath::moves::MIX_TOLERANCE as f64;
    assert!(
        m.composition_error < 0.5 * step + 1e-3,
        "{}",
        m.composition_error
    );
    assert!(m.composition_error > 0.25 * step, "{}", m.composition_error);

    // The field running the other way: error |1 - 2t| along the band (mean 1/2), 1 in the caps.
    let reversed = move |q: Point| Some(blend(&B, &A, along(q)));
    let want = (2.0 * r * l * 0.5 + PI * r * r) / capsule_area(l, r);
    let m = measure_with(&slice, Pattern::Spiral, &path, &reversed, &every_cell);
    assert_close("reversed, every cell", m.composition_error, want, 0.02);
    let m = measure(&slice, Pattern::Spiral, &path, &reversed);
    assert_close("reversed, sampled", m.composition_error, want, 0.05);

    // Constant fields: exact answers.
    let road_a = [travel(a.0, a.1), dep(b.0, b.1)];
    let m = measure(&slice, Pattern::Spiral, &road_a, &|_| Some(C));
    assert_close("disjoint", m.composition_error, 1.0, 1e-6);
    let m = measure(&slice, Pattern::Spiral, &road_a, &|_| {
        Some([0.5, 0.5, 0.0, 0.0])
    });
    assert_close("half", m.composition_error, 0.5, 1e-6);
    let m = measure(&slice, Pattern::Spiral, &road_a, &no_field);
    assert_eq!(m.composition_error, 0.0);
}

#[test]
fn each_cell_takes_the_composition_of_its_nearest_road() {
    // Two roads of different materials, far apart: each cell takes its own road's composition,
    // so a field equal to A left of x = 0 and B right of it has no error.
    let slice = two_holes();
    let left = [(-3.0, -7.0), (-1.0, -6.0)];
    let right = [(1.0, -7.0), (3.0, -6.0)];
    let v = |q: (f64, f64), m: Material, deposit: bool| Vertex {
        at: p(q.0, q.1),
        material: m,
        width: 0.4,
        deposit,
    };
    let path = [
        v(left[0], A, false),
        v(left[1], A, true),
        v(right[0], B, false),
        v(right[1], B, true),
    ];
    let split = |q: Point| Some(if q.x < 0.0 { A } else { B });
    let m = measure(&slice, Pattern::Raster, &path, &split);
    assert_eq!(m.composition_error, 0.0);
    let swapped = |q: Point| Some(if q.x < 0.0 { B } else { A });
    let m = measure(&slice, Pattern::Raster, &path, &swapped);
    assert_close("swapped", m.composition_error, 1.0, 1e-9);
}

/// The point at distance `d` from the boundary along the ray from `from` towards `to`, where
/// `f` (a 1-Lipschitz distance) falls through `d`, by bisection.
fn at_distance(f: impl Fn(Point) -> f32, from: (f64, f64), to: (f64, f64), d: f32) -> Point {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    let at = |t: f64| p(from.0 + t * (to.0 - from.0), from.1 + t * (to.1 - from.1));
    assert!((f(at(lo)) - d) * (f(at(hi)) - d) < 0.0);
    let above = f(at(lo)) > d;
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if (f(at(mid)) > d) == above {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    at(0.5 * (lo + hi))
}

/// A vertex of a 0.4 mm road.
fn road_vertex(at: Point, material: Material, deposit: bool) -> Vertex {
    Vertex {
        at,
        material,
        width: 0.4,
        deposit,
    }
}

/// `path`'s `feature_composition_error` on `slice` (a 0.1 mm raster).
fn keep_out_error(slice: &hollowpath::Slice, path: &[Vertex]) -> f64 {
    measure_with(
        slice,
        Pattern::Zigzag,
        path,
        &no_field,
        &Options::with_cell(0.1),
    )
    .feature_composition_error
}

#[test]
fn feature_composition_error_is_the_worst_keep_out_vertex() {
    let slice = two_holes();
    let half = slice.settings().road_width / 2.0;
    let hole = &slice.holes()[0];
    assert_eq!(hole.material(), B);
    assert_eq!(slice.wall().material(), A);
    // On hole 0's keep-out curve (right of it) and on the wall's (right end of the ellipse).
    let on_hole = at_distance(|q| hole.signed_distance(q), (-8.0, 0.5), (0.0, 0.5), half);
    let on_wall = at_distance(|q| slice.wall_clearance(q), (15.0, 0.3), (20.0, 0.3), half);
    assert!((hole.signed_distance(on_hole) - half).abs() < 1e-4);
    assert!((slice.wall_clearance(on_wall) - half).abs() < 1e-4);
    let mid = p(2.0, -6.0);
    let v = road_vertex;
    let run = |path: &[Vertex]| keep_out_error(&slice, path);
    let near_b = [0.7, 0.3, 0.0, 0.0];
    let near_a = [0.9, 0.1, 0.0, 0.0];
    // A road starts on the hole's curve (0.7 off its material) and ends on the wall's (0.1 off).
    let path = [
        v(on_hole, near_b, false),
        v(mid, B, true),
        v(on_wall, near_a, true),
    ];
    assert!((run(&path) - 0.7).abs() < 1e-6, "{}", run(&path));
    assert!((half_l1(&near_b, &B) - 0.7).abs() < 1e-6);
    // Right material at the hole: the wall's 0.1 is the worst.
    let path = [
        v(on_hole, B, false),
        v(mid, B, true),
        v(on_wall, near_a, true),
    ];
    assert!((run(&path) - 0.1).abs() < 1e-6, "{}", run(&path));
    // Right materials at both: none.
    let path = [
        v(on_hole, B, false),
        v(mid, near_b, true),
        v(on_wall, A, true),
    ];
    assert_eq!(run(&path), 0.0);
    // A vertex only passed by travel deposits nothing there.
    let path = [
        v(mid, A, false),
        v(on_hole, C, false),
        v(mid, A, false),
        v(p(3.0, -6.0), A, true),
    ];
    assert_eq!(run(&path), 0.0);
    // Off the curve (a road width away), a wrong material is not judged here.
    let off = at_distance(
        |q| hole.signed_distance(q),
        (-8.0, 0.5),
        (0.0, 0.5),
        2.0 * half,
    );
    let path = [v(off, C, false), v(mid, C, true)];
    assert_eq!(run(&path), 0.0);
}

#[test]
fn metrics_serialise_with_their_names() {
    let slice = two_holes();
    let path = [travel(-2.0, -7.0), dep(3.0, -5.5)];
    let m = measure_with(
        &slice,
        Pattern::Raster,
        &path,
        &no_field,
        &Options::with_cell(0.1),
    );
    let json = serde_json::to_value(&m).unwrap();
    for key in [
        "pattern",
        "starts",
        "travel_mm",
        "extruded_mm",
        "coverage",
        "overfill",
        "spill",
        "composition_error",
        "feature_composition_error",
    ] {
        assert!(json.get(key).is_some(), "missing {key}");
    }
    assert_eq!(json["starts"], 1);
    assert_eq!(json["pattern"], "raster");
}

/// Every start after the first is explained: a short break at a pinch narrower than
/// `min_width`, a short break where the road is wide enough (a move left out), and a long
/// travel to a separate piece, which carries the layer's own reason.
#[test]
fn every_extra_start_is_explained() {
    use host_sim::metrics::explain_starts;
    let slice = two_holes();
    let path = vec![
        dep(-2.0, 11.95),
        dep(-0.1, 11.95),
        travel(0.1, 11.95),
        dep(2.0, 11.95),
        dep(2.0, 8.0),
        dep(0.1, 8.0),
        travel(-0.1, 8.0),
        dep(-2.0, 8.0),
        travel(-2.0, -8.0),
        dep(2.0, -8.0),
    ];
    let notes = explain_starts(&slice, &path, "2 pieces: loops lie apart");
    assert_eq!(notes.len(), 3, "{notes:?}");
    assert!(notes[0].why.contains("pinch") && notes[0].why.contains("min_width"));
    assert!((notes[0].travel_mm - 0.2).abs() < 1e-4, "{notes:?}");
    assert!(notes[1].why.contains("did not fit"), "{notes:?}");
    assert!(notes[2].why.contains("separate piece") && notes[2].why.contains("loops lie apart"));
    assert_eq!(notes[2].at, [-2.0, -8.0]);
    assert!((notes[2].travel_mm - 16.0).abs() < 1e-4);
    // One start, nothing to explain.
    assert!(explain_starts(&slice, &path[..2], "").is_empty());
}

/// Where two features are closer than a road their keep-out bands overlap and their curves
/// cross, and a point on both can hold only one material: it deviates by the smaller of the
/// two (before, by the larger, so every such point counted as laid in the wrong material,
/// whichever it held). Within the other's band, off its curve, the same.
#[test]
fn a_point_on_two_keep_out_curves_holds_either_feature_s_material() {
    use hollowpath::{Feature, FeatureId, Settings, Slice};
    let square = |x0: f64| [p(x0, -1.0), p(x0 + 2.0, -1.0), p(x0 + 2.0, 1.0), p(x0, 1.0)];
    let wall = [
        p(-10.0, -10.0),
        p(10.0, -10.0),
        p(10.0, 10.0),
        p(-10.0, 10.0),
    ];
    let wall = Feature::new(FeatureId::Wall, &wall, A).unwrap();
    // Two squares 0.2 mm apart at 0.4 mm roads: their curves cross above and below the gap.
    let left = Feature::new(FeatureId::Hole(0), &square(-2.1), B).unwrap();
    let right = Feature::new(FeatureId::Hole(1), &square(0.1), C).unwrap();
    let slice = Slice::new(wall, &[left, right], Settings::for_road_width(0.4)).unwrap();
    let half = 0.2f32;
    // Half a road from both squares' near corners, (-0.1, 1) and (0.1, 1).
    let both = p(0.0, 1.0 + (0.2f64 * 0.2 - 0.1 * 0.1).sqrt());
    for h in slice.holes() {
        assert!((h.signed_distance(both) - half).abs() < 1e-4);
    }
    let mid = p(5.0, 5.0);
    let run_at = |at: Point, material: Material| {
        let path = [
            road_vertex(at, material, false),
            road_vertex(mid, material, true),
        ];
        keep_out_error(&slice, &path)
    };
    let run = |material: Material| run_at(both, material);
    assert_eq!(run(B), 0.0);
    assert_eq!(run(C), 0.0);
    // Neither hole's material: off by the smaller of the two deviations.
    assert!((run(A) - 1.0).abs() < 1e-9);
    let mixed = [0.0, 0.7, 0.3, 0.0];
    assert!((run(mixed) - 0.3).abs() < 1e-6, "{}", run(mixed));
    // On the left square's curve, 0.126 mm from the right square (inside its band): either.
    let inside = p(0.1 * 0.6, 1.0 + (0.2f64 * 0.2 - 0.16 * 0.16).sqrt());
    assert!((slice.holes()[0].signed_distance(inside) - half).abs() < 1e-4);
    assert!(slice.holes()[1].signed_distance(inside) < half - 0.01);
    assert_eq!(run_at(inside, B), 0.0);
    assert_eq!(run_at(inside, C), 0.0);
    assert!((run_at(inside, A) - 1.0).abs() < 1e-9);
    // Beyond the right square's band, the left square's curve is its own.
    let own = p(-2.3, 0.0);
    assert!((run_at(own, C) - 1.0).abs() < 1e-9);
    assert_eq!(run_at(own, B), 0.0);
}
