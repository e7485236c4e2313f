//! Every kind of invalid slice is refused with its own error naming the feature and reason.

mod common;

use common::{circle, feature, A, B, WALL};
use hollowpath::geometry::Point;
use hollowpath::{Error, Feature, FeatureId, Limit, SettingId, Settings, Slice};

fn pts(v: &[(f32, f32)]) -> Vec<Point> {
    v.iter().map(|&(x, y)| Point::new(x, y)).collect()
}

fn square(c: (f32, f32), r: f32) -> Vec<Point> {
    pts(&[
        (c.0 - r, c.1 - r),
        (c.0 + r, c.1 - r),
        (c.0 + r, c.1 + r),
        (c.0 - r, c.1 + r),
    ])
}

fn wall() -> Feature {
    feature(FeatureId::Wall, &square((0.0, 0.0), 10.0), WALL)
}

fn hole(i: u8, p: &[Point]) -> Result<Feature, Error> {
    Feature::new(FeatureId::Hole(i), p, A)
}

fn slice_err(holes: &[Feature]) -> Error {
    Slice::new(wall(), holes, Settings::default()).unwrap_err()
}

#[test]
fn polygon_errors() {
    let h = FeatureId::Hole(3);
    assert_eq!(
        Feature::new(h, &pts(&[(0.0, 0.0), (1.0, 0.0)]), A),
        Err(Error::TooFewPoints {
            feature: h,
            distinct: 2
        })
    );
    // Repeats do not count as distinct points.
    assert_eq!(
        Feature::new(
            h,
            &pts(&[(0.0, 0.0), (1.0, 0.0), (0.0, 0.0), (1.0, 0.0)]),
            A
        ),
        Err(Error::TooFewPoints {
            feature: h,
            distinct: 2
        })
    );
    assert_eq!(
        Feature::new(h, &pts(&[(0.0, 0.0), (1.0, f32::NAN), (0.0, 1.0)]), A),
        Err(Error::NonFinite {
            feature: h,
            vertex: 1
        })
    );
    assert_eq!(
        Feature::new(h, &pts(&[(0.0, 0.0), (1.0, 0.0), (f32::INFINITY, 1.0)]), A),
        Err(Error::NonFinite {
            feature: h,
            vertex: 2
        })
    );
    assert_eq!(
        Feature::new(h, &pts(&[(0.0, 0.0), (5000.0, 0.0), (0.0, 1.0)]), A),
        Err(Error::OutOfRange {
            feature: h,
            vertex: 1
        })
    );
    assert_eq!(
        Feature::new(h, &pts(&[(0.0, 0.0), (1.0, 1.0), (2.0, 2.0)]), A),
        Err(Error::ZeroArea { feature: h })
    );
    assert_eq!(
        Feature::new(
            h,
            &pts(&[(0.0, 0.0), (4.0, 4.0), (4.0, 0.0), (0.0, 2.0)]),
            A
        ),
        Err(Error::SelfIntersection {
            feature: h,
            edge_a: 0,
            edge_b: 2
        })
    );
    let over = hollowpath::config::MAX_VERTICES as u32 + 44;
    let many = circle(0.0, 0.0, 5.0, over as usize, 0.0);
    assert_eq!(
        Feature::new(FeatureId::Wall, &many, WALL),
        Err(Error::TooManyVertices {
            feature: FeatureId::Wall,
            vertices: over,
            simplified: false
        })
    );
}

#[test]
fn a_bow_tie_is_self_intersecting_not_empty() {
    // Two lobes of equal area and opposite turn: no net area, but the fault is the crossing.
    let h = FeatureId::Hole(0);
    assert_eq!(
        Feature::new(
            h,
            &pts(&[(0.0, 0.0), (2.0, 2.0), (2.0, 0.0), (0.0, 2.0)]),
            A
        ),
        Err(Error::SelfIntersection {
            feature: h,
            edge_a: 0,
            edge_b: 2
        })
    );
    // Points on one line still enclose no area.
    assert_eq!(
        Feature::new(
            h,
            &pts(&[(0.0, 0.0), (1.0, 1.0), (2.0, 2.0), (3.0, 3.0)]),
            A
        ),
        Err(Error::ZeroArea { feature: h })
    );
}

