//! The command line: subcommands, their options and the checks clap runs on their values.

use std::path::PathBuf;

use clap::{Parser, Subcommand, ValueEnum};
use hollowpath::toolpath::spiral::ControlFunction;
use host_sim::layers::{self, Fill};

#[derive(Parser)]
#[command(
    name = "hollowpath",
    version,
    about = "Continuous multi-material toolpaths for scaffolds with hollow features"
)]
pub(crate) struct Cli {
    #[command(subcommand)]
    pub(crate) command: Command,
}

/// Fill patterns on the command line.
#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum PatternArg {
    /// Zigzag and spiral layers along the MCLs, alternating.
    Mcl,
    /// The Cartesian raster baseline, as ordinary slicers fill.
    Raster,
}

/// How `slice` lays a part's layers.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum LayersArg {
    /// Zigzag on even layers, offset spiral on odd ones (as `plan --layers`).
    Alternate,
    /// The offset spiral on every layer.
    Spiral,
}

/// Spiral control functions on the command line.
#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum SpiralArg {
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
pub(crate) enum Command {
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
    #[command(group(clap::ArgGroup::new("line").required(true).args(["port", "tcp"])))]
    Print {
        /// The slice file (JSON, see SLICE_FORMAT.md).
        slice: PathBuf,
        /// The serial port (e.g. /dev/ttyUSB0, or the pty QEMU's `-serial pty` opened).
        #[arg(long)]
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
        /// Planning threads (0: one per core; at most 256); the output is the same for any
        /// number.
        #[arg(long, default_value_t = 0,
              value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(0..=256))]
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
pub(crate) fn positive_mm(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
        _ => Err(format!(
            "expected a length in mm greater than 0, not \"{s}\""
        )),
    }
}

/// `--layers`: 1 to [`layers::MAX_LAYERS`], checked before anything is read or built.
pub(crate) fn layer_count(s: &str) -> Result<usize, String> {
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
