//! Planning a sliced model: every island of every layer built into a [`Slice`], planned with
//! the core (MCLs, then the layer: zigzag on even layers, offset spiral on odd ones, as
//! `hollowpath plan --layers` alternates; the offset spiral alone on an island with no hole),
//! measured as printed, previewed, and written back as a slice file. Layers are planned in
//! parallel on the current rayon pool; each layer's result depends on that layer alone, so
//! the output is the same for any number of threads.

use hollowpath::geometry::Point;
use hollowpath::toolpath::composition::BlendedField;
use hollowpath::toolpath::{Pattern, Vertex};
use hollowpath::{Settings, Slice};
use rayon::prelude::*;
use serde::Serialize;

use super::error::ModelError;
use super::ModelLayer;
use crate::layers::{self, Fill};
use crate::metrics::{self, LayerMetrics, Meter, Options, StartNote};

/// One planned island.
#[derive(Clone, Debug)]
pub struct PlannedIsland {
    /// Its road, as the core laid it.
    pub path: Vec<Vertex>,
    /// Its figures as printed.
    pub metrics: LayerMetrics,
    /// Why each extra start.
    pub start_notes: Vec<StartNote>,
    /// How the generator fared.
    pub note: String,
    /// The printable area as rasterised, mm^2.
    pub printable_mm2: f64,
    /// Its channels, hole by hole.
    pub channels: Vec<usize>,
    /// Its slice file (SLICE_FORMAT).
    pub slice_json: String,
    /// Its deposition map.
    pub deposit_png: Vec<u8>,
}

/// One planned layer.
#[derive(Clone, Debug)]
pub struct PlannedLayer {
    /// From 0 at the bed.
    pub index: usize,
    /// The cut's height, mm above the model's bottom.
    pub z: f64,
    /// Zigzag or spiral.
    pub pattern: Pattern,
    /// The islands in printing order.
    pub islands: Vec<PlannedIsland>,
    /// The layer's preview: every island's roads coloured by composition, the travel between
    /// them dashed (empty without previews).
    pub png: Vec<u8>,
}

/// How a part's layers are planned.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Previews {
    /// Draw the road and deposition PNGs.
    pub png: bool,
    /// Lay every layer as the offset spiral (instead of zigzag on even layers).
    pub spiral_only: bool,
}

fn points(pts: &[[f64; 2]]) -> Vec<Point> {
    pts.iter()
        .map(|p| Point::new(p[0] as f32, p[1] as f32))
        .collect()
}

/// The slice of island `i` of `layer`, with `road_width` and `layer_height`.
pub fn island_slice(
    layer: &ModelLayer,
    i: usize,
    road_width: f32,
    layer_height: f32,
) -> Result<Slice, ModelError> {
    let isl = &layer.islands[i];
    let mut settings = Settings::for_road_width(road_width);
    settings.layer_height = layer_height;
    let outer = points(&isl.outer);
    let holes: Vec<(Vec<Point>, hollowpath::Material)> =
        isl.holes.iter().map(|(h, m, _)| (points(h), *m)).collect();
    let refs: Vec<(&[Point], hollowpath::Material)> =
        holes.iter().map(|(p, m)| (&p[..], *m)).collect();
    Slice::from_contours(&outer, isl.wall_material, &refs, settings).map_err(|error| {
        ModelError::Layer {
            layer: layer.index,
            z: layer.z,
            island: i,
            error,
        }
    })
}

/// Plans island `i` of `layer`, whose slice is `slice`.
fn plan_island(
    layer: &ModelLayer,
    i: usize,
    slice: &Slice,
    previews: Previews,
) -> Result<PlannedIsland, ModelError> {
    let fail = |error| ModelError::Plan {
        layer: layer.index,
        island: i,
        error,
    };
    let planner = crate::plan(slice).map_err(fail)?;
    let plan = planner.last_plan();
    // `layers::layer` picks the pattern by the index: odd is the offset spiral.
    let pick = if previews.spiral_only { 1 } else { layer.index };
    // An island about a road wide or narrower (the tip of a cone, a sliver at a model's top)
    // holds no road: it is left out of the part, said in its note, not the part refused.
    let mut built = match layers::layer(slice, plan, Fill::Offset, pick) {
        Err(hollowpath::Error::WallNoRoom) if slice.holes().is_empty() => layers::Layer {
            index: layer.index,
            pattern: hollowpath::toolpath::Pattern::Spiral,
            path: Vec::new(),
            note: "left out: no road fits inside this island (about a road wide or narrower)"
                .into(),
        },
        other => other.map_err(fail)?,
    };
    built.index = layer.index;
    let field = BlendedField::new(slice, plan);
    let field_fn = |p| field.at(p);
    let (lo, hi) = slice.wall().bbox();
    let area = ((hi.x - lo.x + 2.0) * (hi.y - lo.y + 2.0)) as f64;
    let cell = (metrics::CELL_MM as f64).max((area / 2.0e7).sqrt()) as f32;
    let mut meter = Meter::new(slice, Options::with_cell(cell));
    let m = meter.measure(built.pattern, &built.path, &field_fn);
    let deposit_png = if previews.png {
        crate::preview::deposit_png(meter.raster())
    } else {
        Vec::new()
    };
    let start_notes = metrics::explain_starts(slice, &built.path, &built.note);
    let channels: Vec<usize> = layer.islands[i].holes.iter().map(|h| h.2).collect();
    let description = format!(
        "layer {} island {i}, cut at z {:.4} mm; holes are channels {:?}",
        layer.index, layer.z, channels
    );
    Ok(PlannedIsland {
        slice_json: crate::slice_file::to_json(
            &format!("layer-{:04}", layer.index),
            &description,
            slice,
        ),
        printable_mm2: meter.printable_area(),
        path: built.path,
        metrics: m,
        start_notes,
        note: built.note,
        channels,
        deposit_png,
    })
}

