//! Every reference slice plans into MCLs with all the properties a plan must have.

use std::path::Path;

use hollowpath::verify::verify;
use hollowpath::{Settings, Slice, Target};
use host_sim::raster::Raster;
use host_sim::{slice_file, REFERENCE_SLICES};

fn slices() -> Vec<(&'static str, Slice)> {
    REFERENCE_SLICES
        .iter()
        .map(|(name, text)| (*name, slice_file::parse(text).expect(name).slice))
        .collect()
}

fn with_settings(slice: &Slice, settings: Settings) -> Slice {
    Slice::new(slice.wall().clone(), slice.holes(), settings).unwrap()
}

#[test]
fn shipped_copies_match_shared_reference_slices() {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/slices");
    if !shared.is_dir() {
        eprintln!(
            "note: {} not found; comparing copies skipped",
            shared.display()
        );
        return;
    }
    for (name, text) in REFERENCE_SLICES {
        let original = std::fs::read_to_string(shared.join(format!("{name}.json"))).unwrap();
        assert_eq!(
            original, text,
            "host-sim/data/{name}.json differs from shared/slices"
        );
    }
}

#[test]
fn every_reference_slice_plans_and_verifies() {
    for (name, slice) in slices() {
        let planner = host_sim::plan(&slice).unwrap_or_else(|e| panic!("{name}: {e}"));
        let plan = planner.last_plan();
        verify(&slice, plan).unwrap_or_else(|v| panic!("{name}: {v:?}"));
        // Every hole has MCLs.
        for i in 0..slice.holes().len() {
            assert!(
                plan.mcls
                    .iter()
                    .filter(|m| m.from as usize == i || m.to == Target::Hole(i as u8))
                    .count()
                    > 20,
                "{name}: hole {i} has too few MCLs"
            );
        }
        let pairs = plan.mcls.iter().filter(|m| m.second.is_some()).count();
        if slice.holes().len() > 1 {
            assert!(pairs > 10, "{name}: only {pairs} matched MCLs");
            assert!(!plan.bisectors().is_empty(), "{name}: no bisector");
            assert!(
                plan.cells.branch_points.len() >= 2,
                "{name}: too few branch points"
            );
        } else {
            assert_eq!(pairs, 0);
            assert!(plan.bisectors().is_empty());
        }
        assert_eq!(
            plan.stats.off_bisector, 0,
            "{name}: ends missed their bisector"
        );
        assert!(
            plan.stats.residual < 1e-5,
            "{name}: field did not converge ({})",
            plan.stats.residual
        );
    }
}

#[test]
fn bisectors_are_equidistant_and_inside() {
    for (name, slice) in slices() {
        let planner = host_sim::plan(&slice).unwrap();
        let w = slice.settings().road_width;
        for b in planner.last_plan().bisectors() {
            for &p in b.points.iter() {
                let da = slice.holes()[b.a as usize].signed_distance(p);
                let db = slice.holes()[b.b as usize].signed_distance(p);
                assert!(
                    (da - db).abs() < 0.01,
                    "{name}: bisector point {p:?} off by {}",
                    da - db
                );
                let nearest = slice.nearest_holes(p).1;
                assert!(
                    nearest >= da.min(db) - 0.01,
                    "{name}: a third hole is nearer at {p:?}"
                );
                assert!(
                    slice.wall_clearance(p) >= 0.5 * w - 0.01,
                    "{name}: bisector leaves the region"
                );
            }
        }
    }
}

#[test]
fn roads_along_the_mcls_leave_no_gap_wider_than_a_road() {
    // A gap wider than a road between roads of width w means a point farther than w from every
    // MCL. Outside the corners at branch points, and the far ends of a few MCLs whose starts
    // the refinement left a road apart rather than crowd them (the zigzag widens its roads
    // there), there are none: under 1 % of the region.
    for (name, slice) in slices() {
        let planner = host_sim::plan(&slice).unwrap();
        let plan = planner.last_plan();
        let w = slice.settings().road_width;
        let mut raster = Raster::new(&slice, 0.05);
        for m in plan.mcls.iter() {
            raster.stamp_polyline(&plan.points(m), w);
        }
        let bare = raster.uncovered_fraction();
        assert!(
            bare < 0.01,
            "{name}: {:.4} of the region is farther than a road from every MCL",
            bare
        );
    }
}

#[test]
fn planning_is_deterministic() {
    for (name, slice) in slices() {
        let a = host_sim::plan(&slice).unwrap().last_plan().digest();
        let b = host_sim::plan(&slice.clone()).unwrap().last_plan().digest();
        assert_eq!(a, b, "{name}");
    }
}

#[test]
fn settings_change_the_plan_and_keep_its_properties() {
    let (_, base) = slices().remove(0);
    let digest0 = host_sim::plan(&base).unwrap().last_plan().digest();
    let variants = [
        Settings {
            w_n: 3.0,
            w_d: 0.5,
            ..*base.settings()
        },
        Settings {
            delta: 0.3,
            ..*base.settings()
        },
        Settings {
            relax_iterations: 0,
            ..*base.settings()
        },
        Settings {
            relax_iterations: 30,
            relax_spacing: 0.6,
            ..*base.settings()
        },
        Settings {
            mcl_spacing: 0.6,
            ..*base.settings()
        },
        Settings::for_road_width(0.6),
    ];
    for s in variants {
        let slice = with_settings(&base, s);
        let planner = host_sim::plan(&slice).unwrap();
        let plan = planner.last_plan();
        verify(&slice, plan).unwrap_or_else(|v| panic!("{s:?}: {v:?}"));
        assert_ne!(plan.digest(), digest0, "{s:?} changed nothing");
    }
}

#[test]
fn a_tighter_delta_matches_fewer_pairs() {
    let (_, base) = slices().remove(0);
    let loose = host_sim::plan(&with_settings(
        &base,
        Settings {
            delta: 2.0,
            ..*base.settings()
        },
    ))
    .unwrap();
    let tight = host_sim::plan(&with_settings(
        &base,
        Settings {
            delta: 0.05,
            ..*base.settings()
        },
    ))
    .unwrap();
    let (l, t) = (loose.last_plan().stats, tight.last_plan().stats);
    assert!(t.matched_pairs < l.matched_pairs, "{t:?} vs {l:?}");
    assert!(t.removed_unmatched > l.removed_unmatched);
}