#[test]
fn a_repeated_closing_point_does_not_count_against_the_vertex_limit() {
    let n = hollowpath::config::MAX_VERTICES;
    let mut ring = circle(0.0, 0.0, 5.0, n, 0.0);
    let full = Feature::new(FeatureId::Wall, &ring, WALL).unwrap();
    ring.push(ring[0]);
    let closed = Feature::new(FeatureId::Wall, &ring, WALL).unwrap();
    assert_eq!(closed.points(), full.points());
    assert_eq!(closed.points().len(), n);
    // One vertex more is still refused.
    let more = circle(0.0, 0.0, 5.0, n + 1, 0.0);
    assert_eq!(
        Feature::new(FeatureId::Wall, &more, WALL),
        Err(Error::TooManyVertices {
            feature: FeatureId::Wall,
            vertices: n as u32 + 1,
            simplified: false
        })
    );
}

#[test]
fn material_errors() {
    let p = square((0.0, 0.0), 1.0);
    assert_eq!(
        Feature::new(FeatureId::Hole(0), &p, [0.5, -0.1, 0.6, 0.0]),
        Err(Error::MaterialNegative {
            feature: FeatureId::Hole(0),
            channel: 1
        })
    );
    assert_eq!(
        Feature::new(FeatureId::Hole(0), &p, [0.5, f32::NAN, 0.5, 0.0]),
        Err(Error::MaterialNegative {
            feature: FeatureId::Hole(0),
            channel: 1
        })
    );
    assert!(matches!(
        Feature::new(FeatureId::Wall, &p, [0.5, 0.2, 0.0, 0.0]),
        Err(Error::MaterialSum {
            feature: FeatureId::Wall,
            ..
        })
    ));
    // Either orientation, and a repeated closing point, are fine.
    let mut cw = p.clone();
    cw.reverse();
    cw.push(cw[0]);
    assert_eq!(
        Feature::new(FeatureId::Hole(0), &cw, A)
            .unwrap()
            .points()
            .len(),
        4
    );
}

#[test]
fn hole_placement_errors() {
    // A vertex outside the wall.
    let out = hole(0, &pts(&[(5.0, 5.0), (12.0, 5.0), (5.0, 8.0)])).unwrap();
    assert_eq!(
        slice_err(&[out]),
        Error::HoleOutsideWall { hole: 0, vertex: 1 }
    );
    // A vertex exactly on the wall is not strictly inside.
    let on = hole(0, &pts(&[(5.0, 5.0), (10.0, 5.0), (5.0, 8.0)])).unwrap();
    assert_eq!(
        slice_err(&[on]),
        Error::HoleOutsideWall { hole: 0, vertex: 1 }
    );
    // All vertices inside a U-shaped wall, but an edge crosses the notch.
    let u = feature(
        FeatureId::Wall,
        &pts(&[
            (-10.0, -10.0),
            (10.0, -10.0),
            (10.0, 10.0),
            (2.0, 10.0),
            (2.0, 0.0),
            (-2.0, 0.0),
            (-2.0, 10.0),
            (-10.0, 10.0),
        ]),
        WALL,
    );
    let bridge = hole(0, &pts(&[(-5.0, 5.0), (5.0, 5.0), (5.0, 6.0), (-5.0, 6.0)])).unwrap();
    assert!(matches!(
        Slice::new(u, &[bridge], Settings::default()),
        Err(Error::HoleCrossesWall { hole: 0, .. })
    ));
    // Overlapping and nested holes.
    let a = hole(0, &square((0.0, 0.0), 2.0)).unwrap();
    let b = hole(1, &square((1.0, 1.0), 2.0)).unwrap();
    assert_eq!(
        slice_err(&[a.clone(), b]),
        Error::HolesOverlap { a: 0, b: 1 }
    );
    let small = hole(1, &square((0.5, 0.5), 0.5)).unwrap();
    assert_eq!(
        slice_err(&[a.clone(), small.clone()]),
        Error::HolesNested { outer: 0, inner: 1 }
    );
    assert_eq!(
        slice_err(&[small, a]),
        Error::HolesNested { outer: 1, inner: 0 }
    );
    // Touching holes overlap.
    let left = hole(0, &square((-1.0, 0.0), 1.0)).unwrap();
    let right = Feature::new(FeatureId::Hole(1), &square((1.0, 0.0), 1.0), B).unwrap();
    assert_eq!(
        slice_err(&[left, right]),
        Error::HolesOverlap { a: 0, b: 1 }
    );
}

