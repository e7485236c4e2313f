//! Layers on the reference slices, measured as DESIGN.md defines it: what the bar already
//! demands and holds (no spill, few starts, features' materials), and how the MCL layers
//! compare with the raster baseline.

use hollowpath::toolpath::composition::BlendedField;
use hollowpath::toolpath::spiral::ControlFunction;
use hollowpath::toolpath::Pattern;
use hollowpath::Slice;
use host_sim::layers::{layer, Fill, Layer};
use host_sim::metrics::{LayerMetrics, Meter, Options};
use host_sim::{gcode, slice_file, REFERENCE_SLICES};

/// Plans `slice` and builds and measures the given layers (index, fill) on a 0.05 mm raster
/// (coarser than the CLI's, to keep the test quick; the figures move by < 0.5 %).
fn measured(slice: &Slice, layers: &[(usize, Fill)]) -> Vec<(Layer, LayerMetrics)> {
    let planner = host_sim::plan(slice).unwrap();
    let plan = planner.last_plan();
    let field = BlendedField::new(slice, plan);
    let field_fn = |p| field.at(p);
    let mut meter = Meter::new(slice, Options::with_cell(0.05));
    layers
        .iter()
        .map(|&(index, fill)| {
            let l = layer(slice, plan, fill, index).unwrap();
            let m = meter.measure(l.pattern, &l.path, &field_fn);
            (l, m)
        })
        .collect()
}

#[test]
fn mcl_layers_meet_the_spill_start_and_composition_bar() {
    for (name, text) in REFERENCE_SLICES {
        let slice = slice_file::parse(text).unwrap().slice;
        let holes = slice.holes().len() as u32;
        let fills = [
            (0, Fill::Mcl(ControlFunction::RoadWidth)),
            (1, Fill::Mcl(ControlFunction::Linear)),
            (1, Fill::Mcl(ControlFunction::RoadWidth)),
            (1, Fill::Mcl(ControlFunction::Ease)),
        ];
        for (l, m) in measured(&slice, &fills) {
            let what = format!("{name} {} ({})", m.pattern, l.note);
            println!("{what}: {m:?}");
            assert!(m.spill < 1e-4, "{what}: spill {}", m.spill);
            assert!(m.starts <= 1 + holes, "{what}: {} starts", m.starts);
            assert!(
                m.feature_composition_error < 1e-3,
                "{what}: {}",
                m.feature_composition_error
            );
            // Deposited composition follows the blended field (the zigzag exactly, the spiral
            // up to its chords between MCLs).
            assert!(
                m.composition_error < 0.05,
                "{what}: {}",
                m.composition_error
            );
            assert!(m.coverage > 0.8, "{what}: coverage {}", m.coverage);
            // The zigzag and the road-width spiral are one continuous road on every reference
            // slice.
            if l.pattern == Pattern::Zigzag || l.note.contains("road-width") {
                assert_eq!(host_sim::metrics::road_runs(&l.path).len(), 1, "{what}");
            }
        }
    }
}

#[test]
fn default_layers_meet_the_bar_on_every_reference_slice() {
    // The issue's bar, both layers of the default fill (the zigzag, then the offset spiral):
    // one start, no spill, coverage >= 0.97, overfill <= 0.04, each feature's material on its
    // keep-out curve. On the test's coarser raster the figures move by < 0.5 %.
    for (name, text) in REFERENCE_SLICES {
        let slice = slice_file::parse(text).unwrap().slice;
        let (lo, hi) = (slice.settings().min_width, slice.settings().max_width);
        for (l, m) in measured(&slice, &[(0, Fill::Offset), (1, Fill::Offset)]) {
            let what = format!("{name} {} ({})", m.pattern, l.note);
            println!("{what}: {m:?}");
            assert_eq!(m.spill, 0.0, "{what}");
            assert_eq!(m.starts, 1, "{what}");
            assert_eq!(m.travel_mm, 0.0, "{what}");
            assert_eq!(host_sim::metrics::road_runs(&l.path).len(), 1, "{what}");
            assert!(m.feature_composition_error < 1e-3, "{what}");
            assert!(m.composition_error < 0.05, "{what}");
            assert!(m.coverage >= 0.97, "{what}: coverage {}", m.coverage);
            assert!(m.overfill <= 0.04, "{what}: overfill {}", m.overfill);
            // Roads widen and narrow to fill, within the slice's limits, and not all alike.
            assert!(l
                .path
                .iter()
                .all(|v| v.width >= lo - 6.1e-3 && v.width <= hi));
            assert!(l.path.iter().any(|v| v.width > slice.settings().road_width));
        }
    }
}

