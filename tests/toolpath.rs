//! Layers on hand-built slices: zigzag, spiral (every control function), raster baseline.

mod common;

use common::{check_layer, starts, two_circles};
use hollowpath::geometry::Point;
use hollowpath::toolpath::offset::OffsetSpiral;
use hollowpath::toolpath::spiral::{spiral, ControlFunction};
use hollowpath::toolpath::zigzag::zigzag;
use hollowpath::toolpath::{raster::raster, Vertex};
use hollowpath::{Planner, Settings};

type Path = heapless::Vec<Vertex, 16384>;

#[test]
fn zigzag_is_one_continuous_road_through_both_cells() {
    let slice = two_circles(Settings::default());
    let mut planner = Box::new(Planner::new());
    let plan = planner.plan(&slice).unwrap();
    let mut path = Box::new(Path::new());
    let stats = zigzag(&slice, plan, &mut *path).unwrap();
    check_layer(&slice, &path).unwrap();
    assert_eq!(stats.pieces, 1, "{stats:?}");
    assert_eq!(starts(&path), 1);
    // Every MCL is deposited (none had to be left out for parity): each MCL's joint is on
    // the path, up to the road's sideways shift toward its wider gap (at most a quarter of
    // its width), or a quarter road off the keep-out curve where it ends into a splice's
    // shared stretch.
    let w = slice.settings().road_width;
    assert_eq!(stats.dropped, 0);
    // Where the band between MCLs is wider than the widest road the road meanders across it,
    // so the joint is then covered by a stroke rather than passed by a vertex.
    for m in plan.mcls.iter() {
        assert!(
            path.windows(2).any(|s| {
                let (q, _) =
                    hollowpath::geometry::primitives::closest_on_segment(s[0].at, s[1].at, m.joint);
                s[1].deposit && q.dist(m.joint) <= 0.5 * s[1].width.max(w) + 1e-3
            }),
            "MCL ending at {:?} missing",
            m.joint
        );
    }
    // The fan of MCLs is denser at the holes than at the wall: roads narrow near the holes
    // and widen away from them.
    assert!(path.iter().any(|v| v.width < 0.95 * w), "no narrowed road");
    assert!(path.iter().any(|v| v.width > 1.05 * w), "no widened road");
    // Blended composition: half way along the centre MCL it is half and half.
    let mid = path
        .iter()
        .find(|v| v.at.dist(hollowpath::geometry::Point::new(0.0, 0.0)) < 1e-3)
        .unwrap();
    assert!(
        (mid.material[1] - 0.5).abs() < 1e-3 && (mid.material[2] - 0.5).abs() < 1e-3,
        "{:?}",
        mid.material
    );
}

#[test]
fn spirals_of_every_control_function_chain_the_cells() {
    let slice = two_circles(Settings::default());
    let mut planner = Box::new(Planner::new());
    let plan = planner.plan(&slice).unwrap();
    let mut lengths = Vec::new();
    for f in [
        ControlFunction::Linear,
        ControlFunction::RoadWidth,
        ControlFunction::Ease,
    ] {
        let mut path = Box::new(Path::new());
        let stats = spiral(&slice, plan, f, &mut *path).unwrap();
        check_layer(&slice, &path).unwrap_or_else(|e| panic!("{f:?}: {e}"));
        assert_eq!(stats.jumps, 0, "{f:?}");
        assert_eq!(starts(&path), 1, "{f:?}");
        assert!(stats.turns >= 5, "{f:?}: {stats:?}");
        lengths.push(path.windows(2).map(|w| w[0].at.dist(w[1].at)).sum::<f32>());
    }
    // The control functions give different spirals.
    assert!(
        (lengths[0] - lengths[1]).abs() > 1.0 && (lengths[0] - lengths[2]).abs() > 1e-3,
        "{lengths:?}"
    );
}

