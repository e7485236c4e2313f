//! Real-size slices on the host, which compiles the core with its `large` capacities: 64
//! hollow features, contours of 4096 vertices, and a slice too large for the field grid refused
//! in the user's terms.

use hollowpath::geometry::Point;
use hollowpath::toolpath::spiral::ControlFunction;
use hollowpath::{config, Error, Feature, FeatureId, Settings, Slice};
use host_sim::layers::{layer, Fill};
use host_sim::run_on_large_stack;

const WALL: [f32; 4] = [1.0, 0.0, 0.0, 0.0];
const HOLE: [f32; 4] = [0.0, 1.0, 0.0, 0.0];

fn circle(cx: f32, cy: f32, r: f32, n: usize, phase: f32) -> Vec<Point> {
    (0..n)
        .map(|k| {
            let a = phase + k as f32 / n as f32 * std::f32::consts::TAU;
            Point::new(cx + r * a.cos(), cy + r * a.sin())
        })
        .collect()
}

fn square(s: f32) -> Vec<Point> {
    vec![
        Point::new(-s, -s),
        Point::new(s, -s),
        Point::new(s, s),
        Point::new(-s, s),
    ]
}

/// An 8 x 8 array of 60-vertex holes (radius 2 mm, 7.5 mm apart) in a 60 x 60 mm wall.
fn sixty_four_holes() -> Slice {
    let wall = Feature::new(FeatureId::Wall, &square(30.0), WALL).unwrap();
    let holes: Vec<Feature> = (0..64)
        .map(|k| {
            let (i, j) = (k % 8, k / 8);
            let c = (-26.25 + 7.5 * i as f32, -26.25 + 7.5 * j as f32);
            let pts = circle(c.0, c.1, 2.0, 60, 0.1 * (i + j) as f32);
            Feature::new(FeatureId::Hole(k as u8), &pts, HOLE).unwrap()
        })
        .collect();
    Slice::new(wall, &holes, Settings::default()).unwrap()
}

#[test]
fn capacities_are_the_large_ones() {
    const { assert!(config::LARGE) };
    const { assert!(config::MAX_HOLES >= 64 && config::MAX_VERTICES >= 4096) };
}

#[test]
fn sixty_four_holes_plan_and_both_layers_build() {
    run_on_large_stack(|| {
        let slice = sixty_four_holes();
        assert_eq!(slice.holes().len(), 64);
        let planner = host_sim::plan(&slice).unwrap();
        let plan = planner.last_plan();
        hollowpath::verify::verify(&slice, plan).unwrap();
        for i in 0..64u8 {
            assert!(plan.mcls.iter().any(|m| m.from == i), "hole {i} has no MCL");
        }
        for (index, fill) in [
            (0, Fill::Offset),
            (1, Fill::Offset),
            (1, Fill::Mcl(ControlFunction::RoadWidth)),
        ] {
            let l = layer(&slice, plan, fill, index).unwrap();
            assert!(l.path.len() > 1000, "{fill:?} {index}: {}", l.note);
        }
    });
}

#[test]
fn contours_of_4096_vertices_are_accepted() {
    run_on_large_stack(|| {
        let wall = Feature::new(FeatureId::Wall, &circle(0.0, 0.0, 20.0, 4096, 0.0), WALL).unwrap();
        assert_eq!(wall.points().len(), 4096);
        let holes: Vec<Feature> = [(-8.0, 0.0), (8.0, 0.0)]
            .iter()
            .enumerate()
            .map(|(k, &(x, y))| {
                let pts = circle(x, y, 5.0, 4096, 0.0);
                Feature::new(FeatureId::Hole(k as u8), &pts, HOLE).unwrap()
            })
            .collect();
        let slice = Slice::new(wall, &holes, Settings::default()).unwrap();
        let planner = host_sim::plan(&slice).unwrap();
        let plan = planner.last_plan();
        hollowpath::verify::verify(&slice, plan).unwrap();
        assert!(plan.mcls.len() > 100);
        let l = layer(&slice, plan, Fill::Offset, 0).unwrap();
        assert!(l.path.len() > 100, "{}", l.note);
    });
}

