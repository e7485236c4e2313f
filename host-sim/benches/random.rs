//! The distribution of both default layers' figures, as printed, over random slices
//! (`host_sim::random_slice`): min, median and max of coverage, overfill and spill, starts, and
//! how many slices meet the bar (one start, coverage >= 0.97, overfill <= 0.04,
//! spill < 0.0005).
//!
//! `cargo bench -p host-sim --bench random` draws 200 slices from seed 1;
//! `HOLLOWPATH_SLICES=N`, `HOLLOWPATH_SEED=S`, `HOLLOWPATH_MAX_HOLES=H` and `HOLLOWPATH_GAP=G`
//! (the least gap between features, in roads: 1.5) change that, and
//! `HOLLOWPATH_DUMP=DIR` writes every slice that misses the bar there as a slice file (its
//! seed in the name, `simplify_tolerance` 0 so that its contours stay as drawn) to plan again
//! with `hollowpath plan` (with `HOLLOWPATH_DUMP_ALL=1` every slice, to look at one that
//! meets it); `HOLLOWPATH_CSV=FILE` writes every
//! slice's figures per layer there. `HOLLOWPATH_LATTICE=1` measures the 48 regular arrays of
//! channels of `random_slice::lattices` instead (their number in the seed's place; dumped as
//! `lattice-N.json`).

use std::sync::Mutex;

use hollowpath::toolpath::Pattern;
use host_sim::layers::{layer, Fill};
use host_sim::metrics::{LayerMetrics, Meter, Options};
use host_sim::random_slice::{draw_many, lattices, to_json, Draw, RandomSlice};

