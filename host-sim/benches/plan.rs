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

/// A sink that takes the first vertex and refuses the next: a build into it runs to its
/// first vertex (the wait before a layer's road can start).
struct FirstVertex(Option<hollowpath::toolpath::Vertex>);

impl hollowpath::toolpath::PathSink for FirstVertex {
    fn push_vertex(
        &mut self,
        v: hollowpath::toolpath::Vertex,
    ) -> Result<(), hollowpath::toolpath::Vertex> {
        match self.0 {
            None => {
                self.0 = Some(v);
                Ok(())
            }
            Some(_) => Err(v),
        }
    }
    fn last_vertex(&self) -> Option<hollowpath::toolpath::Vertex> {
        self.0
    }
}

/// The offset spiral prepared once per slice (as the controller does after planning) against
/// a fresh one: the whole layer, and the time to its first vertex.
fn offset_spiral_prepared(c: &mut Criterion) {
    use hollowpath::toolpath::offset::OffsetSpiral;
    let mut group = c.benchmark_group("offset");
    group.sample_size(10);
    for (name, text) in REFERENCE_SLICES {
        let slice = slice_file::parse(text).unwrap().slice;
        let planner = host_sim::plan(&slice).unwrap();
        let plan = planner.last_plan();
        let mut prepared = Box::new(OffsetSpiral::new());
        let mut grid = Box::new(hollowpath::field::GridMemory::new());
        prepared.prepare(&slice, &mut grid).unwrap();
        for (what, fresh) in [("fresh", true), ("prepared", false)] {
            let mut fresh_one = Box::new(OffsetSpiral::new());
            let mut grid = Box::new(hollowpath::field::GridMemory::new());
            group.bench_function(format!("{name}/{what}/layer"), |b| {
                b.iter(|| {
                    let work = if fresh {
                        *fresh_one = OffsetSpiral::new();
                        &mut fresh_one
                    } else {
                        &mut prepared
                    };
                    let mut path: Vec<hollowpath::toolpath::Vertex> = Vec::new();
                    work.build(black_box(&slice), plan, &mut grid, &mut path)
                        .unwrap();
                    black_box(path.len())
                })
            });
            group.bench_function(format!("{name}/{what}/first_vertex"), |b| {
                b.iter(|| {
                    let work = if fresh {
                        *fresh_one = OffsetSpiral::new();
                        &mut fresh_one
                    } else {
                        &mut prepared
                    };
                    let mut first = FirstVertex(None);
                    // Refused at the second vertex: the build stops there.
                    let stopped = work
                        .build(black_box(&slice), plan, &mut grid, &mut first)
                        .is_err();
                    black_box((stopped, first.0.is_some()))
                })
            });
        }
    }
    group.finish();
}

criterion_group!(
    benches,
    plan_reference_slices,
    layers_of_reference_slices,
    offset_spiral_prepared
);

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