/// A splice lays two arcs over one stretch of a keep-out curve, half a road each, and the MCLs
/// into the inner arc end a quarter road off the curve, as wide as their bands. The outer arc
/// drops to its half of the strip a road before the inner arc's first end and keeps to it
/// until a road after its last: four_holes' zigzag (60 splices then) doubled 0.031 of its
/// ground when the outer arc ran at full width up to those ends (lenses of a road across at
/// every one of them), 0.024 after. With strong fans keeping halves that crowd for up to 12
/// road widths (eight more MCLs) it splices 45 loops, and doubles 0.024 of its ground. Since
/// pairs that crowd at a hole turn short of it (a splice's inner pair too: its outer arc then
/// has the stretch to itself) and halves are inserted where ends part by 1.5 roads (not 1.9),
/// it splices 43 and doubles 0.010 (coverage 0.9906). Since strong fans take halves from
/// starts a tenth of the narrowest road apart (more MCLs, more of them turning short), it
/// splices 32 and doubles 0.013 (coverage 0.9925). Since pairs turn short from half a road
/// out, not a road (45 pairs turn short, 39 before), it doubles 0.0144 (0.0133; coverage
/// 0.9921); since the MCLs beside a pair may be a whole widest road apart within three roads of
/// the hole (68 pairs), 0.0123, covering 0.98996.
#[test]
fn a_splices_outer_arc_leaves_the_mcls_into_the_inner_arc_their_ground() {
    let slice = slice_file::parse(REFERENCE_SLICES[0].1).unwrap().slice;
    let (l, m) = measured(&slice, &[(0, Fill::Offset)]).remove(0);
    let what = format!("{} ({}): {m:?}", m.pattern, l.note);
    println!("{what}");
    assert!(l.note.contains("splicing 32 loops"), "{what}");
    assert!(m.overfill <= 0.013, "{what}");
    assert!(m.coverage >= 0.989, "{what}");
}

#[test]
fn raster_baseline_is_measured_the_same_way() {
    let slice = slice_file::parse(REFERENCE_SLICES[0].1).unwrap().slice;
    let both = measured(
        &slice,
        &[(0, Fill::Raster), (0, Fill::Mcl(ControlFunction::Linear))],
    );
    let (m, mz) = (&both[0].1, &both[1].1);
    // Many starts (a perimeter per feature and broken lines), good coverage, no spill.
    assert!(m.starts > 1 + slice.holes().len() as u32, "{m:?}");
    assert!(m.coverage > 0.97 && m.spill < 1e-4, "{m:?}");
    assert!(
        mz.starts < m.starts && mz.travel_mm < m.travel_mm,
        "{mz:?} vs {m:?}"
    );
}

/// The two default layers of `slice` (the zigzag, then the offset spiral), as G-code takes them.
fn default_layers(slice: &hollowpath::Slice) -> Vec<(Pattern, Vec<hollowpath::toolpath::Vertex>)> {
    let planner = host_sim::plan(slice).unwrap();
    let plan = planner.last_plan();
    (0..2)
        .map(|k| {
            let l = layer(slice, plan, Fill::Offset, k).unwrap();
            (l.pattern, l.path)
        })
        .collect()
}

