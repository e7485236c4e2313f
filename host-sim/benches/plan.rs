//! Planning each reference slice on the host (criterion). Compare runs as ratios: the machines
//! are shared and noisy.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
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

criterion_group!(benches, plan_reference_slices);
criterion_main!(benches);