fn env<T: std::str::FromStr>(key: &str, default: T) -> T {
    std::env::var(key)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// One slice's outcome: per layer (zigzag, spiral) its metrics, or why it failed.
type Outcome = (u64, String, Vec<Result<LayerMetrics, String>>);

fn run(r: &RandomSlice) -> Outcome {
    let slice = &r.slice;
    let plan = match host_sim::plan(slice) {
        Ok(p) => p,
        Err(e) => {
            return (
                r.seed,
                r.description.clone(),
                vec![Err(format!("plan: {e}")); 2],
            )
        }
    };
    let plan = plan.last_plan();
    // The plan's own check, as the CLI runs it before it writes anything: a slice whose plan
    // fails it gets no layers there.
    if let Err(v) = hollowpath::verify::verify(slice, plan) {
        return (
            r.seed,
            r.description.clone(),
            vec![Err(format!("verify: {v:?}")); 2],
        );
    }
    let cell = slice.settings().road_width / 16.0;
    let mut meter = Meter::new(slice, Options::with_cell(cell));
    let none = |_p: hollowpath::geometry::Point| None;
    let layers = (0..2)
        .map(|k| {
            let l = layer(slice, plan, Fill::Offset, k).map_err(|e| format!("layer {k}: {e}"))?;
            Ok(meter.measure(l.pattern, &l.path, &none))
        })
        .collect();
    (r.seed, r.description.clone(), layers)
}

fn meets(m: &LayerMetrics) -> bool {
    m.starts == 1
        && m.coverage >= 0.97
        && m.overfill <= 0.04
        && m.spill < 5e-4
        && m.feature_composition_error < 1e-3
}

fn stats(name: &str, mut v: Vec<f64>) {
    if v.is_empty() {
        return;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let q = |f: f64| v[((v.len() - 1) as f64 * f).round() as usize];
    println!(
        "  {name:<9} min {:.4}  p10 {:.4}  median {:.4}  p90 {:.4}  max {:.4}",
        v[0],
        q(0.1),
        q(0.5),
        q(0.9),
        v[v.len() - 1]
    );
}

fn main() {
    // `cargo bench` passes `--bench`; a filter that is not ours means another bench target.
    if std::env::args().skip(1).any(|a| !a.starts_with("--")) {
        return;
    }
    // Slices of the host build's capacities are megabytes each.
    host_sim::run_on_large_stack(bench);
}

fn bench() {
    let count = env("HOLLOWPATH_SLICES", 200usize);
    let seed = env("HOLLOWPATH_SEED", 1u64);
    let how = Draw {
        max_holes: env("HOLLOWPATH_MAX_HOLES", Draw::default().max_holes),
        gap: env("HOLLOWPATH_GAP", Draw::default().gap),
        ..Draw::default()
    };
    let dump = std::env::var("HOLLOWPATH_DUMP").ok();
    let dump_all = env("HOLLOWPATH_DUMP_ALL", 0u32) != 0;
    let lattice = env("HOLLOWPATH_LATTICE", 0u32) != 0;
    let slices = if lattice {
        lattices()
    } else {
        draw_many(seed, count, &how)
    };
    let next = Mutex::new(0usize);
    let outcomes = Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..std::thread::available_parallelism().map_or(2, |n| n.get()) {
            s.spawn(|| loop {
                let k = {
                    let mut n = next.lock().unwrap();
                    *n += 1;
                    *n - 1
                };
                let Some(r) = slices.get(k) else { break };
                let o = std::thread::Builder::new()
                    .stack_size(64 << 20)
                    .spawn_scoped(s, || run(r))
                    .unwrap()
                    .join()
                    .unwrap_or_else(|_| {
                        (
                            r.seed,
                            r.description.clone(),
                            vec![Err("panicked".into()); 2],
                        )
                    });
                outcomes.lock().unwrap().push(o);
            });
        }
    });
    let mut outcomes = outcomes.into_inner().unwrap();
    outcomes.sort_by_key(|o| o.0);
    if lattice {
        println!(
            "lattices: {} regular arrays of round channels in a square wall",
            slices.len()
        );
    } else {
        println!(
            "random slices: {} drawn from seed {seed}, 1-{} holes, road {:?} mm, gap {} roads",
            slices.len(),
            how.max_holes,
            how.road_width,
            how.gap
        );
    }
    for (k, pattern) in [Pattern::Zigzag, Pattern::Spiral].iter().enumerate() {
        let ok: Vec<&LayerMetrics> = outcomes
            .iter()
            .filter_map(|o| o.2[k].as_ref().ok())
            .collect();
        let failed: Vec<_> = outcomes
            .iter()
            .filter_map(|o| o.2[k].as_ref().err().map(|e| (o.0, e)))
            .collect();
        println!(
            "{} ({} measured, {} failed, {} meet the bar):",
            pattern.name(),
            ok.len(),
            failed.len(),
            ok.iter().filter(|m| meets(m)).count()
        );
        stats("coverage", ok.iter().map(|m| m.coverage).collect());
        stats("overfill", ok.iter().map(|m| m.overfill).collect());
        stats("spill", ok.iter().map(|m| m.spill).collect());
        stats("starts", ok.iter().map(|m| m.starts as f64).collect());
        // Each feature's own material where a move starts or ends on its keep-out curve: the
        // largest half-L1 deviation.
        stats(
            "lining",
            ok.iter().map(|m| m.feature_composition_error).collect(),
        );
        for (seed, e) in failed.iter().take(5) {
            println!("  seed {seed} failed: {e}");
        }
        let mut worst: Vec<_> = outcomes
            .iter()
            .filter_map(|o| o.2[k].as_ref().ok().filter(|m| !meets(m)).map(|m| (o, m)))
            .collect();
        worst.sort_by(|a, b| a.1.coverage.total_cmp(&b.1.coverage));
        for (o, m) in worst.iter().take(5) {
            println!(
                "  misses: {} -> starts {} coverage {:.4} overfill {:.4} spill {:.5}",
                o.1, m.starts, m.coverage, m.overfill, m.spill
            );
        }
    }
    if let Ok(file) = std::env::var("HOLLOWPATH_CSV") {
        let mut csv =
            String::from("seed,layer,starts,coverage,overfill,spill,lining,description\n");
        for o in &outcomes {
            for (k, m) in o.2.iter().enumerate() {
                let row = match m {
                    Ok(m) => format!(
                        "{},{k},{},{:.4},{:.4},{:.5},{:.4}",
                        o.0, m.starts, m.coverage, m.overfill, m.spill, m.feature_composition_error
                    ),
                    Err(_) => format!("{},{k},,,,,", o.0),
                };
                csv.push_str(&format!("{row},\"{}\"\n", o.1));
            }
        }
        std::fs::write(file, csv).unwrap();
    }
    if let Some(dir) = dump {
        std::fs::create_dir_all(&dir).unwrap();
        for o in &outcomes {
            if !dump_all && o.2.iter().all(|m| m.as_ref().is_ok_and(meets)) {
                continue;
            }
            let r = slices.iter().find(|r| r.seed == o.0).unwrap();
            let kind = if lattice { "lattice" } else { "random" };
            let name = format!("{kind}-{}", o.0);
            std::fs::write(format!("{dir}/{name}.json"), to_json(&r.slice, &name)).unwrap();
        }
    }
}
