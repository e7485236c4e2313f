//! `hollowpath simulate`: each layer's moves run through the core's machine on the virtual
//! printer, and the layer measured twice with one [`Meter`]: as planned, and as rebuilt from
//! the pin trace.

use hollowpath::app::job::Printed;
use hollowpath::geometry::Point;
use hollowpath::link::message::LayerTelemetry;
use hollowpath::motion::machine::Counters;
use hollowpath::motion::PrinterConfig;
use hollowpath::toolpath::moves::Move;
use hollowpath::toolpath::{Pattern, Vertex};
use hollowpath::Material;
use serde_json::{json, Value};

use crate::layers::Layer;
use crate::metrics::{planned_moves, LayerMetrics, Meter};
use crate::virtual_printer::{rebuild, run_layer_counted, Rebuild, SimError, TraceFigures};

/// One simulated layer.
#[derive(Clone, Debug)]
pub struct SimulatedLayer {
    /// The layer index.
    pub index: usize,
    /// Measured from the layer's path, as printed ([`Meter::measure`]).
    pub planned: LayerMetrics,
    /// Measured from the moves rebuilt from the pin trace.
    pub simulated: LayerMetrics,
    /// The trace's figures.
    pub figures: TraceFigures,
    /// What the machine counted (the controller's telemetry of the layer).
    pub counters: Counters,
    /// The planned moves from home (a travel to the first vertex, then the layer's moves).
    pub planned_moves: Vec<Move>,
    /// The rebuilt moves.
    pub rebuilt_moves: Vec<Move>,
}

/// A layer's moves as the machine is fed them: a travel from home to its first vertex, then
/// its moves ([`planned_moves`]).
pub fn machine_moves(cfg: &PrinterConfig, layer: &Layer) -> Vec<Move> {
    let mut moves = from_home(cfg, &layer.path);
    moves.extend(planned_moves(&layer.path));
    moves
}

/// The travel from home to a path's first vertex (none for an empty path), with room for the
/// path's moves after it.
fn from_home(cfg: &PrinterConfig, path: &[Vertex]) -> Vec<Move> {
    let mut moves = Vec::with_capacity(path.len() + 1);
    if let Some(first) = path.first() {
        moves.push(Move {
            from: Point::new(cfg.home[0], cfg.home[1]),
            to: first.at,
            width: first.width,
            material: first.material,
            deposit: false,
        });
    }
    moves
}

/// Runs `layer` on a virtual printer `cfg` (from home, at height `(index + 1) x
/// layer_height`) and measures it as planned and as rebuilt, both on `meter` (the rebuilt
/// one last, so the meter's raster holds the simulated deposition afterwards).
pub fn simulate_layer(
    cfg: &PrinterConfig,
    layer: &Layer,
    meter: &mut Meter,
    road_width: f32,
    field: &dyn Fn(Point) -> Option<Material>,
) -> Result<SimulatedLayer, SimError> {
    let moves = machine_moves(cfg, layer);
    let planned = meter.measure(layer.pattern, &layer.path, field);
    simulate_moves(
        cfg,
        layer.index,
        layer.pattern,
        moves,
        planned,
        meter,
        road_width,
        field,
    )
}

/// Runs `moves` (from home) as layer `index` on a virtual printer `cfg` and measures the print
/// rebuilt from the pin trace on `meter` beside `planned` (what the moves state).
#[allow(clippy::too_many_arguments)]
pub fn simulate_moves(
    cfg: &PrinterConfig,
    index: usize,
    pattern: Pattern,
    moves: Vec<Move>,
    planned: LayerMetrics,
    meter: &mut Meter,
    road_width: f32,
    field: &dyn Fn(Point) -> Option<Material>,
) -> Result<SimulatedLayer, SimError> {
    let z = (index + 1) as f32 * cfg.layer_height;
    let (trace, counters) = run_layer_counted(cfg, &moves, z)?;
    let rebuilt = rebuild(cfg, &trace, &Rebuild::for_road_width(road_width));
    drop(trace);
    let simulated = meter.measure_moves(pattern, &rebuilt.moves, field);
    Ok(SimulatedLayer {
        index,
        planned,
        simulated,
        figures: rebuilt.figures,
        counters,
        planned_moves: moves,
        rebuilt_moves: rebuilt.moves,
    })
}

/// A G-code layer's moves as the machine is fed them: a travel from home to its first vertex,
/// then one move per G-code move at the width and mix the file states
/// ([`gcode::printed_moves`](crate::gcode::printed_moves)).
pub fn gcode_moves(cfg: &PrinterConfig, path: &[Vertex]) -> Vec<Move> {
    let mut moves = from_home(cfg, path);
    moves.extend(crate::gcode::printed_moves(path));
    moves
}

/// The layer's entry of `simulation.json`.
pub fn layer_json(s: &SimulatedLayer, channels: usize) -> Result<Value, serde_json::Error> {
    let f = &s.figures;
    Ok(json!({
        "layer": s.index,
        "planned": serde_json::to_value(&s.planned)?,
        "simulated": serde_json::to_value(&s.simulated)?,
        "steps": {"x": f.net_steps[0], "y": f.net_steps[1], "z": f.net_steps[2]},
        "pulses": {"x": f.pulses[0], "y": f.pulses[1], "z": f.pulses[2]},
        "valve_openings": &f.valve_openings[..channels],
        "valve_open_s": &f.valve_open_s[..channels],
        "volume_mm3": &f.volume_mm3[..channels],
        "any_valve_openings": f.any_openings,
        "max_step_rate_hz": f.max_step_rate_hz,
        "min_pulse_ticks": f.min_pulse_ticks,
        "print_time_s": f.print_time_s,
    }))
}

/// Layer `index`'s telemetry as the controller reports it over the link (`hollowpath print
/// --report`), from what the machine counted over the layer of the whole job
/// ([`run_job_counted`](crate::virtual_printer::run_job_counted)): the two compare key by key.
pub fn telemetry_json(index: usize, printed: &Printed, channels: usize) -> Value {
    let t = LayerTelemetry::from_counters(
        u16::try_from(index).unwrap_or(u16::MAX),
        &printed.counters,
        printed.starved,
    );
    telemetry_value(&t, channels)
}

/// A layer telemetry as JSON (`simulation.json`'s `telemetry.layers`, `print --report`).
pub fn telemetry_value(t: &LayerTelemetry, channels: usize) -> Value {
    json!({
        "layer": t.layer,
        "steps": {"x": t.steps[0], "y": t.steps[1], "z": t.steps[2]},
        "valve_openings": &t.valve_openings[..channels],
        "valve_open_ticks": &t.valve_open_ticks[..channels],
        "print_ticks": t.print_ticks,
        "starved": t.starved,
    })
}
