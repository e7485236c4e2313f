//! The command-line tool, as a user runs it.

use std::process::Command;

fn hollowpath() -> Command {
    Command::new(env!("CARGO_BIN_EXE_hollowpath"))
}

/// Runs the tool and insists it succeeded (showing its stderr if not).
fn run_ok(cmd: &mut Command) -> std::process::Output {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Runs the tool and insists it failed; its stderr.
fn run_err(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    assert!(!out.status.success(), "it succeeded");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Runs `plan SLICE --out OUT --gcode GCODE` expecting it to refuse; returns its stderr.
fn plan_gcode_err(
    slice: &str,
    out: &std::path::Path,
    gcode: impl AsRef<std::ffi::OsStr>,
) -> String {
    run_err(
        hollowpath()
            .args(["plan", slice, "--out"])
            .arg(out)
            .arg("--gcode")
            .arg(gcode),
    )
}

fn read_json(path: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("hollowpath-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn plan_writes_mcls_json_and_svg() {
    let out = tmp("plan");
    let slice = concat!(env!("CARGO_MANIFEST_DIR"), "/data/two_holes.json");
    run_ok(hollowpath().args(["plan", slice, "--out"]).arg(&out));
    let doc = read_json(&out.join("mcls.json"));
    let mcls = doc["mcls"].as_array().unwrap();
    assert!(mcls.len() > 100);
    let mut to_wall = 0;
    let mut to_hole = 0;
    for m in mcls {
        assert!(m["from"].as_u64().unwrap() < 2);
        match &m["to"] {
            serde_json::Value::String(s) => {
                assert_eq!(s, "wall");
                to_wall += 1
            }
            serde_json::Value::Number(n) => {
                assert!(n.as_u64().unwrap() < 2);
                to_hole += 1
            }
            other => panic!("bad to: {other}"),
        }
        let pts = m["points"].as_array().unwrap();
        assert!(pts.len() >= 2 && pts.iter().all(|p| p.as_array().unwrap().len() == 2));
    }
    assert!(to_wall > 0 && to_hole > 0);
    assert_eq!(doc["bisectors"].as_array().unwrap().len(), 1);
    assert_eq!(doc["branch_points"].as_array().unwrap().len(), 2);
    let svg = std::fs::read_to_string(out.join("mcls.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    assert_eq!(svg.matches("linearGradient id=").count(), mcls.len());
    // The same slice through the library gives the same digest.
    let f = host_sim::slice_file::load(std::path::Path::new(slice)).unwrap();
    let planner = host_sim::plan(&f.slice).unwrap();
    assert_eq!(
        doc["digest"],
        format!("{:016x}", planner.last_plan().digest())
    );
}

#[test]
fn plan_with_layers_writes_previews_metrics_and_gcode() {
    let out = tmp("layers");
    let slice = concat!(env!("CARGO_MANIFEST_DIR"), "/data/vessel_ring.json");
    let g = out.join("print.gcode");
    run_ok(
        hollowpath()
            .args([
                "plan", slice, "--layers", "3", "--spiral", "linear", "--out",
            ])
            .arg(&out)
            .arg("--gcode")
            .arg(&g),
    );
    for k in 0..3 {
        assert!(out.join(format!("layer-{k}.svg")).is_file());
        for name in [format!("layer-{k}.png"), format!("layer-{k}-deposit.png")] {
            let png = std::fs::read(out.join(name)).unwrap();
            assert_eq!(&png[1..4], b"PNG");
        }
    }
    let doc = read_json(&out.join("metrics.json"));
    let layers = doc["layers"].as_array().unwrap();
    let patterns: Vec<&str> = layers
        .iter()
        .map(|l| l["pattern"].as_str().unwrap())
        .collect();
    assert_eq!(patterns, ["zigzag", "spiral", "zigzag"]);
    for l in layers {
        for key in [
            "starts",
            "travel_mm",
            "extruded_mm",
            "coverage",
            "overfill",
            "spill",
            "composition_error",
        ] {
            assert!(l[key].is_number(), "{key} missing in {l}");
        }
        assert_eq!(l["starts"], 1);
        assert_eq!(l["start_notes"].as_array().map(Vec::len), Some(0), "{l}");
        assert!(
            l["note"].as_str().unwrap().contains("0 jump")
                || l["note"].as_str().unwrap().contains("1 piece")
        );
    }
    let text = std::fs::read_to_string(&g).unwrap();
    assert!(text.contains("; filament_diameter = 1.75") && text.contains("; road_width = 0.4"));
    assert_eq!(host_sim::gcode::parse(&text).unwrap().len(), 3);
    // The raster baseline through the same command.
    let out2 = tmp("raster");
    run_ok(
        hollowpath()
            .args(["plan", slice, "--pattern", "raster", "--out"])
            .arg(&out2),
    );
    let doc = read_json(&out2.join("metrics.json"));
    assert!(doc["layers"]
        .as_array()
        .unwrap()
        .iter()
        .all(|l| l["pattern"] == "raster"));
}

#[test]
fn demo_runs_on_the_built_in_slice() {
    let out = tmp("demo");
    let st = run_ok(hollowpath().args(["demo", "--out"]).arg(&out));
    assert!(String::from_utf8_lossy(&st.stdout).contains("four_holes"));
    assert!(out.join("mcls.svg").is_file() && out.join("mcls.json").is_file());
    let stdout = String::from_utf8_lossy(&st.stdout);
    for pattern in ["zigzag", "spiral", "raster"] {
        assert!(
            stdout.lines().any(|l| l.starts_with(pattern)),
            "no {pattern} row in\n{stdout}"
        );
    }
    assert!(out.join("demo.gcode").is_file() && out.join("layer-1.png").is_file());
    let doc = read_json(&out.join("metrics.json"));
    assert_eq!(doc["baseline"]["pattern"], "raster");
    // The same layers simulated on the default printer, figures shown.
    assert!(stdout.contains("simulated starts"), "{stdout}");
    let sim = read_json(&out.join("sim").join("simulation.json"));
    assert_eq!(sim["layers"].as_array().unwrap().len(), 2);
    assert!(out.join("sim").join("layer-1-simulated.png").is_file());
}

/// Plans the slice file `text` (written in `dir`) into `dir/o`, insisting it is refused;
/// returns the message.
fn plan_refused(dir: &std::path::Path, text: &str) -> String {
    let input = dir.join("slice.json");
    std::fs::write(&input, text).unwrap();
    let st = hollowpath()
        .args(["plan"])
        .arg(&input)
        .arg("--out")
        .arg(dir.join("o"))
        .output()
        .unwrap();
    assert!(!st.status.success());
    String::from_utf8_lossy(&st.stderr).into_owned()
}

#[test]
fn an_invalid_slice_exits_non_zero_with_one_line() {
    let dir = tmp("invalid");
    std::fs::create_dir_all(&dir).unwrap();
    let err = plan_refused(
        &dir,
        r#"{"outer": {"points": [[0,0],[10,0],[10,10],[0,10]], "material": [1,0,0,0]},
            "holes": [{"points": [[2,2],[3,2],[3,3]], "material": [0,1,0,0]},
                      {"points": [[2.5,2.1],[5,2],[5,5]], "material": [0,1,0,0]}]}"#,
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("holes 0 and 1 overlap"), "{err}");
    assert!(
        !dir.join("o").exists(),
        "output written for an invalid slice"
    );
    let st = hollowpath()
        .args(["plan", "/nonexistent/slice.json"])
        .output()
        .unwrap();
    assert!(!st.status.success());
    assert!(String::from_utf8_lossy(&st.stderr).contains("cannot read"));
}

#[test]
fn a_slice_too_small_for_one_road_is_refused_not_laid_empty() {
    // A 0.5 mm square at 0.4 mm roads, no hole: it planned 'successfully' with nothing laid.
    let dir = tmp("tiny");
    std::fs::create_dir_all(&dir).unwrap();
    let err = plan_refused(
        &dir,
        r#"{"outer": {"points": [[0,0],[0.5,0],[0.5,0.5],[0,0.5]], "material": [1,0,0,0]},
            "holes": []}"#,
    );
    assert!(
        err.contains("no road fits inside it") && err.contains("road_width"),
        "{err}"
    );
    assert!(!dir.join("o").join("metrics.json").exists());
}

#[test]
fn a_run_into_an_earlier_runs_folder_leaves_only_its_own_layers() {
    let out = tmp("rerun");
    let slice = concat!(env!("CARGO_MANIFEST_DIR"), "/data/vessel_ring.json");
    run_ok(
        hollowpath()
            .args(["plan", slice, "--layers", "3", "--out"])
            .arg(&out),
    );
    assert!(out.join("layer-2.json").exists());
    // The user's own file of another name stays.
    std::fs::write(out.join("layer-notes.txt"), "mine").unwrap();
    run_ok(
        hollowpath()
            .args(["plan", slice, "--layers", "1", "--out"])
            .arg(&out),
    );
    for k in 1..3 {
        for tail in [".json", ".svg", ".png", "-deposit.png"] {
            let name = format!("layer-{k}{tail}");
            assert!(
                !out.join(&name).exists(),
                "{name} left from the earlier run"
            );
        }
    }
    assert!(out.join("layer-0.json").exists() && out.join("layer-notes.txt").exists());
    let metrics = read_json(&out.join("metrics.json"));
    assert_eq!(metrics["layers"].as_array().map(|l| l.len()), Some(1));
}

#[test]
fn layer_counts_out_of_range_are_refused_before_any_work() {
    let out = tmp("layer-count");
    let slice = concat!(env!("CARGO_MANIFEST_DIR"), "/data/two_holes.json");
    for (n, says) in [
        ("0", "at least 1 layer".to_string()),
        (
            "1000000",
            format!("at most {} layers", host_sim::layers::MAX_LAYERS),
        ),
    ] {
        let st = hollowpath()
            .args(["plan", slice, "--layers", n, "--out"])
            .arg(&out)
            .output()
            .unwrap();
        assert!(!st.status.success(), "--layers {n} accepted");
        let err = String::from_utf8_lossy(&st.stderr);
        assert!(err.contains("--layers") && err.contains(&says), "{err}");
        assert!(!out.exists(), "--layers {n} wrote output");
    }
}

#[test]
fn a_failed_write_leaves_no_results() {
    let out = tmp("failed-write");
    let slice = concat!(env!("CARGO_MANIFEST_DIR"), "/data/two_holes.json");
    let err = plan_gcode_err(slice, &out, out.join("missing-folder/print.gcode"));
    assert!(
        err.contains("cannot write") && err.contains("print.gcode"),
        "{err}"
    );
    for name in ["metrics.json", "mcls.json", "mcls.svg", "layer-0.png"] {
        assert!(!out.join(name).exists(), "{name} left after a failed run");
    }
    // Nor any temporary.
    if out.exists() {
        let left: Vec<_> = std::fs::read_dir(&out).unwrap().collect();
        assert!(left.is_empty(), "{left:?}");
    }
}

#[test]
fn output_naming_the_input_is_refused() {
    let dir = tmp("input-clash");
    std::fs::create_dir_all(&dir).unwrap();
    let input = dir.join("slice.json");
    let text = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/data/two_holes.json")).unwrap();
    std::fs::write(&input, &text).unwrap();
    // The same file by another spelling of its path.
    let other = dir.join(".").join("slice.json");
    let err = run_err(
        hollowpath()
            .arg("plan")
            .arg(&input)
            .arg("--out")
            .arg(dir.join("o"))
            .arg("--gcode")
            .arg(&other),
    );
    assert!(err.contains("it is the input file"), "{err}");
    assert_eq!(std::fs::read(&input).unwrap(), text);
    assert!(!dir.join("o").join("metrics.json").exists());
    // --out naming a file (the input, here) is a folder wanted, said so.
    let err = run_err(
        hollowpath()
            .arg("plan")
            .arg(&input)
            .arg("--out")
            .arg(&input),
    );
    assert!(err.contains("is a file: give a folder"), "{err}");
    assert_eq!(std::fs::read(&input).unwrap(), text);
}

/// `slice --jobs` is bounded: a thread for each of 30 000 jobs took minutes and memory for a
/// ten-layer model (one per core is the default).
#[test]
fn slice_refuses_more_planning_threads_than_it_allows() {
    let err = run_err(hollowpath().args(["slice", "model.stl", "--jobs", "30000"]));
    assert!(err.contains("--jobs") && err.contains("0..=256"), "{err}");
}

/// An output that is not an ordinary file is refused before anything is written: the rename
/// into place replaced a link (its target untouched), a device (`/dev/null` made a 2 MB
/// file) or failed on a folder after the other results were in place; `--gcode` naming one
/// of the run's own files left that file holding G-code; `print --port` naming a slice
/// appended the link's frames to it.
#[cfg(unix)]
#[test]
fn outputs_that_are_not_ordinary_files_or_collide_are_refused_before_writing() {
    let dir = tmp("not-ordinary");
    std::fs::create_dir_all(&dir).unwrap();
    let slice = concat!(env!("CARGO_MANIFEST_DIR"), "/data/two_holes.json");
    let target = dir.join("kept.gcode");
    std::fs::write(&target, "keep").unwrap();
    let link = dir.join("link.gcode");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let folder = dir.join("a-folder");
    std::fs::create_dir_all(&folder).unwrap();
    for (gcode, says) in [(&link, "it is a link"), (&folder, "it is a folder")] {
        let out = dir.join("o");
        let err = plan_gcode_err(slice, &out, gcode);
        assert!(err.contains(says), "{err}");
        assert!(!out.exists(), "{says}: the output folder was made");
    }
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(std::fs::read_to_string(&target).unwrap(), "keep");
    // One of the run's own files.
    let out = dir.join("same");
    let err = plan_gcode_err(slice, &out, out.join("metrics.json"));
    assert!(err.contains("twice"), "{err}");
    assert!(!out.join("metrics.json").exists() && !out.join("mcls.json").exists());
    // A port that is an ordinary file.
    let victim = dir.join("victim.json");
    std::fs::copy(slice, &victim).unwrap();
    let before = std::fs::read(&victim).unwrap();
    let err = run_err(
        hollowpath()
            .arg("print")
            .arg(&victim)
            .arg("--port")
            .arg(&victim),
    );
    assert!(err.contains("not a serial port"), "{err}");
    assert_eq!(std::fs::read(&victim).unwrap(), before);
    // Neither line given: both ways of giving one are named (it asked for --port alone).
    let err = run_err(hollowpath().arg("print").arg(&victim));
    assert!(err.contains("--port") && err.contains("--tcp"), "{err}");
}

/// A layer that leaves much of the slice bare says so: a zigzag on a C-shaped wall whose one
/// channel sits in the back of the C covered 0.39 of it with exit 0 and nothing said (no
/// material changing line enters the arms). The reference slices' layers warn of nothing.
#[test]
fn a_layer_that_leaves_much_of_the_slice_bare_is_warned_of() {
    let dir = tmp("bare-warning");
    std::fs::create_dir_all(&dir).unwrap();
    let ring: Vec<String> = (0..16)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / 16.0;
            format!("[{:.5}, {:.5}]", -8.0 + a.cos(), a.sin())
        })
        .collect();
    let slice = dir.join("c-wall.json");
    std::fs::write(
        &slice,
        format!(
            r#"{{"outer": {{"points": [[-10,-10],[10,-10],[10,-6],[-6,-6],[-6,6],[10,6],[10,10],[-10,10]], "material": [1,0,0,0]}},
                "holes": [{{"points": [{}], "material": [0,1,0,0]}}], "settings": {{"road_width": 0.4}}}}"#,
            ring.join(",")
        ),
    )
    .unwrap();
    let out = dir.join("o");
    let o = run_ok(
        hollowpath()
            .arg("plan")
            .arg(&slice)
            .args(["--layers", "2", "--out"])
            .arg(&out),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("warning: layer 0 (zigzag): coverage") && err.contains("left bare"),
        "{err}"
    );
    let m = read_json(&out.join("metrics.json"));
    assert_eq!(m["layers"][0]["warnings"].as_array().unwrap().len(), 1);
    // The spiral covers it.
    assert!(m["layers"][1]["warnings"].as_array().unwrap().is_empty());
    let reference = concat!(env!("CARGO_MANIFEST_DIR"), "/data/two_holes.json");
    let o = run_ok(
        hollowpath()
            .args(["plan", reference, "--layers", "2", "--out"])
            .arg(dir.join("ref")),
    );
    assert!(!String::from_utf8_lossy(&o.stderr).contains("warning"));
}

/// A report nobody reads (`hollowpath plan ... | head -1`: the reader exits, the pipe closes)
/// does not stop the run: it writes its files and exits 0. Before, the report's first line
/// into the closed pipe panicked ("failed printing to stdout: Broken pipe") and nothing was
/// written.
#[test]
fn plan_into_a_closed_pipe_still_writes_its_files() {
    use std::process::Stdio;
    let out = tmp("closed-pipe");
    let slice = concat!(env!("CARGO_MANIFEST_DIR"), "/data/two_holes.json");
    let mut child = hollowpath()
        .args(["plan", slice, "--layers", "1", "--out"])
        .arg(&out)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Close the reading end at once, as `head` does once it has its lines.
    drop(child.stdout.take());
    let result = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(result.status.success(), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(out.join("mcls.json").is_file());
    assert!(out.join("metrics.json").is_file());
    assert!(out.join("layer-0.json").is_file());
}