#[test]
fn offset_spiral_is_one_road_of_turns_a_road_width_apart() {
    let slice = two_circles(Settings::default());
    let w = slice.settings().road_width;
    let mut planner = Box::new(Planner::new());
    let plan = planner.plan(&slice).unwrap();
    let mut work = Box::new(OffsetSpiral::new());
    let mut grid = Box::new(hollowpath::field::GridMemory::new());
    let mut path = Box::new(Path::new());
    let stats = work.build(&slice, plan, &mut grid, &mut *path).unwrap();
    check_layer(&slice, &path).unwrap();
    assert_eq!(stats.jumps, 0, "{stats:?}");
    assert_eq!(starts(&path), 1);
    assert!(stats.levels >= 5 && stats.joins >= 2, "{stats:?}");
    // Every road's inner edge lies on a turn's: the distance of a vertex to the nearest
    // feature, less half its width, is k w (plus the first turn's 3 micron margin), to the
    // simplification tolerance. A road is a road width wide, or wider (up to the slice's
    // widest) where it widens into the sliver before a ridge and its centre moves out by half
    // the excess, or narrower (down to the slice's narrowest) where the same level's turn
    // beyond a ridge lies nearer than a road. The exception: a bridge between two turns
    // narrower than the loops it joins (as wide as its twin lies apart) narrows a short way
    // out from each loop, at a vertex between the turns (the moves into and out of it run
    // across the turns, toward the next one).
    let distance = |p: hollowpath::geometry::Point| {
        slice
            .holes()
            .iter()
            .map(|h| h.signed_distance(p))
            .fold(-slice.wall().signed_distance(p), f32::min)
    };
    let mut used = std::collections::BTreeSet::new();
    let mut widened = 0;
    let mut strays = 0;
    let mut tapers = 0;
    for (i, v) in path.iter().enumerate() {
        let d = distance(v.at);
        assert!(
            v.width >= slice.settings().min_width - 1e-6
                && v.width <= slice.settings().max_width + 1e-6,
            "vertex {i}: width {}",
            v.width
        );
        widened += usize::from(v.width > w);
        if i > 0 && i + 1 < path.len() && v.width < w {
            let (before, after) = (distance(path[i - 1].at), distance(path[i + 1].at));
            if (before - d) * (d - after) > 0.0 && (before - after).abs() > 0.5 * w {
                tapers += 1;
                continue;
            }
        }
        let inner = d - 0.5 * v.width;
        let k = ((inner - 3e-3) / w).round();
        let off = inner - (3e-3 + k * w);
        // A small loop at a peak of the distance, a few grid cells across, is traced with
        // chords that stray from its level by up to an eighth of a road; never toward a
        // neighbouring turn.
        assert!(
            off.abs() < 0.25 * w,
            "vertex {i} at {:?}: {off} off turn {k} (d {d}, width {})",
            v.at,
            v.width
        );
        strays += usize::from(off.abs() >= 5e-3);
        used.insert(k as i32);
    }
    assert!(
        strays * 200 <= path.len(),
        "{strays} of {} vertices off their turn",
        path.len()
    );
    // Where the holes' turns meet the wall's and each other's, the ridges leave slivers
    // narrower than a road, and roads widen into them; some joins cut gaps shorter than a
    // road, and their bridges narrow (8 such vertices of 3 587): as rare as the strays, or
    // the exception would excuse a turn's vertices that stray.
    assert!(widened > 0);
    assert!(
        tapers > 0 && tapers * 200 <= path.len(),
        "{tapers} of {}",
        path.len()
    );
    // Every level from the first is laid (the top one may hold only loops too small to turn
    // in, which are left out).
    let n = used.len() as i32;
    assert!(used.iter().copied().eq(0..n), "{used:?}");
    assert!(n + 1 >= stats.levels as i32, "{used:?} of {stats:?}");
    // Deterministic: the same slice gives the same path.
    let mut again = Box::new(Path::new());
    work.build(&slice, plan, &mut grid, &mut *again).unwrap();
    assert!(path.iter().eq(again.iter()));
}