#[test]
fn slice_level_errors() {
    // A wall alone (a cap layer) is a valid slice; only the MCL layers refuse it.
    let cap = Slice::new(wall(), &[], Settings::default()).unwrap();
    assert!(cap.holes().is_empty());
    // One more than the build holds (8 on the MCU, 64 on the host), on a 9 x 9 grid.
    let n = hollowpath::config::MAX_HOLES + 1;
    let holes: Vec<Feature> = (0..n)
        .map(|k| {
            let at = (-8.0 + 2.0 * (k % 9) as f32, -8.0 + 2.0 * (k / 9) as f32);
            hole(k as u8, &square(at, 0.5)).unwrap()
        })
        .collect();
    assert_eq!(slice_err(&holes), Error::TooManyHoles { holes: n as u32 });
    let h = hole(0, &square((0.0, 0.0), 2.0)).unwrap();
    for (settings, id, value) in [
        (
            Settings {
                road_width: 0.0,
                ..Settings::default()
            },
            SettingId::RoadWidth,
            0.0,
        ),
        (
            Settings {
                road_width: -1.0,
                ..Settings::default()
            },
            SettingId::RoadWidth,
            -1.0,
        ),
        (
            Settings {
                road_width: 50.0,
                ..Settings::default()
            },
            SettingId::RoadWidth,
            50.0,
        ),
        (
            Settings {
                layer_height: 0.0,
                ..Settings::default()
            },
            SettingId::LayerHeight,
            0.0,
        ),
        (
            Settings {
                w_n: -1.0,
                ..Settings::default()
            },
            SettingId::WeightNormal,
            -1.0,
        ),
        (
            Settings {
                w_d: -0.5,
                ..Settings::default()
            },
            SettingId::WeightDistance,
            -0.5,
        ),
        (
            Settings {
                delta: 0.0,
                ..Settings::default()
            },
            SettingId::Delta,
            0.0,
        ),
        (
            Settings {
                mcl_spacing: 0.01,
                ..Settings::default()
            },
            SettingId::MclSpacing,
            0.01,
        ),
        (
            Settings {
                relax_spacing: -0.1,
                ..Settings::default()
            },
            SettingId::RelaxSpacing,
            -0.1,
        ),
        (
            Settings {
                min_width: 0.5,
                ..Settings::default()
            },
            SettingId::MinWidth,
            0.5,
        ),
        (
            Settings {
                min_width: 0.0,
                ..Settings::default()
            },
            SettingId::MinWidth,
            0.0,
        ),
        (
            Settings {
                max_width: 0.3,
                ..Settings::default()
            },
            SettingId::MaxWidth,
            0.3,
        ),
        (
            Settings {
                max_width: 1.3,
                ..Settings::default()
            },
            SettingId::MaxWidth,
            1.3,
        ),
    ] {
        assert_eq!(
            Slice::new(wall(), std::slice::from_ref(&h), settings),
            Err(Error::InvalidSetting { setting: id, value })
        );
    }
    let nan = Settings {
        road_width: f32::NAN,
        ..Settings::default()
    };
    assert!(matches!(
        Slice::new(wall(), &[h], nan),
        Err(Error::InvalidSetting {
            setting: SettingId::RoadWidth,
            ..
        })
    ));
}

#[cfg(not(feature = "large"))]
const MCLS_MESSAGE: &str = "capacity exceeded: more than 512 material changing lines: use a wider road_width (fewer MCLs) or fewer hollow features, or split the slice";
#[cfg(feature = "large")]
const MCLS_MESSAGE: &str = "capacity exceeded: more than 8192 material changing lines: use a wider road_width (fewer MCLs) or fewer hollow features, or split the slice";