#[test]
fn gcode_of_real_layers_reads_back_as_the_same_path() {
    let (_, text) = REFERENCE_SLICES[1];
    let slice = slice_file::parse(text).unwrap().slice;
    let layers = default_layers(&slice);
    let text = gcode::export(&slice, &layers, 10.0, 40.0);
    let back = gcode::parse(&text).unwrap();
    assert_eq!(back.len(), 2);
    for ((pattern, path), (name, parsed)) in layers.iter().zip(&back) {
        assert_eq!(name.as_deref(), Some(pattern.name()));
        // The file holds the layer's moves as a printer lays them: each move split to
        // constant width and mix. G-code carries 4 decimals: moves that round to nothing vanish.
        let q = |p: hollowpath::geometry::Point| ((p.x * 1e4).round(), (p.y * 1e4).round());
        let mut at = q(path[0].at);
        let real: Vec<_> = host_sim::metrics::planned_moves(path)
            .into_iter()
            .filter(|m| {
                let keep = !m.deposit || q(m.to) != at;
                if keep {
                    at = q(m.to);
                }
                keep
            })
            .collect();
        // The first parsed vertex is where the layer starts (reached by travel).
        let printed = gcode::printed_moves(parsed);
        assert!(parsed[0].at.dist(path[0].at) < 2e-4);
        assert_eq!(real.len(), printed.len(), "{pattern:?}");
        for (a, b) in real.iter().zip(&printed) {
            assert!(a.to.dist(b.to) < 2e-4, "{a:?} {b:?}");
            assert_eq!(a.deposit, b.deposit, "{a:?} {b:?}");
            // E gives each depositing move's width back (to its 6 decimals and the
            // coordinates' 4 on the move's length: within 1 % on moves of 0.05 mm or more).
            if a.deposit && a.length() >= 0.05 {
                assert!((a.width - b.width).abs() < 0.01 * a.width, "{a:?} {b:?}");
            }
            for c in 0..4 {
                assert!((a.material[c] - b.material[c]).abs() < 2e-3, "{a:?} {b:?}");
            }
        }
        // Roads that taper or blend are laid in more moves than they have vertices.
        assert!(real.len() > path.len(), "{pattern:?}");
        // No move's width differs from its road's by more than 5 %: the split pieces lie
        // within the planned road, each within 5 % of its width at both ends.
        for w in path.windows(2) {
            let (a, b) = (&w[0], &w[1]);
            if a.at.dist(b.at) < 1e-3 {
                continue;
            }
            hollowpath::toolpath::moves::split(a, b, |m| {
                if !m.deposit {
                    return;
                }
                let t = |p: hollowpath::geometry::Point| {
                    let l = a.at.dist(b.at);
                    if l > 0.0 {
                        a.at.dist(p) / l
                    } else {
                        0.0
                    }
                };
                for end in [m.from, m.to] {
                    let road = a.width + (b.width - a.width) * t(end);
                    assert!(
                        m.width <= road + 1e-4 && m.width >= road * 0.95 - 1e-4,
                        "{m:?} in {a:?} {b:?}"
                    );
                }
            });
        }
    }
}

#[test]
fn metrics_agree_with_the_exported_gcode_as_printed() {
    // metrics.json measures the layer's moves as the G-code states them; depositing the
    // exported file read back (one width per move from its E) gives the same figures.
    for (name, text) in REFERENCE_SLICES {
        let slice = slice_file::parse(text).unwrap().slice;
        let layers = default_layers(&slice);
        let back = gcode::parse(&gcode::export(&slice, &layers, 10.0, 40.0)).unwrap();
        let field = |_p: hollowpath::geometry::Point| None;
        let mut meter = host_sim::metrics::Meter::new(&slice, Default::default());
        for ((pattern, path), (_, parsed)) in layers.iter().zip(&back) {
            let planned = meter.measure(*pattern, path, &field);
            let printed = meter.measure_moves(*pattern, &gcode::printed_moves(parsed), &field);
            let what = format!("{name} {pattern:?}: {planned:?} vs {printed:?}");
            assert!((planned.coverage - printed.coverage).abs() < 3e-3, "{what}");
            assert!((planned.overfill - printed.overfill).abs() < 3e-3, "{what}");
            assert!((planned.spill - printed.spill).abs() < 3e-3, "{what}");
            assert_eq!(planned.starts, printed.starts, "{what}");
        }
    }
}