#[test]
fn tapered_dip_finds_exactly_the_roads_that_reach_a_feature() {
    // Segments near the left hole with radii tapering from ra to rb: `tapered_dip` reports a
    // dip exactly when some point of the segment is nearer a feature vertex than the radius
    // there (brute force over 2000 points; the polygons' vertices are what it checks).
    let slice = two_circles(Settings::default());
    let mut seed = 7u32;
    let mut next = move || {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (seed >> 8) as f32 / (1u32 << 24) as f32
    };
    let verts: Vec<hollowpath::geometry::Point> = slice
        .holes()
        .iter()
        .flat_map(|h| h.points().iter().copied())
        .chain(slice.wall().points().iter().copied())
        .collect();
    let (mut found, mut clear) = (0, 0);
    for _ in 0..400 {
        let p = |x: f32, y: f32| hollowpath::geometry::Point::new(x, y);
        let a = p(-9.0 + 4.0 * next(), -3.0 + 6.0 * next());
        let b = p(-9.0 + 4.0 * next(), -3.0 + 6.0 * next());
        let (ra, rb) = (0.1 + 0.5 * next(), 0.1 + 0.5 * next());
        if slice.segment_crosses_feature(a, b) {
            continue;
        }
        // The deepest intrusion of a feature vertex into the road, by brute force.
        let mut depth = f32::NEG_INFINITY;
        for k in 0..=2000 {
            let t = k as f32 / 2000.0;
            let c = a.lerp(b, t);
            let r = ra + (rb - ra) * t;
            for q in &verts {
                depth = depth.max(r - c.dist(*q));
            }
        }
        let got = slice.tapered_dip(a, b, ra, rb);
        if depth > 1e-3 {
            let (t, c) = got.unwrap_or_else(|| panic!("missed a dip {depth} on {a:?}-{b:?}"));
            assert!(c.dist(a.lerp(b, t)) < 1e-4);
            found += 1;
        } else if depth < -1e-3 {
            assert!(got.is_none(), "false dip on {a:?}-{b:?}");
            clear += 1;
        }
    }
    assert!(found > 20 && clear > 20, "{found} {clear}");
}

#[test]
fn raster_baseline_stays_in_the_region() {
    let slice = two_circles(Settings::default());
    let mut planner = Box::new(Planner::new());
    let plan = planner.plan(&slice).unwrap();
    for layer in 0..2 {
        let mut path = Box::new(Path::new());
        raster(&slice, plan, layer, &mut *path).unwrap();
        check_layer(&slice, &path).unwrap();
        // A perimeter per feature at least.
        assert!(starts(&path) >= 3);
    }
}

#[test]
fn a_full_sink_is_a_capacity_error() {
    let slice = two_circles(Settings::default());
    let mut planner = Box::new(Planner::new());
    let plan = planner.plan(&slice).unwrap();
    let mut small: heapless::Vec<Vertex, 64> = heapless::Vec::new();
    assert_eq!(
        zigzag(&slice, plan, &mut small).unwrap_err(),
        hollowpath::Error::Capacity {
            limit: hollowpath::Limit::PathVertices,
            feature: None
        }
    );
}

