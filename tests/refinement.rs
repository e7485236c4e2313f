//! The MCL halves' refinement in strong fans (`mcl::insert`): a small hole in a large cell
//! takes halves from starts closer than the regular rule allows.

mod common;

use common::{circle, feature, A, WALL};
use hollowpath::verify::verify;
use hollowpath::{FeatureId, Planner, Settings, Slice, Target};

/// A hole 0.6 mm across in the middle of a wall 24 mm across (0.4 mm roads): its halves fan
/// out radially, 20 times wider apart at the wall than at its keep-out curve.
fn small_hole_in_a_large_cell() -> Slice {
    let wall = feature(FeatureId::Wall, &circle(0.0, 0.0, 12.0, 128, 0.0), WALL);
    let hole = feature(FeatureId::Hole(0), &circle(0.0, 0.0, 0.3, 48, 0.0), A);
    Slice::new(wall, &[hole], Settings::default()).unwrap()
}

#[test]
fn a_strong_fan_takes_halves_from_closer_starts() {
    let slice = small_hole_in_a_large_cell();
    let s = slice.settings();
    let mut planner = Box::new(Planner::new());
    let plan = planner.plan(&slice).unwrap();
    verify(&slice, plan).unwrap();
    // The regular rule: starts a road apart round the keep-out curve, the gaps halved while
    // they are at least 0.9 narrowest roads, at most three times.
    let keep_out = std::f32::consts::TAU * (0.3 + 0.5 * s.road_width);
    let starts = (keep_out / s.mcl_spacing).ceil() as usize;
    let (mut regular, mut gap) = (starts, keep_out / starts as f32);
    for _ in 0..3 {
        if gap >= 0.9 * s.min_width {
            regular *= 2;
            gap *= 0.5;
        }
    }
    let to_wall = plan.mcls.iter().filter(|m| m.to == Target::Wall).count();
    assert!(
        to_wall > regular,
        "{to_wall} MCLs to the wall, at most {regular} without the strong fan's halves"
    );
    // Radial halves 0.05 mm apart at the start part to a narrowest road within about four
    // road widths: none crowds.
    assert_eq!(plan.stats.dropped_crowded, 0, "{:?}", plan.stats);
}
