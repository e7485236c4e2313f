//! `hollowpath plan`: a slice's MCLs, layers, previews, metrics and G-code, written to a
//! folder.

use std::path::Path;

use super::create_out;
use hollowpath::toolpath::composition::BlendedField;
use hollowpath::toolpath::Pattern;
use host_sim::layers::{self, Fill};
use host_sim::metrics::{LayerMetrics, Meter, Options};
use host_sim::staged::Staged;
use host_sim::{gcode, output, preview, render, slice_file};

pub(crate) fn run(
    file: &slice_file::SliceFile,
    out: &Path,
    count: usize,
    fill: Fill,
    gcode_path: Option<&Path>,
    with_baseline: bool,
    input: Option<&Path>,
) -> Result<(), String> {
    let mut staged = Staged::new(input);
    if let Some(g) = gcode_path {
        staged.check_making(g, Some(out))?;
    }
    // An earlier run's layers beyond this run's count would sit beside its metrics.
    staged.own(out, |name| {
        host_sim::staged::layer_file(name, &[".json", ".svg", ".png", "-deposit.png"])
    });
    let mut write = |path: &Path, bytes: &[u8]| staged.write(path, bytes);
    let slice = &file.slice;
    let planner = host_sim::plan(slice).map_err(|e| format!("planning failed: {e}"))?;
    let plan = planner.last_plan();
    hollowpath::verify::verify(slice, plan)
        .map_err(|v| format!("the plan failed its own check ({v:?}); please report this slice"))?;
    let built =
        layers::layers(slice, plan, fill, count).map_err(|e| format!("layers failed: {e}"))?;
    let baseline = if with_baseline {
        Some(
            layers::layer(slice, plan, Fill::Raster, 0)
                .map_err(|e| format!("baseline failed: {e}"))?,
        )
    } else {
        None
    };

    create_out(out)?;
    let json = serde_json::to_string_pretty(&output::mcls_json(plan)).map_err(|e| e.to_string())?;
    write(&out.join("mcls.json"), json.as_bytes())?;
    write(
        &out.join("mcls.svg"),
        render::mcls_svg(slice, plan).as_bytes(),
    )?;

    let name = if file.name.is_empty() {
        "slice"
    } else {
        &file.name
    };
    let pairs = plan.mcls.iter().filter(|m| m.second.is_some()).count();
    say!(
        "{name}: {} MCLs ({pairs} hole-to-hole through p*, {} to the wall), {} bisectors, {} branch points; digest {:016x}",
        plan.mcls.len(),
        plan.mcls.len() - pairs,
        plan.bisectors().len(),
        plan.cells.branch_points.len(),
        plan.digest()
    );

    let field = BlendedField::new(slice, plan);
    let field_fn = |p| field.at(p);
    // The deposition raster is 0.025 mm, coarser only where the slice would need more than
    // 20 million cells; previews are 20 px/mm up to 16 megapixels.
    let (lo, hi) = slice.wall().bbox();
    let area = ((hi.x - lo.x + 2.0) * (hi.y - lo.y + 2.0)) as f64;
    let cell = (host_sim::metrics::CELL_MM as f64).max((area / 2.0e7).sqrt()) as f32;
    let px_per_mm = 20.0f32.min((16.0e6 / area).sqrt() as f32);
    let mut meter = Meter::new(slice, Options::with_cell(cell));
    let mut measured: Vec<(String, LayerMetrics)> = Vec::new();
    // Each layer's deposition map is drawn from the raster right after it is measured.
    let mut deposits = Vec::new();
    for l in built.iter().chain(baseline.iter()) {
        let m = meter.measure(l.pattern, &l.path, &field_fn);
        measured.push((l.note.clone(), m));
        deposits.push(preview::deposit_png(meter.raster()));
    }
    for l in &built {
        let vertices: Vec<_> = l
            .path
            .iter()
            .map(|v| serde_json::json!({"at": [v.at.x, v.at.y], "deposit": v.deposit, "material": v.material, "width": v.width}))
            .collect();
        let doc = serde_json::json!({"layer": l.index, "pattern": l.pattern.name(), "vertices": vertices});
        write(
            &out.join(format!("layer-{}.json", l.index)),
            doc.to_string().as_bytes(),
        )?;
        write(
            &out.join(format!("layer-{}.svg", l.index)),
            preview::layer_svg(slice, &l.path).as_bytes(),
        )?;
        write(
            &out.join(format!("layer-{}.png", l.index)),
            &preview::layer_png(slice, &l.path, px_per_mm),
        )?;
    }
    for (l, png) in built.iter().zip(&deposits) {
        write(&out.join(format!("layer-{}-deposit.png", l.index)), png)?;
    }
    if let Some(b) = &baseline {
        write(
            &out.join("baseline.svg"),
            preview::layer_svg(slice, &b.path).as_bytes(),
        )?;
        write(
            &out.join("baseline.png"),
            &preview::layer_png(slice, &b.path, px_per_mm),
        )?;
    }
    // Each layer's figures, with how its generator fared (where a jump was needed, and why).
    let mut layer_json = Vec::new();
    for ((note, m), l) in measured.iter().zip(&built) {
        let mut v = serde_json::to_value(m).map_err(|e| e.to_string())?;
        v["note"] = serde_json::Value::String(note.clone());
        let why = host_sim::metrics::explain_starts(slice, &l.path, note);
        v["start_notes"] = serde_json::to_value(&why).map_err(|e| e.to_string())?;
        let warnings = layer_warnings(l.index, l.pattern, m);
        for w in &warnings {
            eprintln!("warning: layer {} ({}): {w}", l.index, l.pattern.name());
        }
        v["warnings"] = serde_json::to_value(&warnings).map_err(|e| e.to_string())?;
        layer_json.push(v);
    }
    let mut doc = serde_json::json!({ "slice": name, "layers": layer_json });
    if baseline.is_some() {
        doc["baseline"] =
            serde_json::to_value(&measured.last().unwrap().1).map_err(|e| e.to_string())?;
    }
    write(
        &out.join("metrics.json"),
        serde_json::to_string_pretty(&doc)
            .map_err(|e| e.to_string())?
            .as_bytes(),
    )?;
    if let Some(g) = gcode_path {
        let layers: Vec<_> = built.iter().map(|l| (l.pattern, l.path.clone())).collect();
        write(g, gcode::export(slice, &layers, 10.0, 40.0).as_bytes())?;
    }
    staged.commit()?;

    say!(
        "{:<8} {:>6} {:>10} {:>11} {:>9} {:>9} {:>7} {:>12}",
        "pattern",
        "starts",
        "travel mm",
        "extruded mm",
        "coverage",
        "overfill",
        "spill",
        "composition"
    );
    for (i, (note, m)) in measured.iter().enumerate() {
        let label = if i >= built.len() { "baseline" } else { "" };
        say!(
            "{:<8} {:>6} {:>10.1} {:>11.1} {:>9.3} {:>9.3} {:>7.4} {:>12.4}   {label}{}{note}",
            m.pattern,
            m.starts,
            m.travel_mm,
            m.extruded_mm,
            m.coverage,
            m.overfill,
            m.spill,
            m.composition_error,
            if label.is_empty() { "" } else { ": " }
        );
    }
    say!(
        "wrote {}/mcls.json, mcls.svg, layer-K.svg/png, layer-K-deposit.png, metrics.json{}",
        out.display(),
        gcode_path
            .map(|g| format!(", {}", g.display()))
            .unwrap_or_default()
    );
    Ok(())
}

/// Below this coverage a layer is said to leave much of the slice bare (`metrics.json`'s
/// `warnings`, and stderr): every layer of the reference and random slices covers 0.92 or
/// more; a zigzag on a C-shaped wall covered 0.39 with nothing said.
const LOW_COVERAGE: f64 = 0.9;

/// What the user should know of a layer before printing it.
fn layer_warnings(index: usize, pattern: Pattern, m: &LayerMetrics) -> Vec<String> {
    let mut out = Vec::new();
    if m.coverage < LOW_COVERAGE {
        let why = if pattern == Pattern::Zigzag {
            "the zigzag's material changing lines do not reach part of the slice (a pocket of \
             a cell far from its feature, such as the arms of a C-shaped wall, which no line \
             from the feature enters); the offset spiral (the odd layers; `slice --layers \
             spiral` lays it on every layer) covers such slices"
        } else {
            "the generator could not reach it"
        };
        out.push(format!(
            "coverage {:.3}: {:.0} % of the slice is left bare (red in layer-{index}-deposit.png); \
             {why}",
            m.coverage,
            100.0 * (1.0 - m.coverage)
        ));
    }
    out
}
