//! `hollowpath slice`: scaffold models (generated here, written as STL) to printed parts, run
//! through the real binary where the user would.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use host_sim::model::scaffold::{circle, rectangle, Channel, Scaffold, Triangle};
use host_sim::model::{materials::MaterialMap, mesh, stl, ModelError};

fn hollowpath() -> Command {
    Command::new(env!("CARGO_BIN_EXE_hollowpath"))
}

fn run_ok(cmd: &mut Command) -> Output {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Runs the tool expecting it to refuse; returns its stderr (never a panic).
fn run_err(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "expected a refusal");
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    err
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hollowpath-model-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// A round block of radius 4 mm, `height` tall, with `n` straight channels 0.8 mm across on
/// a circle of radius 2 mm.
fn cylinder(n: usize, height: f64) -> Scaffold {
    Scaffold {
        outline: circle([0.0, 0.0], 4.0, 96),
        height,
        channels: (0..n)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / n as f64;
                Channel::straight([2.0 * a.cos(), 2.0 * a.sin()], 0.4, 0.0, height, 32)
            })
            .collect(),
    }
}

/// The slice files `slice` wrote, in layer order.
fn slice_files(out: &Path) -> Vec<host_sim::slice_file::SliceFile> {
    let mut names: Vec<_> = std::fs::read_dir(out.join("slices"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    names.sort();
    names
        .iter()
        .map(|p| host_sim::run_on_large_stack(|| host_sim::slice_file::load(p).unwrap()))
        .collect()
}

fn area(pts: &[hollowpath::geometry::Point]) -> f64 {
    hollowpath::geometry::polygon::double_area(pts).abs() as f64 * 0.5
}

#[test]
fn a_cylinder_with_n_channels_has_n_holes_of_the_right_area_on_every_layer() {
    let dir = tmp("cylinder");
    let model = cylinder(3, 1.2);
    let expected = model.channels[0].section_area();
    // ASCII here; the binary reader is exercised by the other tests.
    let stl = write(
        &dir,
        "cyl.stl",
        stl::to_ascii("cyl", &model.triangles()).as_bytes(),
    );
    let out = dir.join("out");
    run_ok(
        hollowpath()
            .args(["slice", "--layer-height", "0.3", "--no-previews", "--out"])
            .arg(&out)
            .arg(&stl),
    );
    let files = slice_files(&out);
    assert_eq!(files.len(), 4);
    for f in &files {
        let holes = f.slice.holes();
        assert_eq!(holes.len(), 3, "{}", f.name);
        for h in holes {
            let a = area(h.points());
            assert!(
                (a - expected).abs() <= 0.01 * expected,
                "{}: {a} vs {expected}",
                f.name
            );
            assert_eq!(h.material(), [0.0, 1.0, 0.0, 0.0]);
        }
        assert_eq!(f.slice.wall().material(), [1.0, 0.0, 0.0, 0.0]);
        let wall = area(f.slice.wall().points());
        let disc = 0.5 * 96.0 * 16.0 * (std::f64::consts::TAU / 96.0).sin();
        assert!((wall - disc).abs() <= 0.01 * disc);
    }
}

#[test]
fn vertices_exactly_on_the_cut_planes_slice_cleanly() {
    // Layer height 0.25 and rings at 0.125, 0.375, ... (exact in binary): every cut passes
    // through a ring of vertices.
    let rings = (0..=8)
        .map(|k| (k as f64 * 0.125, [0.2 * (k as f64 * 0.7).sin(), 0.0]))
        .collect();
    let model = Scaffold {
        outline: circle([0.0, 0.0], 3.0, 64),
        height: 1.0,
        channels: vec![Channel {
            rings,
            radius: 0.6,
            segments: 40,
        }],
    };
    let raw = stl::parse(&stl::to_binary(&model.triangles())).unwrap();
    let (m, _) = mesh::build(&raw).unwrap();
    let sliced = host_sim::run_on_large_stack(|| {
        host_sim::model::slice_mesh(&m, 0.25, &MaterialMap::two_channel(), &|| {}).unwrap()
    });
    assert_eq!(sliced.layers.len(), 4);
    let expected = model.channels[0].section_area();
    for l in &sliced.layers {
        assert_eq!(l.islands.len(), 1);
        assert_eq!(l.islands[0].holes.len(), 1, "layer {}", l.index);
        let a = host_sim::model::cut::area(&l.islands[0].holes[0].0).abs();
        assert!(
            (a - expected).abs() <= 1e-6,
            "layer {}: {a} vs {expected}",
            l.index
        );
        // One channel throughout.
        assert_eq!(l.islands[0].holes[0].2, 0);
    }
}

/// A 6 x 6 mm block, 3 mm tall, with a straight channel and one that bends 2.5 mm sideways.
fn bending_block() -> Scaffold {
    Scaffold {
        outline: rectangle(6.0, 6.0),
        height: 3.0,
        channels: vec![
            Channel::straight([1.5, 1.5], 0.4, 0.0, 3.0, 32),
            Channel::bending([1.5, 4.5], [4.0, 4.5], 0.4, 0.0, 3.0, 40),
        ],
    }
}

#[test]
fn a_bending_channel_keeps_its_material_on_every_layer() {
    let dir = tmp("bend");
    let model = bending_block();
    let stl = write(&dir, "bend.stl", &stl::to_binary(&model.triangles()));
    // The rule names a point inside the bending channel on the bottom layer only: tracking
    // carries its material up the bend, where the point is far outside the channel.
    let map = write(
        &dir,
        "map.json",
        br#"{"wall": [1, 0, 0, 0],
            "channels": [{"name": "vessel", "at": [1.5, 4.5, 0.1], "material": "C"}],
            "default": "B"}"#,
    );
    let out = dir.join("out");
    let said = run_ok(
        hollowpath()
            .args([
                "slice",
                "--layer-height",
                "0.3",
                "--no-previews",
                "--materials",
            ])
            .arg(&map)
            .arg("--out")
            .arg(&out)
            .arg(&stl),
    );
    let said = String::from_utf8_lossy(&said.stdout);
    assert!(!said.contains("no --materials"), "{said}");
    let files = slice_files(&out);
    assert_eq!(files.len(), 10);
    let c = [0.0, 0.0, 1.0, 0.0];
    let b = [0.0, 1.0, 0.0, 0.0];
    for (k, f) in files.iter().enumerate() {
        let z = (k as f64 + 0.5) * 0.3;
        let centre = model.channels[1]
            .rings
            .iter()
            .min_by(|a, b| (a.0 - z).abs().total_cmp(&(b.0 - z).abs()));
        let centre = centre.unwrap().1;
        assert_eq!(f.slice.holes().len(), 2);
        for h in f.slice.holes() {
            let p = h.points();
            let cx = p.iter().map(|q| q.x as f64).sum::<f64>() / p.len() as f64;
            let bending = (cx - centre[0]).abs() < 0.2 && p[0].y > 3.0;
            let want = if bending { c } else { b };
            assert_eq!(h.material(), want, "layer {k}: hole at x {cx}");
        }
    }
    // Far up the bend the channel has left the rule's point behind.
    let top = &files[9].slice.holes();
    assert!(top
        .iter()
        .all(|h| h.signed_distance(hollowpath::geometry::Point::new(1.5, 4.5)) > 0.5));
}

#[test]
fn the_materials_file_names_an_unknown_key() {
    let dir = tmp("mapkey");
    let stl = write(
        &dir,
        "m.stl",
        &stl::to_binary(&cylinder(1, 0.6).triangles()),
    );
    for (text, want) in [
        (
            r#"{"wall": "A", "colour": "red"}"#,
            "unknown key \"colour\" in the materials file",
        ),
        (
            r#"{"channels": [{"at": [0, 0], "material": "B", "size": 1}]}"#,
            "unknown key \"size\" in channels[0]",
        ),
        (
            r#"{"channels": [{"at": [0, 0], "material": "Q"}]}"#,
            "unknown channel \"Q\"",
        ),
        (r#"{"wall": [0.5, 0.2]}"#, "sum to 0.7"),
        (
            r#"{"channels": []}"#,
            "matches no rule and the file has no \"default\"",
        ),
    ] {
        let map = write(&dir, "map.json", text.as_bytes());
        let out = dir.join("out");
        let err = run_err(
            hollowpath()
                .args(["slice", "--layer-height", "0.3", "--materials"])
                .arg(&map)
                .arg("--out")
                .arg(&out)
                .arg(&stl),
        );
        assert!(err.contains(want), "{text}: {err}");
        assert!(!out.join("metrics.json").exists());
    }
}

#[test]
fn an_open_model_is_refused_naming_the_open_edge() {
    let mut tris: Vec<Triangle> = cylinder(2, 0.9).triangles();
    // Take away one side-wall triangle of the outline: its three edges are left open.
    let removed = tris.remove(0);
    let raw = stl::parse(&stl::to_binary(&tris)).unwrap();
    match mesh::build(&raw) {
        Err(ModelError::OpenEdge { from, to }) => {
            let on = |p: [f64; 3]| {
                removed
                    .iter()
                    .any(|q| (0..3).all(|a| (p[a] - q[a]).abs() < 1e-5))
            };
            assert!(on(from) && on(to), "{from:?} {to:?} vs {removed:?}");
        }
        other => panic!("expected an open edge, got {other:?}"),
    }
    let dir = tmp("open");
    let stl = write(&dir, "open.stl", &stl::to_binary(&tris));
    let out = dir.join("out");
    let err = run_err(
        hollowpath()
            .args(["slice", "--layer-height", "0.3", "--out"])
            .arg(&out)
            .arg(&stl),
    );
    assert!(
        err.contains("the model is not closed: the edge from ("),
        "{err}"
    );
    assert!(err.contains("belongs to one face only"), "{err}");
    // Nothing that looks like a result.
    assert!(!out.join("metrics.json").exists() && !out.join("part.gcode").exists());
}

#[test]
fn an_island_too_small_for_a_road_is_left_out_and_said() {
    // A 0.5 mm cube at 0.4 mm roads: it 'sliced' to nothing laid, without a word.
    let dir = tmp("tiny");
    let cube = Scaffold {
        outline: vec![[0.0, 0.0], [0.5, 0.0], [0.5, 0.5], [0.0, 0.5]],
        height: 0.5,
        channels: Vec::new(),
    };
    let p = write(&dir, "tiny.stl", &stl::to_binary(&cube.triangles()));
    let out = run_ok(
        hollowpath()
            .args(["slice", "--layer-height", "0.3", "--out"])
            .arg(dir.join("out"))
            .arg(&p),
    );
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(said.contains("island(s) left out"), "{said}");
    let metrics = std::fs::read_to_string(dir.join("out").join("metrics.json")).unwrap();
    assert!(
        metrics.contains("no road fits inside this island"),
        "{metrics}"
    );
}

#[test]
fn a_file_that_is_not_stl_or_ends_early_is_refused() {
    let dir = tmp("notstl");
    let good = stl::to_binary(&cylinder(1, 0.6).triangles());
    let ascii = stl::to_ascii("c", &cylinder(1, 0.6).triangles());
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("text.stl", b"hello, this is not a model at all, but it is long enough to have a header of eighty bytes and a count".to_vec(), "not an STL file"),
        ("short.stl", b"abc".to_vec(), "not an STL file"),
        ("empty.stl", Vec::new(), "not an STL file"),
        ("cut.stl", good[..good.len() - 30].to_vec(), "truncated STL file"),
        ("cut-ascii.stl", ascii.as_bytes()[..ascii.len() / 2].to_vec(), "truncated STL file"),
        ("json.stl", br#"{"outer": {"points": []}}"#.to_vec(), "not an STL file"),
    ];
    for (name, bytes, want) in cases {
        let p = write(&dir, name, &bytes);
        let err = run_err(
            hollowpath()
                .args(["slice", "--layer-height", "0.3", "--out"])
                .arg(dir.join("out"))
                .arg(&p),
        );
        assert!(err.contains(want), "{name}: {err}");
        assert!(
            err.contains(name),
            "{name}: the message names the file: {err}"
        );
    }
    // In the library, typed.
    assert!(matches!(
        stl::parse(&good[..100]),
        Err(ModelError::Truncated(_))
    ));
    assert!(matches!(
        stl::parse(b"plain words"),
        Err(ModelError::NotStl(_))
    ));
    // An ASCII model's bad number is named with its line; keywords in upper case are read.
    let bad = ascii.replacen("vertex ", "vertex abc ", 1);
    let line = bad.lines().position(|l| l.contains("abc")).unwrap() + 1;
    match stl::parse(bad.as_bytes()) {
        Err(ModelError::NotStl(m)) => {
            assert_eq!(m, format!("line {line}: `abc` is not a number"))
        }
        other => panic!("{other:?}"),
    }
    let far = ascii.replacen("vertex ", "vertex 1e39 ", 1);
    match stl::parse(far.as_bytes()) {
        Err(ModelError::NotStl(m)) => assert!(
            m.starts_with(&format!("line {line}: coordinate 1e39 is out of range")),
            "{m}"
        ),
        other => panic!("{other:?}"),
    }
    let upper = stl::parse(ascii.to_ascii_uppercase().as_bytes()).unwrap();
    assert_eq!(upper, stl::parse(ascii.as_bytes()).unwrap());
    let missing =
        run_err(hollowpath().args(["slice", "--layer-height", "0.3", "/nonexistent/x.stl"]));
    assert!(
        missing.contains("cannot read /nonexistent/x.stl"),
        "{missing}"
    );
}

#[test]
fn degenerate_and_repeated_faces_and_near_vertices_are_cleaned() {
    let mut tris = cylinder(1, 0.6).triangles();
    let first = tris[0];
    tris.push(first); // repeated
    tris.push([first[0], first[0], first[1]]); // degenerate
                                               // A corner moved by 0.3 µm still welds to its neighbours.
    tris[5][0][0] += 3e-4;
    let raw = stl::parse(&stl::to_binary(&tris)).unwrap();
    let (m, report) = mesh::build(&raw).unwrap();
    assert_eq!(report.duplicates, 1);
    assert_eq!(report.degenerate, 1);
    assert_eq!(m.triangles.len(), tris.len() - 2);
}

/// The bar a layer must meet (README): one start, coverage >= 0.97, overfill <= 0.04, no
/// deposit in a channel.
fn assert_bar(metrics: &serde_json::Value) {
    for l in metrics["layers"].as_array().unwrap() {
        let k = &l["layer"];
        assert_eq!(l["starts"], 1, "layer {k}: {l}");
        assert!(l["coverage"].as_f64().unwrap() >= 0.97, "layer {k}: {l}");
        assert!(l["overfill"].as_f64().unwrap() <= 0.04, "layer {k}: {l}");
        assert!(l["spill"].as_f64().unwrap() < 0.0005, "layer {k}: {l}");
    }
}

/// A 5 x 5 x 5 mm block with solid caps 0.5 mm thick and a channel 1.2 mm across between
/// them: caps (no hole), the layers where the channel opens and closes, and the channel.
fn capped_block() -> Scaffold {
    Scaffold {
        outline: rectangle(5.0, 5.0),
        height: 5.0,
        channels: vec![Channel::straight([2.5, 2.5], 0.6, 0.5, 4.5, 48)],
    }
}

fn plan_capped_block(name: &str, layer_height: &str) -> (serde_json::Value, PathBuf) {
    let dir = tmp(name);
    let stl = write(
        &dir,
        "block.stl",
        &stl::to_binary(&capped_block().triangles()),
    );
    let out = dir.join("out");
    run_ok(
        hollowpath()
            .args([
                "slice",
                "--no-previews",
                "--layer-height",
                layer_height,
                "--out",
            ])
            .arg(&out)
            .arg(&stl),
    );
    (read_json(&out.join("metrics.json")), out)
}

#[test]
fn a_capped_block_plans_every_layer_to_the_bar() {
    let (metrics, out) = plan_capped_block("capped", "0.25");
    let layers = metrics["layers"].as_array().unwrap();
    assert_eq!(layers.len(), 20);
    // Caps: two layers at each end have no hole, and are one road all the same.
    for l in [&layers[0], &layers[1], &layers[18], &layers[19]] {
        assert_eq!(l["islands"][0]["channels"].as_array().unwrap().len(), 0);
        assert!(l["islands"][0]["note"]
            .as_str()
            .unwrap()
            .starts_with("no hollow feature"));
    }
    assert_eq!(layers[2]["islands"][0]["channels"], serde_json::json!([0]));
    assert_bar(&metrics);
    // The G-code rises a layer at a time.
    let g = std::fs::read_to_string(out.join("part.gcode")).unwrap();
    let zs: Vec<f64> = g
        .lines()
        .filter_map(|l| l.strip_prefix("G0 Z"))
        .map(|r| r.split_whitespace().next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(zs.len(), 20);
    for (k, z) in zs.iter().enumerate() {
        assert!((z - (k + 1) as f64 * 0.25).abs() < 1e-9);
    }
}

// The whole 5 mm block at 0.025 mm: 200 layers, about 4 s on 2 shared cores (release
// test profile), quick enough for CI.
#[test]
fn a_5_mm_block_in_200_layers_plans_every_layer_to_the_bar() {
    let (metrics, out) = plan_capped_block("capped200", "0.025");
    assert_eq!(metrics["layers"].as_array().unwrap().len(), 200);
    assert_bar(&metrics);
    assert_eq!(metrics["total"]["starts"], 200);
    assert_eq!(std::fs::read_dir(out.join("slices")).unwrap().count(), 200);
}

/// Two round blocks ([`cylinder`], 0.6 mm tall) with `channels` channels each, the second
/// `dx` mm along x from the first, in one STL file, and the command that slices it at 0.3 mm
/// layers into the returned output folder.
fn two_blocks(name: &str, channels: [usize; 2], dx: f64) -> (Command, PathBuf) {
    let mut tris = cylinder(channels[0], 0.6).triangles();
    let mut other = cylinder(channels[1], 0.6).triangles();
    for t in &mut other {
        for v in t.iter_mut() {
            v[0] += dx;
        }
    }
    tris.extend(other);
    let dir = tmp(name);
    let stl = write(&dir, "two.stl", &stl::to_binary(&tris));
    let out = dir.join("out");
    let mut cmd = hollowpath();
    cmd.args(["slice", "--layer-height", "0.3", "--out"])
        .arg(&out)
        .arg(&stl);
    (cmd, out)
}

#[test]
fn separate_islands_print_one_road_each_with_one_travel_between() {
    let (mut cmd, out) = two_blocks("islands", [1, 2], 10.0);
    run_ok(&mut cmd);
    let m = read_json(&out.join("metrics.json"));
    for l in m["layers"].as_array().unwrap() {
        let islands = l["islands"].as_array().unwrap();
        assert_eq!(islands.len(), 2);
        assert_eq!(l["starts"], 2);
        assert_eq!(islands[0]["starts"], 1);
        assert_eq!(islands[1]["starts"], 1);
        let reached = &islands[1]["reached_by"];
        assert!(reached["travel_mm"].as_f64().unwrap() > 1.0);
        assert!(reached["why"].as_str().unwrap().contains("separate piece"));
    }
    assert!(out.join("slices/layer-0000.json").exists());
    assert!(out.join("slices/layer-0000-1.json").exists());
    assert!(out.join("previews/layer-0001-1-deposit.png").exists());
    assert!(!out.join("previews/layer-0001-1.png").exists());
    let g = std::fs::read_to_string(out.join("part.gcode")).unwrap();
    assert_eq!(g.matches("; island 1").count(), 2);
}

#[test]
fn overlapping_solids_are_refused_naming_the_layer_and_the_place() {
    // Two round blocks 8 mm across, their centres 5 mm apart: each is closed, but together
    // they would print the lens where they overlap twice.
    let (mut cmd, out) = two_blocks("overlap", [1, 1], 5.0);
    let err = run_err(&mut cmd);
    assert!(err.contains("layer 0 (z 0.1500 mm)"), "{err}");
    assert!(err.contains("surfaces cross at (2.5"), "{err}");
    assert!(err.contains("boolean union"), "{err}");
    assert!(!out.join("part.gcode").exists());
    // Side by side, touching at one point of each cut, they are two islands (above).
    let contours = vec![
        vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
        vec![[1.0, 1.0], [2.0, 1.0], [2.0, 2.0], [1.0, 2.0]],
        vec![[1.0, 0.2], [2.0, 0.2], [2.0, 0.8], [1.0, 0.8]],
    ];
    assert_eq!(host_sim::model::nest::crossing(&contours), None);
    // Side by side along a face that each solid cut into a slightly different segment: the
    // edges cross at a hair's angle, by rounding, not an overlap.
    let touching = vec![
        contours[0].clone(),
        vec![
            [1.0 + 1e-13, 0.0],
            [2.0, 0.0],
            [2.0, 1.0],
            [1.0 - 1e-13, 1.0],
        ],
    ];
    assert_eq!(host_sim::model::nest::crossing(&touching), None);
    let crossed = vec![
        contours[0].clone(),
        vec![[0.5, 0.5], [1.5, 0.5], [1.5, 1.5], [0.5, 1.5]],
    ];
    assert_eq!(host_sim::model::nest::crossing(&crossed), Some([1.0, 0.5]));
}

#[test]
fn parallel_planning_writes_the_same_bytes_as_sequential() {
    let dir = tmp("jobs");
    let stl = write(
        &dir,
        "bend.stl",
        &stl::to_binary(&bending_block().triangles()),
    );
    let run = |jobs: &str| {
        let out = dir.join(format!("out-{jobs}"));
        run_ok(
            hollowpath()
                .args(["slice", "--layer-height", "0.3", "--jobs", jobs, "--out"])
                .arg(&out)
                .arg(&stl),
        );
        out
    };
    let (a, b) = (run("1"), run("2"));
    let mut files = Vec::new();
    let mut stack = vec![PathBuf::new()];
    while let Some(rel) = stack.pop() {
        for e in std::fs::read_dir(a.join(&rel)).unwrap() {
            let e = e.unwrap();
            let r = rel.join(e.file_name());
            if e.file_type().unwrap().is_dir() {
                stack.push(r);
            } else {
                files.push(r);
            }
        }
    }
    assert!(files.len() > 30);
    for f in files {
        assert!(
            std::fs::read(a.join(&f)).unwrap() == std::fs::read(b.join(&f)).unwrap(),
            "{} differs",
            f.display()
        );
    }
}

#[test]
fn slice_demo_runs_with_no_files() {
    let dir = tmp("demo");
    let out = dir.join("part");
    let said = run_ok(
        hollowpath()
            .current_dir(&dir)
            .args(["slice", "--demo", "--out"])
            .arg(&out),
    );
    let said = String::from_utf8_lossy(&said.stdout);
    assert!(
        said.contains("the wall is channel A and every hollow feature channel B"),
        "{said}"
    );
    assert!(said.contains("channel 2"), "{said}");
    for f in [
        "model.stl",
        "part.gcode",
        "metrics.json",
        "slices/layer-0009.json",
        "previews/layer-0009.png",
    ] {
        assert!(out.join(f).exists(), "{f}");
    }
    let html = std::fs::read_to_string(out.join("part.html")).unwrap();
    assert!(html.starts_with("<!DOCTYPE html>") && !html.contains("<script src"));
    let png = std::fs::read(out.join("part.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    // No temporaries left behind.
    let left: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .contains(".tmp-")
        })
        .collect();
    assert!(left.is_empty());
    // The slice files are what `plan` reads.
    run_ok(
        hollowpath()
            .args(["plan", "--layers", "1", "--out"])
            .arg(dir.join("again"))
            .arg(out.join("slices/layer-0005.json")),
    );
    // A cap layer (no hole) plans too.
    run_ok(
        hollowpath()
            .args(["plan", "--layers", "2", "--out"])
            .arg(dir.join("cap"))
            .arg(out.join("slices/layer-0000.json")),
    );
}

#[test]
fn an_edge_of_more_than_two_faces_is_refused_naming_it() {
    // Two cubes sharing one edge: that edge belongs to four faces.
    let cube = |o: [f64; 3]| {
        Scaffold {
            outline: rectangle(1.0, 1.0),
            height: 1.0,
            channels: Vec::new(),
        }
        .triangles()
        .into_iter()
        .map(move |t| t.map(|v| [v[0] + o[0], v[1] + o[1], v[2] + o[2]]))
    };
    let tris: Vec<Triangle> = cube([0.0; 3]).chain(cube([1.0, 1.0, 0.0])).collect();
    let raw = stl::parse(&stl::to_binary(&tris)).unwrap();
    match mesh::build(&raw) {
        Err(ModelError::NonManifoldEdge { from, to, faces }) => {
            assert_eq!(faces, 4);
            for p in [from, to] {
                assert!(
                    (p[0] - 1.0).abs() < 1e-6 && (p[1] - 1.0).abs() < 1e-6,
                    "{p:?}"
                );
            }
        }
        other => panic!("expected a non-manifold edge, got {other:?}"),
    }
}

#[test]
fn the_part_gcode_read_back_prints_what_metrics_json_measured() {
    let dir = tmp("gcode");
    let stl = write(
        &dir,
        "bend.stl",
        &stl::to_binary(&bending_block().triangles()),
    );
    let out = dir.join("out");
    run_ok(
        hollowpath()
            .args(["slice", "--layer-height", "0.3", "--no-previews", "--out"])
            .arg(&out)
            .arg(&stl),
    );
    let metrics = read_json(&out.join("metrics.json"));
    let text = std::fs::read_to_string(out.join("part.gcode")).unwrap();
    let back = host_sim::gcode::parse(&text).unwrap();
    let files = slice_files(&out);
    assert_eq!(back.len(), files.len());
    host_sim::run_on_large_stack(|| {
        for (k, (f, (_, parsed))) in files.iter().zip(&back).enumerate() {
            let mut meter = host_sim::metrics::Meter::new(&f.slice, Default::default());
            let pattern = hollowpath::toolpath::Pattern::Spiral;
            let printed =
                meter.measure_moves(pattern, &host_sim::gcode::printed_moves(parsed), &|_| None);
            let planned = &metrics["layers"][k];
            let what = format!("layer {k}: {planned} vs {printed:?}");
            assert_eq!(planned["starts"], printed.starts, "{what}");
            for key in ["coverage", "overfill", "spill"] {
                let p = planned[key].as_f64().unwrap();
                let q = match key {
                    "coverage" => printed.coverage,
                    "overfill" => printed.overfill,
                    _ => printed.spill,
                };
                assert!((p - q).abs() < 3e-3, "{key}: {what}");
            }
        }
    });
}
