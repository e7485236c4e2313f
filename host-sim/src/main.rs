//! `hollowpath`: plan, preview and measure scaffold slices on the PC with the printer's own core.

use hollowpath::toolpath::moves::Move;
use hollowpath::toolpath::Pattern;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};
use hollowpath::toolpath::composition::BlendedField;
use hollowpath::toolpath::spiral::ControlFunction;
use host_sim::layers::{self, Fill};
use host_sim::metrics::{LayerMetrics, Meter, Options};
use host_sim::model::run::SliceArgs;
use host_sim::staged::Staged;
use host_sim::{gcode, output, preview, printer_file, render, simulate, slice_file};

#[derive(Parser)]
#[command(
    name = "hollowpath",
    version,
    about = "Continuous multi-material toolpaths for scaffolds with hollow features"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// Fill patterns on the command line.
#[derive(Clone, Copy, ValueEnum)]
enum PatternArg {
    /// Zigzag and spiral layers along the MCLs, alternating.
    Mcl,
    /// The Cartesian raster baseline, as ordinary slicers fill.
    Raster,
}

/// How `slice` lays a part's layers.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum LayersArg {
    /// Zigzag on even layers, offset spiral on odd ones (as `plan --layers`).
    Alternate,
    /// The offset spiral on every layer.
    Spiral,
}

/// Spiral control functions on the command line.
#[derive(Clone, Copy, ValueEnum)]
enum SpiralArg {
    /// u = v, the paper's.
    Linear,
    /// Turns a road width apart along every MCL.
    RoadWidth,
    /// Turns packed closer at the feature and at the cell boundary.
    Ease,
    /// Turns at fixed distances from the features, a road width apart everywhere, joined into
    /// one closed road (the default).
    Offset,
}

impl From<SpiralArg> for Fill {
    fn from(s: SpiralArg) -> Self {
        match s {
            SpiralArg::Linear => Fill::Mcl(ControlFunction::Linear),
            SpiralArg::RoadWidth => Fill::Mcl(ControlFunction::RoadWidth),
            SpiralArg::Ease => Fill::Mcl(ControlFunction::Ease),
            SpiralArg::Offset => Fill::Offset,
        }
    }
}

