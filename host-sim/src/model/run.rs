//! `hollowpath slice`: model file (or the built-in scaffold) to slice files, one G-code file
//! for the whole part, metrics and previews, every file staged and renamed into place only
//! once the whole run succeeded.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use indicatif::{ProgressBar, ProgressStyle};

use super::materials::MaterialMap;
use super::part::{self, PlannedLayer, Previews};
use super::{mesh, scaffold, stl, ModelError};
use crate::gcode::{self, PartLayer};
use crate::staged::Staged;

/// What to slice and where to write.
#[derive(Clone, Debug)]
pub struct SliceArgs {
    /// The model file; `None`: the built-in scaffold ([`scaffold::demo`]) of `demo_height`.
    pub model: Option<PathBuf>,
    /// The built-in scaffold's height, mm.
    pub demo_height: f64,
    /// Layer height, mm.
    pub layer_height: f64,
    /// Road width, mm.
    pub road_width: f64,
    /// The materials file.
    pub materials: Option<PathBuf>,
    /// Output directory.
    pub out: PathBuf,
    /// The G-code file (default `out/part.gcode`).
    pub gcode: Option<PathBuf>,
    /// Threads (0: one per core).
    pub jobs: usize,
    /// Draw the per-layer PNGs.
    pub previews: bool,
    /// Every layer the offset spiral (not zigzag and spiral alternating).
    pub spiral_only: bool,
}

/// Printing and travel feeds of the part's G-code, mm/s (as `hollowpath plan`).
const FEED_MM_S: f64 = 10.0;
const TRAVEL_MM_S: f64 = 40.0;

fn progress(len: usize, what: &'static str) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(len as u64);
    if let Ok(style) =
        ProgressStyle::with_template("{msg:>9} [{bar:40}] {pos}/{len} layers {elapsed}")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(what);
    bar
}

/// Runs `hollowpath slice`; returns the lines to print.
pub fn run(args: &SliceArgs) -> Result<Vec<String>, String> {
    let mut said = Vec::new();
    let road = args.road_width;
    if !(road >= hollowpath::config::MIN_ROAD_WIDTH_MM as f64
        && road <= hollowpath::config::MAX_ROAD_WIDTH_MM as f64)
    {
        return Err(ModelError::RoadWidth(road).to_string());
    }
    let shown = args.model.as_ref().map_or_else(
        || "built-in scaffold".to_string(),
        |p| p.display().to_string(),
    );
    let map = match &args.materials {
        Some(p) => {
            let text = crate::json_file::read_text(p, 1 << 20).map_err(|e| match e {
                crate::json_file::ReadError::Io(e) => format!("cannot read {}: {e}", p.display()),
                crate::json_file::ReadError::TooLarge(l) => {
                    format!("{}: larger than {}", p.display(), crate::json_file::size(l))
                }
                crate::json_file::ReadError::NotUtf8(at) => {
                    format!(
                        "{}: not UTF-8 text (invalid byte at offset {at})",
                        p.display()
                    )
                }
            })?;
            super::materials::parse(&text).map_err(|e| format!("{}: {e}", p.display()))?
        }
        None => {
            said.push("materials: no --materials file, so the wall is channel A and every hollow feature channel B".to_string());
            MaterialMap::two_channel()
        }
    };
    let (raw, model_stl) = match &args.model {
        Some(p) => (
            stl::load(p).map_err(|e| format!("{}: {e}", p.display()))?,
            None,
        ),
        None => {
            let tris = scaffold::demo(args.demo_height).triangles();
            let bytes = stl::to_binary(&tris);
            (
                stl::parse(&bytes).map_err(|e| format!("built-in scaffold: {e}"))?,
                Some(bytes),
            )
        }
    };
    let (mesh, report) = mesh::build(&raw).map_err(|e| format!("{shown}: {e}"))?;
    let (lo, hi) = mesh.bounds();
    said.push(format!(
        "{shown}: {} triangles ({} degenerate and {} repeated dropped), {} vertices, {:.3} x {:.3} x {:.3} mm",
        report.read - report.degenerate - report.duplicates,
        report.degenerate,
        report.duplicates,
        report.vertices,
        hi[0] - lo[0],
        hi[1] - lo[1],
        hi[2] - lo[2]
    ));
    let jobs = if args.jobs == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        args.jobs
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .stack_size(crate::STACK_BYTES)
        .build()
        .map_err(|e| format!("cannot start {jobs} planning threads: {e}"))?;
    let n = super::layer_count(hi[2] - lo[2], args.layer_height);
    let bar = progress(n, "slicing");
    let tick = || bar.inc(1);
    let sliced = pool
        .install(|| super::slice_mesh(&mesh, args.layer_height, &map, &tick))
        .map_err(|e| format!("{shown}: {e}"))?;
    bar.finish_and_clear();
    let bar = progress(n, "planning");
    let tick = || bar.inc(1);
    let (w, h) = (road as f32, args.layer_height as f32);
    let planned = pool
        .install(|| {
            part::plan_layers(
                &sliced.layers,
                w,
                h,
                Previews {
                    png: args.previews,
                    spiral_only: args.spiral_only,
                },
                &tick,
            )
        })
        .map_err(|e| format!("{shown}: {e}"))?;
    bar.finish_and_clear();

    for (c, m) in sliced.channels.material.iter().enumerate() {
        let (l0, p) = sliced.channels.first[c];
        let (_, l1) = sliced.channels.span[c];
        let why = match sliced.channels.rule[c] {
            Some(r) => format!("rule channels[{r}]"),
            None => "default".to_string(),
        };
        said.push(format!(
            "channel {c}: layers {l0}-{l1}, from ({:.3}, {:.3}): material {m:?} ({why})",
            p[0], p[1]
        ));
    }
    write_outputs(args, &sliced, &planned, model_stl, &mut said)?;
    Ok(said)
}

