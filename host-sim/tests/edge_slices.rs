//! Awkward but valid slices (found by review and fuzzing): features a hair from the wall or
//! each other, sharp corners, combs, a C around a circle, a C-shaped wall, a U-shaped hole, a
//! spiky star, extreme settings (a road half or a quarter of the slice across). Each either plans
//! into a plan that passes `verify` and layers that never leave the printable region, or is
//! refused with a typed error — never a panic, never a wrong plan.

mod common;

use hollowpath::toolpath::spiral::ControlFunction;
use hollowpath::{Error, Slice};
use host_sim::layers::{layer, Fill};
use host_sim::slice_file;

fn road_stays_in_region(
    slice: &Slice,
    path: &[hollowpath::toolpath::Vertex],
) -> Result<(), String> {
    let half = 0.5 * slice.settings().road_width;
    for i in 1..path.len() {
        if !path[i].deposit {
            continue;
        }
        let (a, b) = (path[i - 1].at, path[i].at);
        let (wa, wb) = (path[i - 1].width, path[i].width);
        let n = (a.dist(b) / (0.1 * half)).ceil().max(1.0) as usize;
        for t in 0..=n {
            let f = t as f32 / n as f32;
            let p = a.lerp(b, f);
            if !slice.fits(p, wa + (wb - wa) * f, 1e-3) {
                return Err(format!("road {i} leaves the printable region at {p:?}"));
            }
        }
    }
    Ok(())
}

#[test]
fn edge_slices_plan_correctly_or_are_refused() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/edge");
    let mut planned = 0;
    let mut refused = 0;
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    names.sort();
    for path in names {
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        let slice = match slice_file::load(&path) {
            Ok(f) => f.slice,
            Err(e) => panic!("{name}: {e}"),
        };
        let mut planner = Box::new(hollowpath::Planner::new());
        let plan = match planner.plan(&slice) {
            Ok(plan) => plan,
            Err(e @ (Error::NoRoom { .. } | Error::Capacity { .. })) => {
                println!("{name}: refused: {e}");
                refused += 1;
                continue;
            }
            Err(e) => panic!("{name}: unexpected error {e}"),
        };
        hollowpath::verify::verify(&slice, plan).unwrap_or_else(|v| panic!("{name}: {v:?}"));
        for (index, f) in [
            (0, ControlFunction::Linear),
            (1, ControlFunction::Linear),
            (1, ControlFunction::RoadWidth),
            (1, ControlFunction::Ease),
        ] {
            let l =
                layer(&slice, plan, Fill::Mcl(f), index).unwrap_or_else(|e| panic!("{name}: {e}"));
            road_stays_in_region(&slice, &l.path)
                .unwrap_or_else(|e| panic!("{name} {:?} {f:?}: {e}", l.pattern));
        }
        // The default layers: the zigzag with its widened and narrowed roads, and the offset
        // spiral; at most 1 + holes starts (the bar; the aim, met on the reference
        // slices, is 1), within the width limits, never leaving the region.
        for index in 0..2 {
            let l = layer(&slice, plan, Fill::Offset, index)
                .unwrap_or_else(|e| panic!("{name} default {index}: {e}"));
            road_stays_in_region(&slice, &l.path)
                .unwrap_or_else(|e| panic!("{name} {:?}: {e}", l.pattern));
            let (lo, hi) = (slice.settings().min_width, slice.settings().max_width);
            assert!(
                l.path
                    .iter()
                    .all(|v| v.width >= lo - 6.1e-3 && v.width <= hi),
                "{name} {:?}: width out of limits",
                l.pattern
            );
            // As printed (one width per G-code move, a round nozzle): nothing in a hole or
            // outside the wall.
            let cell = slice.settings().road_width / 16.0;
            let m =
                host_sim::metrics::Meter::new(&slice, host_sim::metrics::Options::with_cell(cell))
                    .measure(l.pattern, &l.path, &|_| None);
            assert!(
                m.spill < 5e-4,
                "{name} {:?}: spill {} as printed",
                l.pattern,
                m.spill
            );
            let starts = (1..l.path.len())
                .filter(|&i| l.path[i].deposit && (i == 1 || !l.path[i - 1].deposit))
                .count();
            // Every layer, the zigzag on `quarter_road` (a road a quarter of the slice across)
            // too since moves across a thin feature go round it and moves that sag into a
            // keep-out band are laid narrower.
            let bound = 1 + slice.holes().len();
            assert!(starts <= bound, "{name} {:?}: {starts} starts", l.pattern);
        }
        for index in 0..2 {
            if let Ok(l) = layer(&slice, plan, Fill::Raster, index) {
                road_stays_in_region(&slice, &l.path)
                    .unwrap_or_else(|e| panic!("{name} raster: {e}"));
            }
        }
        planned += 1;
    }
    // Both outcomes occur in this set: the test exercises each.
    assert!(
        planned >= 10 && refused >= 2,
        "planned {planned}, refused {refused}"
    );
}