#[derive(Subcommand)]
enum Command {
    /// Plan a slice file: DIR/mcls.json and mcls.svg, then per layer layer-K.svg,
    /// layer-K.png, layer-K-deposit.png (the deposition: bare ground red, deposited twice
    /// blue) and layer-K.json (the path's vertices), DIR/metrics.json and, with --gcode,
    /// G-code.
    Plan {
        /// The slice file (JSON, see SLICE_FORMAT.md), or a drawing (.svg: outlines nested into
        /// a wall and holes, material from data-material or the fill colour).
        slice: PathBuf,
        /// Output directory.
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Number of layers (zigzag, spiral, zigzag, ...).
        #[arg(long, default_value_t = 2, value_parser = layer_count)]
        layers: usize,
        /// What fills the layers.
        #[arg(long, value_enum, default_value = "mcl")]
        pattern: PatternArg,
        /// The spiral control function u = f(v).
        #[arg(long, value_enum, default_value = "offset")]
        spiral: SpiralArg,
        /// Also write Marlin G-code here.
        #[arg(long)]
        gcode: Option<PathBuf>,
    },
    /// Plan a slice, then run each layer through the printer's motion code on a virtual
    /// printer (virtual pins, virtual clock): DIR/simulation.json (per layer the metrics as
    /// planned and as rebuilt from the pin trace alone, steps, valve openings and open time,
    /// the fastest step rate, the print time) and DIR/layer-K-simulated.png (the rebuilt
    /// deposition: bare red, twice blue, spilt black).
    Simulate {
        /// The slice file (JSON, see SLICE_FORMAT.md).
        slice: PathBuf,
        /// The printer file (JSON; omitted keys take the default pneumatic printer's values).
        #[arg(long)]
        printer: Option<PathBuf>,
        /// Number of layers (zigzag, offset spiral, zigzag, ...; default 2, or with --gcode
        /// every layer of the file).
        #[arg(long, value_parser = layer_count)]
        layers: Option<usize>,
        /// Run this G-code file (ours, or a stock slicer's: G0/G1 with E, G90/G91, M82/M83,
        /// G92, M165 mixes) through the printer's motion code instead of planning the slice;
        /// the slice is what its deposit is measured against, in the file's coordinates.
        #[arg(long)]
        gcode: Option<PathBuf>,
        /// Output directory.
        #[arg(long, default_value = "out/sim")]
        out: PathBuf,
    },
    /// Print a slice on the controller over the link (a serial port, or TCP to QEMU's
    /// `-serial tcp:...`): progress as it comes, the telemetry in --report.
    Print {
        /// The slice file (JSON, see SLICE_FORMAT.md).
        slice: PathBuf,
        /// The serial port (e.g. /dev/ttyUSB0, or the pty QEMU's `-serial pty` opened).
        #[arg(long, conflicts_with = "tcp", required_unless_present = "tcp")]
        port: Option<String>,
        /// HOST:PORT of a TCP serial line (QEMU's `-serial tcp:HOST:PORT,server=on`).
        #[arg(long)]
        tcp: Option<String>,
        /// The printer file (JSON; omitted keys take the default printer's values).
        #[arg(long)]
        printer: Option<PathBuf>,
        /// Number of layers (zigzag, offset spiral, zigzag, ...).
        #[arg(long, default_value_t = 2, value_parser = layer_count)]
        layers: usize,
        /// Write the telemetry here (JSON: digest, layers, retransmitted, upload_bytes,
        /// upload_messages, last_stop).
        #[arg(long)]
        report: Option<PathBuf>,
        /// Send the file's contours without validating the slice on the host: the
        /// controller's own verdict (a bad slice comes back with the error `plan` gives).
        #[arg(long)]
        no_check: bool,
        /// Milliseconds of silence after which the host sends a keep-alive (1 to 1000; the
        /// controller stops a job after its watchdog, 3 s on the SKR 2, without a frame).
        /// Under QEMU, whose clock outruns the wall clock, use 2.
        #[arg(long, default_value_t = host_sim::print::KEEPALIVE_MS,
              value_parser = clap::value_parser!(u64).range(1..=1000))]
        keepalive_ms: u64,
    },
    /// Plan the built-in four-hole slice: MCLs, a zigzag and a spiral layer with previews,
    /// G-code, and a metrics table against the raster baseline; then slice the built-in
    /// scaffold model (a 6 x 6 x 3 mm block with three channels, one bending) into DIR/part
    /// as `hollowpath slice --demo` does.
    Demo {
        /// Output directory.
        #[arg(long, default_value = "out/demo")]
        out: PathBuf,
    },
    /// Slice a model (STL, binary or ASCII) into layers, plan every layer (zigzag and offset
    /// spiral alternating; the offset spiral alone where a layer has no hole) and write
    /// DIR/slices/layer-NNNN.json (slice files `plan` reads), DIR/previews/layer-NNNN.png
    /// and -deposit.png, DIR/metrics.json (per layer and island, and totals) and one G-code
    /// file for the whole part.
    Slice {
        /// The model file (STL); omit with --demo.
        #[arg(required_unless_present = "demo")]
        model: Option<PathBuf>,
        /// Slice the built-in scaffold instead of a file (also written as DIR/model.stl).
        #[arg(long, conflicts_with = "model")]
        demo: bool,
        /// The built-in scaffold's height, mm (with --demo).
        #[arg(long, default_value_t = 3.0, requires = "demo", value_parser = positive_mm)]
        demo_height: f64,
        /// Layer height, mm (the model is cut at the middle of every layer).
        #[arg(long, value_parser = positive_mm, required_unless_present = "demo", default_value_if("demo", "true", "0.3"))]
        layer_height: Option<f64>,
        /// Road width, mm.
        #[arg(long, default_value_t = 0.4, value_parser = positive_mm)]
        road_width: f64,
        /// Materials file (JSON): the wall's material and rules giving each channel its own;
        /// without it the wall is channel A and every hollow feature channel B.
        #[arg(long)]
        materials: Option<PathBuf>,
        /// Output directory (default out/MODEL-NAME).
        #[arg(long)]
        out: Option<PathBuf>,
        /// The G-code file (default DIR/part.gcode).
        #[arg(long)]
        gcode: Option<PathBuf>,
        /// Planning threads (0: one per core); the output is the same for any number.
        #[arg(long, default_value_t = 0)]
        jobs: usize,
        /// Skip the per-layer PNG previews.
        #[arg(long)]
        no_previews: bool,
        /// How the layers are laid: zigzag and offset spiral alternating, or the offset
        /// spiral on every layer.
        #[arg(long, value_enum, default_value = "alternate")]
        layers: LayersArg,
    },
}

/// A length in mm: a positive finite number.
fn positive_mm(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
        _ => Err(format!(
            "expected a length in mm greater than 0, not \"{s}\""
        )),
    }
}

