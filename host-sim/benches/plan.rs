//! Planning each reference slice on the host (criterion). Compare runs as ratios: the machines
//! are shared and noisy.

use criterion::{black_box, criterion_group, Criterion};
use hollowpath::Planner;
use host_sim::{slice_file, REFERENCE_SLICES};

fn plan_reference_slices(c: &mut Criterion) {
    let mut group = c.benchmark_group("plan");
    group.sample_size(20);
    let mut planner = Box::new(Planner::new());
    for (name, text) in REFERENCE_SLICES {
        let slice = slice_file::parse(text).unwrap().slice;
        group.bench_function(name, |b| {
            b.iter(|| {
                let plan = planner.plan(black_box(&slice)).unwrap();
                black_box(plan.mcls.len())
            })
        });
    }
    group.finish();
}

fn layers_of_reference_slices(c: &mut Criterion) {
    use hollowpath::toolpath::spiral::ControlFunction;
    use host_sim::layers::{layer, Fill};
    let mut group = c.benchmark_group("layer");
    group.sample_size(20);
    for (name, text) in REFERENCE_SLICES {
        let slice = slice_file::parse(text).unwrap().slice;
        let planner = host_sim::plan(&slice).unwrap();
        let plan = planner.last_plan();
        for (what, fill, index) in [
            ("zigzag", Fill::Offset, 0),
            (
                "spiral-road-width",
                Fill::Mcl(ControlFunction::RoadWidth),
                1,
            ),
            ("spiral-offset", Fill::Offset, 1),
        ] {
            group.bench_function(format!("{name}/{what}"), |b| {
                b.iter(|| {
                    let l = layer(&slice, plan, fill, index).unwrap();
                    black_box(l.path.len())
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, plan_reference_slices, layers_of_reference_slices);

/// `criterion_main!` on a thread with room for the host build's capacities (the planner and
/// the layers' working memory take megabytes, more than the main thread's stack).
fn main() {
    std::thread::Builder::new()
        .stack_size(512 << 20)
        .spawn(|| {
            benches();
            Criterion::default().configure_from_args().final_summary();
        })
        .unwrap()
        .join()
        .unwrap();
}