#[test]
fn messages_name_feature_and_reason() {
    let cases = [
        (
            Error::HoleOutsideWall { hole: 2, vertex: 7 },
            "hole 2: vertex 7 is not strictly inside the wall",
        ),
        (
            Error::HolesNested { outer: 0, inner: 1 },
            "hole 1 lies inside hole 0 (nested holes)",
        ),
        (
            Error::SelfIntersection {
                feature: FeatureId::Wall,
                edge_a: 1,
                edge_b: 5,
            },
            "the wall: edges 1 and 5 intersect (self-intersecting polygon)",
        ),
        (
            Error::Capacity {
                limit: Limit::Mcls,
                feature: None,
            },
            MCLS_MESSAGE,
        ),
        (
            Error::InvalidSetting {
                setting: SettingId::Delta,
                value: -1.0,
            },
            "setting delta: -1 is out of range (allowed: a finite number of mm, more than 0)",
        ),
        (
            Error::InvalidSetting {
                setting: SettingId::RelaxIterations,
                value: 256.0,
            },
            "setting relax_iterations: 256 is out of range (allowed: a whole number from 0 to 64)",
        ),
        (
            Error::OutOfRange {
                feature: FeatureId::Hole(1),
                vertex: 3,
            },
            "hole 1: vertex 3 has a coordinate out of range (coordinates must lie from -1000 to 1000 mm)",
        ),
    ];
    assert_eq!(
        (
            hollowpath::config::MAX_RELAX_ITERATIONS,
            hollowpath::config::MAX_COORD_MM,
            hollowpath::config::MIN_ROAD_WIDTH_MM,
            hollowpath::config::MAX_ROAD_WIDTH_MM,
        ),
        (64, 1000.0, 0.01, 10.0),
        "update the messages above and SettingId::allowed"
    );
    for (e, text) in cases {
        assert_eq!(e.to_string(), text);
    }
}

#[test]
fn a_failed_plan_leaves_no_partial_plan() {
    // Plan a good slice, then one too large for the grid: the second fails and the first's
    // MCLs are gone.
    let mut planner = Box::new(hollowpath::Planner::new());
    let good = Slice::new(
        wall(),
        &[hole(0, &circle(0.0, 0.0, 3.0, 32, 0.0)).unwrap()],
        Settings::default(),
    )
    .unwrap();
    assert!(!planner.plan(&good).unwrap().mcls.is_empty());
    let big_wall = feature(FeatureId::Wall, &square((0.0, 0.0), 200.0), WALL);
    let big = Slice::new(
        big_wall,
        &[hole(0, &circle(0.0, 0.0, 3.0, 32, 0.0)).unwrap()],
        Settings::default(),
    )
    .unwrap();
    let e = planner.plan(&big).unwrap_err();
    assert!(
        matches!(e, Error::SliceTooLarge { spiral: false, .. }),
        "{e:?}"
    );
    // In the user's terms: the slice's size, the road and what the grid holds.
    // (72.8 mm in the MCU build, 147.4 mm in the host's.)
    let holds = if cfg!(feature = "large") {
        "147.4"
    } else {
        "72.8"
    };
    assert_eq!(
        e.to_string(),
        format!("the slice is 400.0 x 400.0 mm; at road_width 0.4 the field grid holds {holds} x {holds} mm: use a coarser road or split the slice")
    );
    assert!(planner.last_plan().mcls.is_empty() && planner.last_plan().halves.is_empty());
}

fn ring(cx: f32, r: f32, n: usize) -> Vec<Point> {
    (0..n)
        .map(|k| {
            let a = k as f32 / n as f32 * std::f32::consts::TAU;
            Point::new(cx + r * a.cos(), r * a.sin())
        })
        .collect()
}