proptest::proptest! {
    /// A move split for a printer: contiguous pieces from one end to the other, each one width
    /// that is never wider than the road and at most 5 % narrower anywhere along the piece, and
    /// one mix within 0.02 of the road's along it.
    #[test]
    fn a_split_move_stays_within_its_road(
        ax in -50.0f32..50.0, ay in -50.0f32..50.0, dx in -5.0f32..5.0, dy in -5.0f32..5.0,
        wa in 0.1f32..1.2, wb in 0.1f32..1.2, ta in 0.0f32..1.0, tb in 0.0f32..1.0,
    ) {
        use hollowpath::toolpath::moves::{split, Move, MIX_TOLERANCE, WIDTH_TOLERANCE};

        let mat = |t: f32| [1.0 - t, t, 0.0, 0.0];
        let a = Vertex { at: Point::new(ax, ay), material: mat(ta), width: wa, deposit: true };
        let b = Vertex { at: Point::new(ax + dx, ay + dy), material: mat(tb), width: wb, deposit: true };
        // Within the cap of pieces (a width ratio of up to 7.4 along one move; the default
        // settings allow 3.2).
        proptest::prop_assume!(wa.max(wb) <= 6.0 * wa.min(wb));
        let mut pieces: Vec<Move> = Vec::new();
        split(&a, &b, |m| pieces.push(m));
        proptest::prop_assert!(!pieces.is_empty());
        proptest::prop_assert_eq!(pieces[0].from, a.at);
        proptest::prop_assert_eq!(pieces.last().unwrap().to, b.at);
        proptest::prop_assert_eq!(pieces.last().unwrap().material, b.material);
        proptest::prop_assert_eq!(pieces[0].material, a.material);
        let n = pieces.len() as f32;
        for (k, m) in pieces.iter().enumerate() {
            proptest::prop_assert!(m.deposit);
            if k > 0 {
                proptest::prop_assert_eq!(m.from, pieces[k - 1].to);
            }
            // The road's width and mix at the piece's ends (equal pieces: t = k / n).
            let (t0, t1) = (k as f32 / n, (k + 1) as f32 / n);
            for t in [t0, t1] {
                let road = wa + (wb - wa) * t;
                proptest::prop_assert!(m.width <= road * (1.0 + 1e-5), "{m:?} road {road}");
                proptest::prop_assert!(m.width >= road * (1.0 - WIDTH_TOLERANCE) * (1.0 - 1e-5), "{m:?} road {road}");
                let mix = ta + (tb - ta) * t;
                proptest::prop_assert!((m.material[1] - mix).abs() <= MIX_TOLERANCE * (1.0 + 1e-4), "{m:?} mix {mix}");
            }
        }
    }
}

#[test]
fn a_travel_move_is_one_move_and_a_constant_road_is_not_split() {
    use hollowpath::toolpath::moves::split;

    let a = Vertex {
        at: Point::new(0.0, 0.0),
        material: [1.0, 0.0, 0.0, 0.0],
        width: 0.4,
        deposit: true,
    };
    let mut b = Vertex {
        at: Point::new(3.0, 0.0),
        material: [0.0, 1.0, 0.0, 0.0],
        width: 0.2,
        deposit: false,
    };
    let mut n = 0;
    split(&a, &b, |m| {
        assert!(!m.deposit);
        n += 1;
    });
    assert_eq!(n, 1);
    b.deposit = true;
    b.material = a.material;
    b.width = 0.41;
    n = 0;
    split(&a, &b, |m| {
        assert_eq!(m.width, 0.4);
        n += 1;
    });
    assert_eq!(n, 1);
}

