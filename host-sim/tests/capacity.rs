//! How full the core's fixed buffers get on the reference slices: a guard that the capacities
//! in `config.rs` leave head-room (at least a quarter free) for slices like these.

use hollowpath::config::{BOUNDARY_NODES, HALF_POOL_POINTS, MAX_BISECTORS, MAX_HALVES, MAX_MCLS};
use host_sim::{slice_file, REFERENCE_SLICES};

#[test]
fn reference_slices_leave_head_room_in_every_buffer() {
    for (name, text) in REFERENCE_SLICES {
        let slice = slice_file::parse(text).unwrap().slice;
        let planner = host_sim::plan(&slice).unwrap();
        let plan = planner.last_plan();
        let s = plan.stats;
        let rows = [
            ("boundary nodes", s.boundary_nodes as usize, BOUNDARY_NODES),
            ("traced halves", s.traced as usize, MAX_HALVES),
            (
                "points of the traced halves",
                s.half_points as usize,
                HALF_POOL_POINTS,
            ),
            ("MCLs", plan.mcls.len(), MAX_MCLS),
            ("bisectors", plan.bisectors().len(), MAX_BISECTORS),
        ];
        for (what, used, cap) in rows {
            println!("{name}: {what} {used} of {cap}");
            assert!(used * 4 <= cap * 3, "{name}: {what} {used} of {cap}");
        }
    }
}

#[test]
fn working_memory_sizes() {
    use std::mem::size_of;
    let rows = [
        ("Planner", size_of::<hollowpath::Planner>()),
        ("Slice", size_of::<hollowpath::Slice>()),
        ("Feature", size_of::<hollowpath::Feature>()),
        (
            "OffsetSpiral",
            size_of::<hollowpath::toolpath::offset::OffsetSpiral>(),
        ),
        (
            "KeepOut",
            size_of::<hollowpath::keep_out::KeepOut<'static>>(),
        ),
        ("Half", size_of::<hollowpath::mcl::Half>()),
        ("Halves", size_of::<hollowpath::mcl::Halves>()),
        ("Plan", size_of::<hollowpath::Plan>()),
        ("Field", size_of::<hollowpath::field::Field>()),
    ];
    for (what, bytes) in rows {
        println!("{what}: {bytes} bytes ({} KiB)", bytes / 1024);
    }
}
