//! `hollowpath simulate`: a slice's plan, or a G-code file, run through the printer's motion
//! code on the virtual printer.

use hollowpath::toolpath::moves::Move;
use hollowpath::toolpath::Pattern;
use std::path::Path;

use super::create_out;
use hollowpath::toolpath::composition::BlendedField;
use host_sim::layers::{self, Fill};
use host_sim::metrics::{Meter, Options};
use host_sim::staged::Staged;
use host_sim::{gcode, preview, simulate, slice_file};

/// What `simulate` runs: the slice's own plan, or a G-code file's layers.
pub(crate) enum Source {
    Plan,
    Gcode(Vec<gcode::ParsedLayer>),
}

/// Largest G-code file `simulate --gcode` reads.
pub(crate) const MAX_GCODE_BYTES: u64 = 256 << 20;

pub(crate) fn read_gcode(path: &Path) -> Result<Vec<gcode::ParsedLayer>, String> {
    use host_sim::json_file::{read_text, ReadError};
    let text = read_text(path, MAX_GCODE_BYTES).map_err(|e| match e {
        ReadError::Io(e) => format!("{}: {e}", path.display()),
        ReadError::TooLarge(n) => format!("{}: larger than {n} bytes", path.display()),
        ReadError::NotUtf8(at) => {
            format!(
                "{}: not a text file (byte {at} is not UTF-8)",
                path.display()
            )
        }
    })?;
    let parsed = gcode::parse(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    let layers: Vec<_> = parsed
        .into_iter()
        .filter(|(_, path)| path.iter().any(|v| v.deposit))
        .collect();
    if layers.is_empty() {
        return Err(format!(
            "{}: no layer deposits anything (no G1 move with E)",
            path.display()
        ));
    }
    Ok(layers)
}

pub(crate) fn run_simulation(
    file: &slice_file::SliceFile,
    cfg: &hollowpath::motion::PrinterConfig,
    out: &Path,
    count: Option<usize>,
    source: Source,
    input: Option<&Path>,
) -> Result<(), String> {
    let mut staged = Staged::new(input);
    staged.own(out, |name| {
        host_sim::staged::layer_file(name, &["-simulated.png", "-simulated-deposit.png"])
    });
    let slice = &file.slice;
    let planner = host_sim::plan(slice).map_err(|e| format!("planning failed: {e}"))?;
    let plan = planner.last_plan();
    hollowpath::verify::verify(slice, plan)
        .map_err(|v| format!("the plan failed its own check ({v:?}); please report this slice"))?;
    // The slice as the controller receives it, and its plan, made before any layer runs: a
    // slice the controller would refuse is refused before the simulation's work (its layers
    // ran and its folder was made first). A G-code file is not a job the controller plans.
    let controller = match source {
        Source::Plan => {
            let layers16 =
                u16::try_from(count.unwrap_or(2)).map_err(|_| "too many layers".to_string())?;
            // (The controller would refuse what fails here: say so in those terms.)
            const RECEIVED: &str = "the slice as the controller receives it, every coordinate \
                 rounded to a whole micrometre";
            let uploaded = host_sim::link_client::as_uploaded(slice, layers16).map_err(|e| {
                format!("{RECEIVED}: {e}; the controller would refuse it: move vertices that lie within a micrometre or two of another edge apart")
            })?;
            let up_planner = host_sim::plan(&uploaded).map_err(|e| {
                format!("{RECEIVED}: {e}; the controller could not plan it (to simulate the unrounded layers alone, export them with `plan --gcode` and simulate that file with `--gcode`)")
            })?;
            Some((count.unwrap_or(2), uploaded, up_planner))
        }
        Source::Gcode(_) => None,
    };
    // Each layer to run: its index, pattern, the moves from home, and what they state.
    type Job = (usize, Pattern, Vec<Move>, Option<layers::Layer>);
    let mut jobs: Vec<Job> = Vec::new();
    match source {
        Source::Plan => {
            let built = layers::layers(slice, plan, Fill::Offset, count.unwrap_or(2))
                .map_err(|e| format!("layers failed: {e}"))?;
            for l in built {
                let moves = simulate::machine_moves(cfg, &l);
                jobs.push((l.index, l.pattern, moves, Some(l)));
            }
        }
        Source::Gcode(parsed) => {
            let n = count.unwrap_or(layers::MAX_LAYERS).min(parsed.len());
            for (k, (name, path)) in parsed.into_iter().take(n).enumerate() {
                let pattern = match name.as_deref() {
                    Some("zigzag") => Pattern::Zigzag,
                    Some("spiral") => Pattern::Spiral,
                    _ => Pattern::Raster,
                };
                jobs.push((k, pattern, simulate::gcode_moves(cfg, &path), None));
            }
        }
    }
    create_out(out)?;
    let field = BlendedField::new(slice, plan);
    let field_fn = |p| field.at(p);
    let (lo, hi) = slice.wall().bbox();
    let area = ((hi.x - lo.x + 2.0) * (hi.y - lo.y + 2.0)) as f64;
    // As `plan`'s pictures: 20 px/mm, fewer for a large slice.
    let px_per_mm = 20.0f32.min((16.0e6 / area).sqrt() as f32);
    let cell = (host_sim::metrics::CELL_MM as f64).max((area / 2.0e7).sqrt()) as f32;
    let mut meter = Meter::new(slice, Options::with_cell(cell));
    let channels = cfg.channels().len();
    let road = slice.settings().road_width;
    let mut docs = Vec::new();
    let mut telemetry = Vec::new();
    for (index, pattern, moves, layer) in jobs {
        // What the moves state: the planned layer as printed, or the G-code's moves.
        let planned = match &layer {
            Some(l) => meter.measure(l.pattern, &l.path, &field_fn),
            None => meter.measure_moves(pattern, &moves[1..], &field_fn),
        };
        let s = simulate::simulate_moves(
            cfg, index, pattern, moves, planned, &mut meter, road, &field_fn,
        )
        .map_err(|e| format!("layer {index}: {e}"))?;
        let l = &s;
        let pattern_name = pattern.name();
        staged.write(
            &out.join(format!("layer-{}-simulated-deposit.png", l.index)),
            &preview::deposit_png(meter.raster()),
        )?;
        staged.write(
            &out.join(format!("layer-{}-simulated.png", l.index)),
            &preview::layer_png(slice, &preview::moves_path(&l.rebuilt_moves), px_per_mm),
        )?;
        let f = &s.figures;
        say!(
            "layer {} ({}): {:.1} s; steps x {} y {} z {} ({} / {} / {} pulses), fastest {:.0} Hz, shortest pulse {} ticks; valve openings {:?} (all shut -> any open {}), open {:.1?} s",
            l.index,
            pattern_name,
            f.print_time_s,
            f.net_steps[0],
            f.net_steps[1],
            f.net_steps[2],
            f.pulses[0],
            f.pulses[1],
            f.pulses[2],
            f.max_step_rate_hz,
            f.min_pulse_ticks,
            &f.valve_openings[..channels],
            f.any_openings,
            &f.valve_open_s[..channels],
        );
        say!(
            "    planned   starts {:>4} coverage {:.4} overfill {:.4} spill {:.4}\n    simulated starts {:>4} coverage {:.4} overfill {:.4} spill {:.4}",
            s.planned.starts,
            s.planned.coverage,
            s.planned.overfill,
            s.planned.spill,
            s.simulated.starts,
            s.simulated.coverage,
            s.simulated.overfill,
            s.simulated.spill,
        );
        docs.push(simulate::layer_json(&s, channels).map_err(|e| e.to_string())?);
    }
    // The controller's telemetry: the slice as the controller receives it (whole
    // micrometres), its whole job on one virtual printer through the core's job routine, as
    // the controller prints it. A G-code file is not a job the controller plans: none.
    let mut digest = None;
    if let Some((count, uploaded, up_planner)) = &controller {
        let count = *count;
        let up_plan = up_planner.last_plan();
        let counted = host_sim::virtual_printer::run_job_counted(cfg, uploaded, up_plan, count)
            .map_err(|e| {
                format!("the controller's job over {count} layer(s), on the virtual printer: {e}")
            })?;
        for (k, c) in counted.iter().enumerate() {
            telemetry.push(simulate::telemetry_json(k, c, channels));
        }
        digest = Some(format!("{:016x}", up_plan.digest()));
    }
    let name = if file.name.is_empty() {
        "slice"
    } else {
        &file.name
    };
    let doc = serde_json::json!({
        "slice": name,
        "layers": docs,
        "telemetry": {"digest": digest, "layers": telemetry},
    });
    staged.write(
        &out.join("simulation.json"),
        serde_json::to_string_pretty(&doc)
            .map_err(|e| e.to_string())?
            .as_bytes(),
    )?;
    staged.commit()?;
    say!(
        "wrote {}/simulation.json, layer-K-simulated.png (the rebuilt print by composition), layer-K-simulated-deposit.png",
        out.display()
    );
    Ok(())
}
