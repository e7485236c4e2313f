//! `hollowpath`: plan and preview scaffold slices on the PC with the printer's own core.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use host_sim::{output, render, slice_file};

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

#[derive(Subcommand)]
enum Command {
    /// Plan a slice file: writes DIR/mcls.json and DIR/mcls.svg.
    Plan {
        /// The slice file (JSON, see SLICE_FORMAT.md).
        slice: PathBuf,
        /// Output directory.
        #[arg(long, default_value = "out")]
        out: PathBuf,
    },
    /// Plan the built-in four-hole slice and write its MCL picture.
    Demo {
        /// Output directory.
        #[arg(long, default_value = "out/demo")]
        out: PathBuf,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Plan { slice, out } => slice_file::load(&slice)
            .map_err(|e| format!("{}: {e}", slice.display()))
            .and_then(|f| run(&f, &out)),
        Command::Demo { out } => slice_file::parse(host_sim::DEFAULT_SLICE)
            .map_err(|e| format!("built-in slice: {e}"))
            .and_then(|f| run(&f, &out)),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(file: &slice_file::SliceFile, out: &Path) -> Result<(), String> {
    let planner = host_sim::plan(&file.slice).map_err(|e| format!("planning failed: {e}"))?;
    let plan = planner_plan(&planner);
    std::fs::create_dir_all(out).map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    let json = serde_json::to_string_pretty(&output::mcls_json(plan)).map_err(|e| e.to_string())?;
    let write = |name: &str, text: &str| {
        let p = out.join(name);
        std::fs::write(&p, text).map_err(|e| format!("cannot write {}: {e}", p.display()))
    };
    write("mcls.json", &json)?;
    write("mcls.svg", &render::mcls_svg(&file.slice, plan))?;
    let s = &plan.stats;
    let pairs = plan.mcls.iter().filter(|m| m.second.is_some()).count();
    println!(
        "{}: {} MCLs ({} hole-to-hole through p*, {} to the wall), {} bisectors, {} branch points",
        if file.name.is_empty() {
            "slice"
        } else {
            &file.name
        },
        plan.mcls.len(),
        pairs,
        plan.mcls.len() - pairs,
        plan.bisectors().len(),
        plan.cells.branch_points.len()
    );
    println!(
        "  field {} nodes at {:.3} mm, {} sweeps; {} traced, {} unmatched removed, {} relaxation moves, {} thinned; digest {:016x}",
        s.grid_nodes, s.grid_h, s.sweeps, s.traced, s.removed_unmatched, s.relax_moves, s.thinned, plan.digest()
    );
    println!(
        "  wrote {}/mcls.json and {}/mcls.svg",
        out.display(),
        out.display()
    );
    Ok(())
}

fn planner_plan(p: &hollowpath::Planner) -> &hollowpath::Plan {
    p.last_plan()
}