fn write_outputs(
    args: &SliceArgs,
    sliced: &super::SlicedModel,
    planned: &[PlannedLayer],
    model_stl: Option<Vec<u8>>,
    said: &mut Vec<String>,
) -> Result<(), String> {
    let out = &args.out;
    let mut staged = Staged::new(args.model.as_deref());
    let gcode_path = args.gcode.clone().unwrap_or_else(|| out.join("part.gcode"));
    // Checked before the folder is made (which counts as there), so a run refused for its
    // G-code file leaves no folder behind.
    staged.check_making(&gcode_path, Some(out))?;
    if out.exists() && !out.is_dir() {
        return Err(format!("--out {} is a file: give a folder", out.display()));
    }
    for d in [out.clone(), out.join("slices"), out.join("previews")] {
        std::fs::create_dir_all(&d).map_err(|e| format!("cannot create {}: {e}", d.display()))?;
    }
    let name = |l: usize, i: usize, ext: &str| {
        if i == 0 {
            format!("layer-{l:04}{ext}")
        } else {
            format!("layer-{l:04}-{i}{ext}")
        }
    };
    let mut layer_docs = Vec::new();
    let mut worst = (1.0f64, 0.0f64, 0.0f64, 0u32);
    let (mut travel, mut extruded, mut starts) = (0.0, 0.0, 0u32);
    for l in planned {
        let between = part::island_travel(l);
        let mut islands = Vec::new();
        for (i, isl) in l.islands.iter().enumerate() {
            staged.write(
                &out.join("slices").join(name(l.index, i, ".json")),
                isl.slice_json.as_bytes(),
            )?;
            if args.previews {
                staged.write(
                    &out.join("previews").join(name(l.index, i, "-deposit.png")),
                    &isl.deposit_png,
                )?;
            }
            let mut v = serde_json::to_value(&isl.metrics).map_err(|e| e.to_string())?;
            v["note"] = serde_json::Value::String(isl.note.clone());
            v["start_notes"] = serde_json::to_value(&isl.start_notes).map_err(|e| e.to_string())?;
            v["channels"] = serde_json::to_value(&isl.channels).map_err(|e| e.to_string())?;
            v["printable_mm2"] = serde_json::json!(isl.printable_mm2);
            if i > 0 {
                v["reached_by"] = serde_json::json!({
                    "travel_mm": between[i - 1],
                    "why": format!("island {i} is a separate piece of the part: the road of island {} ends and a {:.2} mm travel reaches this island's road", i - 1, between[i - 1]),
                });
            }
            islands.push(v);
        }
        if args.previews {
            staged.write(
                &out.join("previews")
                    .join(format!("layer-{:04}.png", l.index)),
                &l.png,
            )?;
        }
        let t = part::totals(l);
        worst.0 = worst.0.min(t.coverage);
        worst.1 = worst.1.max(t.overfill);
        worst.2 = worst.2.max(t.spill);
        worst.3 = worst.3.max(t.starts);
        travel += t.travel_mm;
        extruded += t.extruded_mm;
        starts += t.starts;
        let mut doc = serde_json::to_value(&t).map_err(|e| e.to_string())?;
        doc["layer"] = serde_json::json!(l.index);
        doc["z_mm"] = serde_json::json!(l.z);
        doc["pattern"] = serde_json::json!(l.pattern.name());
        doc["islands"] = serde_json::Value::Array(islands);
        layer_docs.push(doc);
    }
    let channels: Vec<_> = (0..sliced.channels.material.len())
        .map(|c| {
            serde_json::json!({
                "channel": c,
                "material": sliced.channels.material[c],
                "layers": [sliced.channels.span[c].0, sliced.channels.span[c].1],
                "first_at": sliced.channels.first[c].1,
                "rule": sliced.channels.rule[c],
            })
        })
        .collect();
    let doc = serde_json::json!({
        "model": args.model.as_ref().map_or("built-in scaffold".to_string(), |p| p.display().to_string()),
        "layer_height": args.layer_height,
        "road_width": args.road_width,
        "total": {
            "layers": planned.len(),
            "starts": starts,
            "travel_mm": travel,
            "extruded_mm": extruded,
            "min_coverage": worst.0,
            "max_overfill": worst.1,
            "max_spill": worst.2,
            "max_starts_per_layer": worst.3,
        },
        "channels": channels,
        "layers": layer_docs,
    });
    staged.write(
        &out.join("metrics.json"),
        serde_json::to_string_pretty(&doc)
            .map_err(|e| e.to_string())?
            .as_bytes(),
    )?;
    let layers: Vec<PartLayer<'_>> = planned
        .iter()
        .map(|l| PartLayer {
            pattern: l.pattern,
            islands: l.islands.iter().map(|i| &i.path[..]).collect(),
        })
        .collect();
    let g = gcode::export_part(
        args.road_width,
        args.layer_height,
        &layers,
        FEED_MM_S,
        TRAVEL_MM_S,
    );
    staged.write(&gcode_path, g.as_bytes())?;
    if args.previews {
        let pieces = super::view3d::pieces(planned, args.layer_height, 0.1);
        staged.write(&out.join("part.png"), &super::view3d::png(&pieces, 1000))?;
        let title = args
            .model
            .as_ref()
            .and_then(|p| p.file_name())
            .map_or("built-in scaffold".to_string(), |n| {
                n.to_string_lossy().into_owned()
            });
        staged.write(
            &out.join("part.html"),
            super::view3d::html(&title, &pieces, args.layer_height).as_bytes(),
        )?;
    }
    if let Some(bytes) = model_stl {
        staged.write(&out.join("model.stl"), &bytes)?;
    }
    staged.commit()?;
    said.push(format!(
        "{} layers: {starts} extrusion starts, {travel:.1} mm travel, {extruded:.1} mm deposited; worst layer: coverage {:.3}, overfill {:.3}, spill {:.4}, {} starts",
        planned.len(),
        worst.0,
        worst.1,
        worst.2,
        worst.3
    ));
    let left_out = planned
        .iter()
        .flat_map(|l| &l.islands)
        .filter(|i| i.path.is_empty())
        .count();
    if left_out > 0 {
        said.push(format!(
            "warning: {left_out} island(s) left out: no road fits inside them (about a road wide or narrower; metrics.json notes which); a narrower --road-width lays them"
        ));
    }
    said.push(format!(
        "wrote {}/slices/layer-NNNN.json, {}metrics.json, {}",
        out.display(),
        if args.previews {
            "previews/layer-NNNN.png, part.png and part.html (the part in 3D), "
        } else {
            ""
        },
        gcode_path.display()
    ));
    Ok(())
}

/// The default output directory of `path`'s model.
pub fn default_out(path: Option<&Path>) -> PathBuf {
    match path.and_then(|p| p.file_stem()) {
        Some(stem) => Path::new("out").join(stem),
        None => PathBuf::from("out/part"),
    }
}