#[test]
fn too_many_vertices_and_holes_are_refused_in_the_users_terms() {
    let e = Feature::new(FeatureId::Hole(3), &circle(0.0, 0.0, 5.0, 5000, 0.0), HOLE).unwrap_err();
    assert_eq!(
        e,
        Error::TooManyVertices {
            feature: FeatureId::Hole(3),
            vertices: 5000,
            simplified: false
        }
    );
    assert_eq!(
        e.to_string(),
        "hole 3 has 5000 vertices; at most 4096: simplify the polygon or split the feature"
    );
    run_on_large_stack(|| {
        let wall = Feature::new(FeatureId::Wall, &square(30.0), WALL).unwrap();
        let holes: Vec<Feature> = (0..65)
            .map(|k| {
                let c = (-28.0 + 7.0 * (k % 9) as f32, -28.0 + 7.0 * (k / 9) as f32);
                Feature::new(FeatureId::Hole(0), &circle(c.0, c.1, 1.0, 16, 0.0), HOLE).unwrap()
            })
            .collect();
        let e = Slice::new(wall, &holes, Settings::default()).unwrap_err();
        assert_eq!(e, Error::TooManyHoles { holes: 65 });
        assert_eq!(
            e.to_string(),
            "the slice has 65 hollow features; at most 64: split the slice"
        );
    });
}

#[test]
fn a_slice_too_large_for_the_field_grid_says_so_in_mm() {
    run_on_large_stack(|| {
        let wall = Feature::new(FeatureId::Wall, &square(80.0), WALL).unwrap();
        let hole = Feature::new(FeatureId::Hole(0), &circle(0.0, 0.0, 5.0, 64, 0.0), HOLE).unwrap();
        let slice = Slice::new(wall, &[hole], Settings::default()).unwrap();
        let e = host_sim::plan(&slice).map(|_| ()).unwrap_err();
        assert!(
            matches!(e, Error::SliceTooLarge { spiral: false, .. }),
            "{e:?}"
        );
        assert_eq!(
            e.to_string(),
            "the slice is 160.0 x 160.0 mm; at road_width 0.4 the field grid holds 147.4 x 147.4 mm: use a coarser road or split the slice"
        );
        // 100 x 100 mm at 0.4 mm roads fits.
        let wall = Feature::new(FeatureId::Wall, &square(50.0), WALL).unwrap();
        let hole =
            Feature::new(FeatureId::Hole(0), &circle(0.0, 0.0, 20.0, 256, 0.0), HOLE).unwrap();
        let slice = Slice::new(wall, &[hole], Settings::default()).unwrap();
        let planner = host_sim::plan(&slice).unwrap();
        assert!(planner.last_plan().stats.grid_nodes as usize > config::GRID_SPACING_NODES);
    });
}

#[test]
fn slice_files_simplify_big_contours_by_their_setting() {
    let ring: Vec<String> = circle(0.0, 0.0, 5.0, 4096, 0.0)
        .iter()
        .map(|p| format!("[{},{}]", p.x, p.y))
        .collect();
    let text = |settings: &str| {
        format!(
            r#"{{"outer": {{"points": [[-10,-10],[10,-10],[10,10],[-10,10]], "material": [1,0,0,0]}}, "holes": [{{"points": [{}], "material": [0,1,0,0]}}], "settings": {{{settings}}}}}"#,
            ring.join(",")
        )
    };
    run_on_large_stack(|| {
        let s = host_sim::slice_file::parse(&text("")).unwrap().slice;
        assert!(
            s.holes()[0].points().len() <= 256,
            "{}",
            s.holes()[0].points().len()
        );
        let s = host_sim::slice_file::parse(&text(r#""simplify_tolerance": 0"#))
            .unwrap()
            .slice;
        assert_eq!(s.holes()[0].points().len(), 4096);
        let e = host_sim::slice_file::parse(&text(r#""simplify_tolerance": 0.1"#)).unwrap_err();
        assert_eq!(
            e.to_string(),
            "invalid slice: setting simplify_tolerance: 0.1 is out of range (allowed: 0 to a tenth of the road width, mm)"
        );
    });
}