/// Largest distance from a vertex of `input` to the polygon `simple`.
fn deviation(input: &[Point], simple: &[Point]) -> f32 {
    let n = simple.len();
    input
        .iter()
        .map(|&p| {
            (0..n)
                .map(|k| {
                    let (q, _) = hollowpath::geometry::primitives::closest_on_segment(
                        simple[k],
                        simple[(k + 1) % n],
                        p,
                    );
                    q.dist(p)
                })
                .fold(f32::INFINITY, f32::min)
        })
        .fold(0.0, f32::max)
}

#[test]
fn a_4096_vertex_circle_simplifies_within_tolerance_and_fits_the_mcu() {
    let circle = ring(0.0, 5.0, 4096);
    let f = Feature::simplified(FeatureId::Hole(0), &circle, A, 0.005).unwrap();
    let n = f.points().len();
    assert!((20..=hollowpath::config::MAX_VERTICES).contains(&n), "{n}");
    assert!(deviation(&circle, f.points()) <= 0.005 + 1e-5);
    // Feature::new would refuse it on the MCU build (256 vertices).
    if !hollowpath::config::LARGE {
        assert!(matches!(
            Feature::new(FeatureId::Hole(0), &circle, A),
            Err(Error::TooManyVertices {
                vertices: 4096,
                simplified: false,
                ..
            })
        ));
    }
}

#[test]
fn a_4096_vertex_star_keeps_its_corners() {
    // 32 points, every edge split into 64 collinear pieces.
    let corners: Vec<Point> = (0..64)
        .map(|k| {
            let a = k as f32 / 64.0 * std::f32::consts::TAU;
            let r = if k % 2 == 0 { 10.0 } else { 4.0 };
            Point::new(r * a.cos(), r * a.sin())
        })
        .collect();
    let star: Vec<Point> = (0..4096)
        .map(|k| {
            let (c, t) = (k / 64, (k % 64) as f32 / 64.0);
            corners[c].lerp(corners[(c + 1) % 64], t)
        })
        .collect();
    let f = Feature::simplified(FeatureId::Wall, &star, WALL, 0.005).unwrap();
    assert_eq!(f.points().len(), 64);
    for c in &corners {
        assert!(f.points().iter().any(|p| p.dist(*c) < 1e-4), "{c:?} lost");
    }
    assert!(deviation(&star, f.points()) <= 0.005 + 1e-5);
}

#[test]
fn simplification_keeps_more_vertices_where_features_would_meet() {
    // The wall's chords cut up to 5 µm inward at 0.005 mm tolerance; the hole is 2 µm away (the wall keeps 128 vertices, 3 µm in).
    let wall = ring(0.0, 10.0, 4096);
    // Its vertices face the middles of the coarse wall's chords.
    let (sin, cos) = (std::f32::consts::PI / 128.0).sin_cos();
    let hole: Vec<Point> = ring(0.0, 9.998, 4096)
        .iter()
        .map(|p| Point::new(p.x * cos - p.y * sin, p.x * sin + p.y * cos))
        .collect();
    let coarse = Feature::simplified(FeatureId::Wall, &wall, WALL, 0.005).unwrap();
    let s = Slice::from_contours(&wall, WALL, &[(&hole, A)], Settings::default()).unwrap();
    assert!(s.wall().points().len() > coarse.points().len());
    assert!(s.wall().points().len() <= hollowpath::config::MAX_VERTICES);
    assert!(s.holes()[0]
        .points()
        .iter()
        .all(|&p| s.wall().signed_distance(p) < 0.0));
}

#[test]
fn simplify_tolerance_is_validated() {
    let s = Settings {
        simplify_tolerance: 0.05,
        ..Settings::default()
    };
    assert_eq!(
        Slice::from_contours(&ring(0.0, 10.0, 64), WALL, &[(&ring(0.0, 3.0, 32), A)], s)
            .unwrap_err(),
        Error::InvalidSetting {
            setting: hollowpath::SettingId::SimplifyTolerance,
            value: 0.05
        }
    );
    // Contours of at most 256 vertices are kept exactly.
    let small = ring(0.0, 3.0, 200);
    let f = Feature::simplified(FeatureId::Hole(0), &small, A, 0.005).unwrap();
    assert_eq!(
        f.points(),
        Feature::new(FeatureId::Hole(0), &small, A)
            .unwrap()
            .points()
    );
}