/// `--layers`: 1 to [`layers::MAX_LAYERS`], checked before anything is read or built.
fn layer_count(s: &str) -> Result<usize, String> {
    let n: usize = s
        .parse()
        .map_err(|_| format!("the number of layers must be a whole number, not \"{s}\""))?;
    if n == 0 {
        return Err("at least 1 layer is needed".into());
    }
    if n > layers::MAX_LAYERS {
        return Err(format!(
            "at most {} layers can be planned in one run",
            layers::MAX_LAYERS
        ));
    }
    Ok(n)
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // The core's `large` capacities put megabytes on the stack (a slice, the layers' working
    // sets): plan on a thread with room for them.
    host_sim::run_on_large_stack(move || execute(cli))
}

fn execute(cli: Cli) -> ExitCode {
    let result = match cli.command {
        Command::Plan {
            slice,
            out,
            layers,
            pattern,
            spiral,
            gcode,
        } => load_slice(&slice).and_then(|f| {
            let fill = match pattern {
                PatternArg::Mcl => spiral.into(),
                PatternArg::Raster => Fill::Raster,
            };
            run(
                &f,
                &out,
                layers,
                fill,
                gcode.as_deref(),
                false,
                Some(&slice),
            )
        }),
        Command::Simulate {
            slice,
            printer,
            layers,
            gcode,
            out,
        } => load_slice(&slice).and_then(|f| {
            let cfg = match &printer {
                Some(p) => printer_file::load(p).map_err(|e| format!("{}: {e}", p.display()))?,
                None => hollowpath::motion::PrinterConfig::default(),
            };
            cfg.check_slice(&f.slice)
                .map_err(|e| format!("printer and slice: {e}"))?;
            let source = match &gcode {
                Some(g) => Source::Gcode(read_gcode(g)?),
                None => Source::Plan,
            };
            run_simulation(&f, &cfg, &out, layers, source, Some(&slice))
        }),
        Command::Print {
            slice,
            port,
            tcp,
            printer,
            layers,
            report,
            no_check,
            keepalive_ms,
        } => {
            let loaded = if no_check {
                slice_file::load_contours(&slice).map(|c| (None, Some(c)))
            } else {
                slice_file::load(&slice).map(|f| (Some(f), None))
            };
            loaded
                .map_err(|e| format!("{}: {e}", slice.display()))
                .and_then(|(file, contours)| {
                    let cfg = match &printer {
                        Some(p) => printer_file::load(p)
                            .map_err(|e| format!("{}: {e}", p.display()))?,
                        None => hollowpath::motion::PrinterConfig::default(),
                    };
                    let job = match (&file, &contours) {
                        (Some(f), _) => {
                            cfg.check_slice(&f.slice)
                                .map_err(|e| format!("printer and slice: {e}"))?;
                            host_sim::print::Job::Slice(&f.slice)
                        }
                        (None, Some(c)) => host_sim::print::Job::Unchecked(c),
                        (None, None) => return Err("no slice".into()),
                    };
                    let stream = match (&port, &tcp) {
                        (_, Some(addr)) => host_sim::print::open_tcp(addr)?,
                        (Some(p), None) => host_sim::print::open_serial(p)?,
                        (None, None) => return Err("--port or --tcp is needed".into()),
                    };
                    let interrupted =
                        std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
                    let flag = interrupted.clone();
                    if let Err(e) = ctrlc::set_handler(move || {
                        flag.store(true, std::sync::atomic::Ordering::Relaxed)
                    }) {
                        eprintln!("note: Ctrl-C cannot abort the job ({e})");
                    }
                    let layers =
                        u16::try_from(layers).map_err(|_| "too many layers".to_string())?;
                    let link = hollowpath::link::endpoint::LinkConfig {
                        keepalive_us: keepalive_ms * 1_000,
                        ..host_sim::print::HOST_LINK
                    };
                    let r = host_sim::print::print(stream, job, &cfg, layers, link, interrupted)
                        .map_err(|e| e.to_string())?;
                    println!(
                        "printed {} layers, plan {:016x}, {} frames retransmitted, upload {} bytes in {} messages",
                        r.layers.len(),
                        r.digest,
                        r.retransmitted,
                        r.upload_bytes,
                        r.upload_messages
                    );
                    if let Some(path) = &report {
                        let text = serde_json::to_string_pretty(&r.json(cfg.channels().len()))
                            .map_err(|e| e.to_string())?;
                        std::fs::write(path, text)
                            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
                    }
                    Ok(())
                })
        }
        Command::Demo { out } => slice_file::parse(host_sim::DEFAULT_SLICE)
            .map_err(|e| format!("built-in slice: {e}"))
            .and_then(|f| {
                let g = out.join("demo.gcode");
                run(&f, &out, 2, Fill::Offset, Some(&g), true, None)?;
                // The same two layers on the default printer's virtual pins.
                println!("\non the default printer (virtual pins, the print rebuilt from the pin trace):");
                let cfg = hollowpath::motion::PrinterConfig::default();
                run_simulation(&f, &cfg, &out.join("sim"), Some(2), Source::Plan, None)
            })
            .and_then(|()| {
                println!("\nthe built-in scaffold model, sliced:");
                slice(&SliceArgs {
                    model: None,
                    demo_height: 3.0,
                    layer_height: 0.3,
                    road_width: 0.4,
                    materials: None,
                    out: out.join("part"),
                    gcode: None,
                    jobs: 0,
                    previews: true,
                    spiral_only: false,
                })
            }),
        Command::Slice {
            model,
            demo,
            demo_height,
            layer_height,
            road_width,
            materials,
            out,
            gcode,
            jobs,
            no_previews,
            layers,
        } => slice(&SliceArgs {
            spiral_only: layers == LayersArg::Spiral,
            out: out.unwrap_or_else(|| host_sim::model::run::default_out(model.as_deref())),
            model: if demo { None } else { model },
            demo_height,
            layer_height: layer_height.unwrap_or(0.3),
            road_width,
            materials,
            gcode,
            jobs,
            previews: !no_previews,
        }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// A slice file, or a drawing (`.svg`, through usvg).
fn load_slice(path: &Path) -> Result<slice_file::SliceFile, String> {
    let svg = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("svg"));
    if svg {
        host_sim::svg_file::load(path).map_err(|e| format!("{}: {e}", path.display()))
    } else {
        slice_file::load(path).map_err(|e| format!("{}: {e}", path.display()))
    }
}

fn slice(args: &SliceArgs) -> Result<(), String> {
    for line in host_sim::model::run::run(args)? {
        println!("{line}");
    }
    Ok(())
}

fn run(
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
        staged.check(g)?;
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
    println!(
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

    println!(
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
        println!(
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
    println!(
        "wrote {}/mcls.json, mcls.svg, layer-K.svg/png, layer-K-deposit.png, metrics.json{}",
        out.display(),
        gcode_path
            .map(|g| format!(", {}", g.display()))
            .unwrap_or_default()
    );
    Ok(())
}

/// What `simulate` runs: the slice's own plan, or a G-code file's layers.
enum Source {
    Plan,
    Gcode(Vec<gcode::ParsedLayer>),
}

/// Largest G-code file `simulate --gcode` reads.
const MAX_GCODE_BYTES: u64 = 256 << 20;

fn read_gcode(path: &Path) -> Result<Vec<gcode::ParsedLayer>, String> {
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

fn run_simulation(
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
    // Each layer to run: its index, pattern, the moves from home, and what they state.
    type Job = (usize, Pattern, Vec<Move>, Option<layers::Layer>);
    let mut jobs: Vec<Job> = Vec::new();
    // The layers the controller would plan and print (none for a G-code file).
    let mut job_layers = None;
    match source {
        Source::Plan => {
            job_layers = Some(count.unwrap_or(2));
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
        println!(
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
        println!(
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
    if let Some(count) = job_layers {
        let layers16 = u16::try_from(count).map_err(|_| "too many layers".to_string())?;
        // (The controller would refuse what fails here: say so in those terms.)
        const RECEIVED: &str = "the slice as the controller receives it, every coordinate rounded \
             to a whole micrometre (the layers above are the unrounded slice's)";
        let uploaded = host_sim::link_client::as_uploaded(slice, layers16).map_err(|e| {
            format!("{RECEIVED}: {e}; the controller would refuse it: move vertices that lie within a micrometre or two of another edge apart")
        })?;
        let up_planner = host_sim::plan(&uploaded).map_err(|e| {
            format!("{RECEIVED}: {e}; the controller could not plan it (to simulate the unrounded layers alone, export them with `plan --gcode` and simulate that file with `--gcode`)")
        })?;
        let up_plan = up_planner.last_plan();
        let counted = host_sim::virtual_printer::run_job_counted(cfg, &uploaded, up_plan, count)
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
    println!(
        "wrote {}/simulation.json, layer-K-simulated.png (the rebuilt print by composition), layer-K-simulated-deposit.png",
        out.display()
    );
    Ok(())
}

/// Creates the output folder `out` (and its parents); a file of that name is named as such.
fn create_out(out: &Path) -> Result<(), String> {
    if out.is_file() {
        return Err(format!(
            "--out {} is a file: give a folder for the results",
            out.display()
        ));
    }
    std::fs::create_dir_all(out).map_err(|e| format!("cannot create {}: {e}", out.display()))
}
