//! `hollowpath`: plan, preview and measure scaffold slices on the PC with the printer's own core.

/// Prints a line of the run's report to standard output, as `println!` does, but a report
/// nobody reads any more (`hollowpath plan ... | head -1`: the pipe's reader has exited) does
/// not stop the run: the files it writes are its result, and `println!` would panic there.
/// Any other failure to write the report (a full disk under a redirected stdout) is said on
/// standard error, and the run goes on.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = writeln!(std::io::stdout(), $($arg)*) {
            if e.kind() != std::io::ErrorKind::BrokenPipe {
                eprintln!("warning: the report could not be written to standard output: {e}");
            }
        }
    }};
}

mod cmd;

use cmd::args::{Cli, Command, LayersArg, PatternArg};
use cmd::plan::run;
use cmd::simulate::{read_gcode, run_simulation, Source};

use std::path::Path;
use std::process::ExitCode;

use clap::Parser;
use host_sim::layers::Fill;
use host_sim::model::run::SliceArgs;
use host_sim::{printer_file, slice_file};

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
                    say!(
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
                say!("\non the default printer (virtual pins, the print rebuilt from the pin trace):");
                let cfg = hollowpath::motion::PrinterConfig::default();
                run_simulation(&f, &cfg, &out.join("sim"), Some(2), Source::Plan, None)
            })
            .and_then(|()| {
                say!("\nthe built-in scaffold model, sliced:");
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
        say!("{line}");
    }
    Ok(())
}