#[test]
fn a_slice_without_holes_is_one_offset_spiral_road_and_the_mcl_layers_refuse_it() {
    use hollowpath::{Error, FeatureId, Slice};
    // A cap: a 6 mm square wall and nothing inside.
    let square = [
        Point::new(0.0, 0.0),
        Point::new(6.0, 0.0),
        Point::new(6.0, 6.0),
        Point::new(0.0, 6.0),
    ];
    let wall = common::feature(FeatureId::Wall, &square, common::WALL);
    let slice = Slice::new(wall, &[], Settings::default()).unwrap();
    let mut planner = Box::new(Planner::new());
    let plan = planner.plan(&slice).unwrap();
    assert!(plan.mcls.is_empty() && plan.halves.is_empty());
    hollowpath::verify::verify(&slice, plan).unwrap();
    let mut work = Box::new(OffsetSpiral::new());
    let mut grid = Box::new(hollowpath::field::GridMemory::new());
    let mut path = Box::new(Path::new());
    let stats = work.build(&slice, plan, &mut grid, &mut *path).unwrap();
    check_layer(&slice, &path).unwrap();
    assert_eq!(starts(&path), 1, "{stats:?}");
    assert_eq!(stats.jumps, 0);
    // Turns from the wall inwards, a road apart: 6 mm across holds 7 of 0.4 mm.
    assert!(stats.levels >= 6, "{stats:?}");
    // Everything deposited is the wall's material.
    assert!(path.iter().all(|v| v.material == common::WALL));
    let mut other = Box::new(Path::new());
    assert_eq!(
        zigzag(&slice, plan, &mut *other).unwrap_err(),
        Error::NoHoles
    );
    assert_eq!(
        spiral(&slice, plan, ControlFunction::Linear, &mut *other).unwrap_err(),
        Error::NoHoles
    );
    // Deterministic.
    let mut again = Box::new(Path::new());
    work.build(&slice, plan, &mut grid, &mut *again).unwrap();
    assert!(path.iter().eq(again.iter()));
}

/// The spiral's loops and joins are prepared once per slice: a second build of the same
/// slice lays the same path bit for bit, and another slice (here the same contours at
/// another road width) is prepared anew, never walked on the first slice's loops. The
/// distance grid is the planner's field memory, lent as on a controller, and plans made after
/// the spiral wrote over it are bit-identical to a fresh planner's.
#[test]
fn offset_spiral_prepared_once_lays_the_same_path_and_a_new_slice_is_prepared_anew() {
    let fresh = |slice: &hollowpath::Slice| {
        let mut planner = Box::new(Planner::new());
        let plan = planner.plan(slice).unwrap();
        let mut work = Box::new(OffsetSpiral::new());
        let mut grid = Box::new(hollowpath::field::GridMemory::new());
        let mut path = Box::new(Path::new());
        work.build(slice, plan, &mut grid, &mut *path).unwrap();
        path
    };
    let a = two_circles(Settings::default());
    let b = two_circles(Settings::for_road_width(0.3));
    let (want_a, want_b) = (fresh(&a), fresh(&b));
    assert_ne!(want_a.len(), want_b.len());

    // As a controller runs it: one planner, whose field lends its node memory to the spiral
    // once the plan is made (`plan_and_grid`); planning again is not disturbed by what the
    // spiral left in that memory.
    let digest_of = |slice: &hollowpath::Slice| {
        let mut fresh = Box::new(Planner::new());
        fresh.plan(slice).unwrap().digest()
    };
    let mut planner = Box::new(Planner::new());
    let mut work = Box::new(OffsetSpiral::new());
    planner.plan(&a).unwrap();
    assert!(!planner.field().grid().is_empty());
    let (plan, grid) = planner.plan_and_grid();
    let prepared = work.prepare(&a, grid).unwrap();
    for _ in 0..2 {
        let mut path = Box::new(Path::new());
        let stats = work.build(&a, plan, grid, &mut *path).unwrap();
        assert_eq!(stats.loops, prepared.loops);
        assert_eq!(path.len(), want_a.len());
        assert!(path.iter().zip(want_a.iter()).all(|(p, q)| p == q));
    }
    // The field is empty while lent.
    assert!(planner.field().grid().is_empty());
    assert_eq!(planner.plan(&b).unwrap().digest(), digest_of(&b));
    let (plan, grid) = planner.plan_and_grid();
    let mut path = Box::new(Path::new());
    work.build(&b, plan, grid, &mut *path).unwrap();
    assert_eq!(path.len(), want_b.len());
    assert!(path.iter().zip(want_b.iter()).all(|(p, q)| p == q));
    // Back to the first slice, after the spiral wrote over the field's memory twice.
    assert_eq!(planner.plan(&a).unwrap().digest(), digest_of(&a));
}