/// Plans one layer, island by island.
pub fn plan_layer(
    layer: &ModelLayer,
    road_width: f32,
    layer_height: f32,
    previews: Previews,
) -> Result<PlannedLayer, ModelError> {
    let slices = (0..layer.islands.len())
        .map(|i| island_slice(layer, i, road_width, layer_height).map(Box::new))
        .collect::<Result<Vec<_>, _>>()?;
    let islands = slices
        .iter()
        .enumerate()
        .map(|(i, s)| plan_island(layer, i, s, previews))
        .collect::<Result<Vec<_>, _>>()?;
    let png = if previews.png {
        // 20 px/mm, coarser only where the layer would exceed 16 megapixels.
        let area: f64 = slices
            .iter()
            .map(|s| {
                let (lo, hi) = s.wall().bbox();
                ((hi.x - lo.x + 2.0) * (hi.y - lo.y + 2.0)) as f64
            })
            .sum();
        let px_per_mm = 20.0f32.min((16.0e6 / area.max(1e-9)).sqrt() as f32);
        let pairs: Vec<(&Slice, &[Vertex])> = slices
            .iter()
            .zip(&islands)
            .map(|(s, i)| (&**s, &i.path[..]))
            .collect();
        crate::preview::islands_png(&pairs, px_per_mm)
    } else {
        Vec::new()
    };
    let pattern = islands
        .iter()
        .map(|i| i.metrics.pattern.as_str())
        .find(|p| *p == "zigzag")
        .map_or(Pattern::Spiral, |_| Pattern::Zigzag);
    Ok(PlannedLayer {
        index: layer.index,
        z: layer.z,
        pattern,
        islands,
        png,
    })
}

/// Plans every layer on the current rayon pool (whose threads need
/// [`crate::STACK_BYTES`] of stack); the first failing layer, from the bed up, is the error.
pub fn plan_layers(
    layers: &[ModelLayer],
    road_width: f32,
    layer_height: f32,
    previews: Previews,
    on_layer: &(dyn Fn() + Sync),
) -> Result<Vec<PlannedLayer>, ModelError> {
    let results: Vec<Result<PlannedLayer, ModelError>> = layers
        .par_iter()
        .map(|l| {
            let r = plan_layer(l, road_width, layer_height, previews);
            on_layer();
            r
        })
        .collect();
    results.into_iter().collect()
}

/// The travel from the end of each island's road to the start of the next one's, mm.
pub fn island_travel(layer: &PlannedLayer) -> Vec<f64> {
    layer
        .islands
        .windows(2)
        .map(|w| {
            let (a, b) = (w[0].path.last(), w[1].path.first());
            match (a, b) {
                (Some(a), Some(b)) => a.at.dist(b.at) as f64,
                _ => 0.0,
            }
        })
        .collect()
}

/// A layer's figures over all its islands: starts and lengths added (with the travel between
/// islands), coverage, overfill and spill weighted by each island's printable area,
/// composition errors the worst island's.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LayerTotals {
    /// Extrusion starts, all islands.
    pub starts: u32,
    /// Travel, within and between islands, mm.
    pub travel_mm: f64,
    /// Deposited length, mm.
    pub extruded_mm: f64,
    /// Covered share of the printable area.
    pub coverage: f64,
    /// Area covered twice or more, over the printable area.
    pub overfill: f64,
    /// Area covered in a hole or outside a wall, over the printable area.
    pub spill: f64,
    /// The worst island's mean composition error.
    pub composition_error: f64,
}

/// The totals of `layer`.
pub fn totals(layer: &PlannedLayer) -> LayerTotals {
    let area: f64 = layer
        .islands
        .iter()
        .map(|i| i.printable_mm2)
        .sum::<f64>()
        .max(1e-12);
    let weighted = |f: &dyn Fn(&LayerMetrics) -> f64| {
        layer
            .islands
            .iter()
            .map(|i| f(&i.metrics) * i.printable_mm2)
            .sum::<f64>()
            / area
    };
    LayerTotals {
        starts: layer.islands.iter().map(|i| i.metrics.starts).sum(),
        travel_mm: layer
            .islands
            .iter()
            .map(|i| i.metrics.travel_mm)
            .sum::<f64>()
            + island_travel(layer).iter().sum::<f64>(),
        extruded_mm: layer.islands.iter().map(|i| i.metrics.extruded_mm).sum(),
        coverage: weighted(&|m| m.coverage),
        overfill: weighted(&|m| m.overfill),
        spill: weighted(&|m| m.spill),
        composition_error: layer
            .islands
            .iter()
            .map(|i| i.metrics.composition_error)
            .fold(0.0, f64::max),
    }
}