/// A slice file's text: a round wall of `sides` vertices and radius `radius` mm, with a round
/// hole of radius `hole` (none at 0) at `at`, 0.4 mm roads.
fn round_slice(sides: usize, radius: f32, hole: f32, at: (f32, f32)) -> Slice {
    let ring = |c: (f32, f32), r: f32, n: usize| {
        (0..n)
            .map(|i| {
                let a = 2.0 * std::f32::consts::PI * i as f32 / n as f32;
                format!("[{}, {}]", c.0 + r * a.cos(), c.1 + r * a.sin())
            })
            .collect::<Vec<_>>()
            .join(", ")
    };
    let holes = if hole > 0.0 {
        format!(
            r#"{{"points": [{}], "material": [0, 1, 0, 0]}}"#,
            ring(at, hole, 24)
        )
    } else {
        String::new()
    };
    let text = format!(
        r#"{{"units": "mm", "outer": {{"points": [{}], "material": [1, 0, 0, 0]}}, "holes": [{holes}], "settings": {{"road_width": 0.4}}}}"#,
        ring((0.0, 0.0), radius, sides)
    );
    slice_file::parse(&text).unwrap().slice
}

/// A round wall sampled by 32 to 40 vertices (as a CAD exporter tessellates a cylinder) turns
/// its edges 9 to 11 degrees at each: each vertex's spoke, where its two edges are equally near,
/// is a ridge of the wall's own that the offset spiral's turns cross round a corner, but its
/// distance fell short of growing with the step by the tolerance only half a road to a road
/// beyond it, and every turn's road widened there into a sliver that is not there. A plain disk
/// of 36 vertices had overfill 0.111, of 40 0.076 (24 or 48 vertices: 0.004, 0.002); a spoke
/// counts as a ridge now only where the distance beyond it falls or grows as slowly as fronts
/// meeting at 60 degrees (`toolpath::offset::ridge`).
#[test]
fn the_offset_spiral_does_not_widen_at_the_vertices_of_a_round_wall() {
    for (sides, radius) in [(32, 7.0), (36, 7.0), (40, 10.0)] {
        let slice = round_slice(sides, radius, 0.0, (0.0, 0.0));
        let (l, m) = measured(&slice, &[(1, Fill::Offset)]).remove(0);
        let what = format!("{sides} sides, radius {radius}: {} ({})", m.pattern, l.note);
        println!("{what}: {m:?}");
        assert_eq!(m.starts, 1, "{what}");
        assert!(m.overfill <= 0.01, "{what}: overfill {}", m.overfill);
        assert!(m.coverage >= 0.99, "{what}: coverage {}", m.coverage);
    }
}

/// A channel at the centre of a round wall: the wall's turns and the channel's meet at a ridge
/// they never cross, a circle half way, and no loop runs beside loops of both families. The
/// join across that ridge (`toolpath::offset::pinch`) kept the distance along its
/// bridge within half a road of the two loops', clear of a road a level above; between the
/// last turns it rises higher (0.75 to 0.99 of a road above theirs for these channels), though
/// no turn lies above them there. Each family was a road of its own: two starts for channels
/// of radius 1 µm to 0.3 mm. Where no loop a level above lies near the bridge, it is joined now.
#[test]
fn the_offset_spiral_joins_a_centred_channel_across_its_ridge_in_one_road() {
    for hole in [0.01, 0.2, 0.3] {
        let slice = round_slice(200, 10.0, hole, (0.0, 0.0));
        let (l, m) = measured(&slice, &[(1, Fill::Offset)]).remove(0);
        let what = format!("hole {hole} mm: {} ({})", m.pattern, l.note);
        println!("{what}: {m:?}");
        assert_eq!(m.starts, 1, "{what}");
        assert!(l.note.contains(", 0 jump(s)"), "{what}");
        assert!(m.spill < 5e-4 && m.overfill <= 0.04, "{what}");
        assert!(m.coverage >= 0.97, "{what}: coverage {}", m.coverage);
    }
}
