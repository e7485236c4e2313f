//! Slice files: every malformed or invalid file gets its own clear error, never a panic.

use host_sim::slice_file::{parse, SliceFileError};
use host_sim::REFERENCE_SLICES;

fn err(text: &str) -> String {
    match parse(text) {
        Ok(_) => panic!("accepted: {text}"),
        Err(e) => e.to_string(),
    }
}

const SQUARE: &str = "[[-10,-10],[10,-10],[10,10],[-10,10]]";
const SMALL: &str = "[[-1,-1],[1,-1],[1,1],[-1,1]]";

fn slice(outer: &str, holes: &[&str], settings: &str) -> String {
    let holes: Vec<String> = holes
        .iter()
        .map(|h| format!(r#"{{"points": {h}, "material": [0, 1, 0, 0]}}"#))
        .collect();
    format!(
        r#"{{"name": "t", "units": "mm", "outer": {{"points": {outer}, "material": [1, 0, 0, 0]}}, "holes": [{}], "settings": {{{settings}}}}}"#,
        holes.join(",")
    )
}

#[test]
fn a_valid_minimal_file_parses() {
    let f = parse(&slice(SQUARE, &[SMALL], r#""road_width": 0.4"#)).unwrap();
    assert_eq!(f.name, "t");
    assert_eq!(f.slice.holes().len(), 1);
}

#[test]
fn road_width_limits_are_read_and_checked() {
    let f = parse(&slice(
        SQUARE,
        &[SMALL],
        r#""road_width": 0.4, "min_width": 0.3, "max_width": 0.8"#,
    ))
    .unwrap();
    let s = f.slice.settings();
    assert_eq!((s.min_width, s.max_width), (0.3, 0.8));
    // Defaults scale with the road width.
    let f = parse(&slice(SQUARE, &[SMALL], r#""road_width": 0.5"#)).unwrap();
    let s = f.slice.settings();
    assert!((s.min_width - 0.25).abs() < 1e-6 && (s.max_width - 0.8).abs() < 1e-6);
    // The narrowest road is no wider than a road, the widest no narrower.
    let e = err(&slice(SQUARE, &[SMALL], r#""min_width": 0.6"#));
    assert!(e.contains("min_width"), "{e}");
    let e = err(&slice(SQUARE, &[SMALL], r#""max_width": 0.2"#));
    assert!(e.contains("max_width"), "{e}");
}

#[test]
fn reference_slices_parse() {
    for (name, text) in REFERENCE_SLICES {
        parse(text).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

#[test]
fn malformed_and_truncated_json() {
    let full = slice(SQUARE, &[SMALL], "");
    let e = err(&full[..full.len() / 2]);
    assert!(e.contains("truncated"), "{e}");
    let e = err(r#"{"outer": {"points": [[0,0] [1,1]]}}"#);
    assert!(e.contains("malformed JSON"), "{e}");
    assert!(!e.contains("NaN"), "{e}");
    // A writer's NaN or infinity where a number belongs is named (it said only "expected
    // value at line 1 column 31"), wherever it stands on the line, multi-byte text before it.
    for bad in ["NaN", "-Infinity", "Infinity", "nan"] {
        let e = err(&format!(
            "{{\"name\": \"µ-vessel\", \"outer\": {{\"points\": [[0,0],\n [1, {bad}], [1,1]]}}}}"
        ));
        assert!(e.contains("malformed JSON") && e.contains("line 2"), "{e}");
        assert!(
            e.contains("NaN and infinities are not JSON numbers"),
            "{bad}: {e}"
        );
    }
    let e = err(r#"{"holes": []}"#);
    assert_eq!(e, "missing key \"outer\" at the top level");
    let e = err(r#"{"outer": {"points": "square", "material": {}}, "holes": []}"#);
    assert_eq!(
        e,
        "the wall: material must be a list of fractions, found an object"
    );
    let e = err(&slice("[[0,0,1],[1,0],[0,1]]", &[SMALL], ""));
    assert_eq!(e, "the wall: point 0 has 3 coordinates, expected [x, y]");
}

#[test]
fn format_errors() {
    let e = err(&slice(SQUARE, &[SMALL], r#""road_widht": 0.4"#));
    assert!(
        e.starts_with("unknown key \"road_widht\" in settings; expected one of road_width,"),
        "{e}"
    );
    let e = err(&slice(SQUARE, &[SMALL], "").replace("\"mm\"", "\"inch\""));
    assert!(e.contains("units \"inch\""), "{e}");
    let e = err(&slice(SQUARE, &[SMALL], "").replace("[0, 1, 0, 0]", "[0, 1, 0, 0, 0]"));
    assert_eq!(
        e,
        "hole 0: material has 5 fractions, the printer has 4 channels"
    );
}

#[test]
fn invalid_slices_name_the_feature_and_reason() {
    let cases: &[(String, &str)] = &[
        (
            slice(SQUARE, &["[[0,0],[1,1]]"], ""),
            "hole 0: only 2 distinct points",
        ),
        (
            slice(SQUARE, &[SMALL, "[[3,3],[4,3],[4,4],[3,3.0000001e39]]"], ""),
            "hole 1: vertex 3 has a coordinate out of range (coordinates must lie from -1000 to 1000 mm)",
        ),
        (
            slice(SQUARE, &["[[0,0],[1,1],[2,2]]"], ""),
            "hole 0: the polygon encloses no area",
        ),
        (
            // Tiny, not flat: 0.5 square micrometres.
            slice(SQUARE, &["[[5,5],[5.001,5],[5,5.001]]"], ""),
            "hole 0: the polygon encloses no area (less than a square micrometre)",
        ),
        (
            slice(SQUARE, &["[[0,0],[4,4],[4,0],[0,2]]"], ""),
            "hole 0: edges 0 and 2 intersect",
        ),
        (
            slice(SQUARE, &["[[5,5],[12,5],[5,8]]"], ""),
            "hole 0: vertex 1 is not strictly inside the wall",
        ),
        // Numbered as the file gives them: a clockwise hole (stored the other way round) and
        // repeated points (stored once) said vertex 3, vertex 2 and edges 0 and 2.
        (
            slice(SQUARE, &["[[12,0],[0,-2],[2,0],[0,2]]"], ""),
            "hole 0: vertex 0 is not strictly inside the wall",
        ),
        (
            slice(SQUARE, &["[[0,0],[0,0],[0,0],[2,0],[12,1],[0,2]]"], ""),
            "hole 0: vertex 4 is not strictly inside the wall",
        ),
        (
            slice(
                SQUARE,
                &["[[0,0],[0,0],[0,0],[3,3],[3,0],[0,3],[-3,3],[-3,0]]"],
                "",
            ),
            "hole 0: edges 2 and 4 intersect",
        ),
        (
            slice(SQUARE, &[SMALL, "[[0,0],[3,0],[3,3]]"], ""),
            "holes 0 and 1 overlap or touch",
        ),
        (
            slice(SQUARE, &["[[-5,-5],[5,-5],[5,5],[-5,5]]", SMALL], ""),
            "hole 1 lies inside hole 0",
        ),
        (
            slice(SQUARE, &[SMALL], r#""road_width": 0"#),
            "setting road_width: 0 is out of range",
        ),
        (
            slice(SQUARE, &[SMALL], r#""road_width": -0.4"#),
            "setting road_width: -0.4 is out of range",
        ),
        (
            slice(SQUARE, &[SMALL], r#""layer_height": 0"#),
            "setting layer_height",
        ),
        // A layer the G-code's `Z` cannot tell from the next (every layer at `Z0.0000`).
        (
            slice(SQUARE, &[SMALL], r#""layer_height": 1e-9"#),
            "setting layer_height: 0.000000001 is out of range",
        ),
        (
            slice(SQUARE, &[SMALL], "").replace("[0, 1, 0, 0]", "[0, 1.5, -0.5, 0]"),
            "hole 0: material fraction of channel 2 is negative",
        ),
        (
            slice(SQUARE, &[SMALL], "").replace("[0, 1, 0, 0]", "[0, 0.5, 0.2, 0]"),
            "hole 0: material fractions sum to 0.7",
        ),
        (
            slice("[[-10,-10],[10,-10],[10,1e6],[-10,10]]", &[SMALL], ""),
            "the wall: vertex 2 has a coordinate out of range",
        ),
    ];
    for (text, expected) in cases {
        let e = err(text);
        assert!(e.starts_with("invalid slice: "), "{e}");
        assert!(e.contains(expected), "expected `{expected}` in `{e}`");
    }
}

#[test]
fn capacity_limits_are_errors() {
    // host-sim compiles the core with its `large` capacities: 4096 vertices, 64 holes. A
    // jagged contour keeps every vertex through simplification.
    let many: Vec<String> = (0..4100)
        .map(|k| {
            let a = k as f64 / 4100.0 * std::f64::consts::TAU;
            let r = if k % 2 == 0 { 9.0 } else { 8.5 };
            format!("[{},{}]", r * a.cos(), r * a.sin())
        })
        .collect();
    let e = err(&slice(&format!("[{}]", many.join(",")), &[SMALL], ""));
    assert_eq!(
        e,
        "invalid slice: the wall has more than 4096 vertices after simplification (4100 given): raise simplify_tolerance or split the feature"
    );
    let holes: Vec<String> = (0..65)
        .map(|k| {
            let (x, y) = (-8.0 + 2.0 * (k % 9) as f64, -8.0 + 2.0 * (k / 9) as f64);
            format!("[[{x},{y}],[{},{y}],[{x},{}]]", x + 0.5, y + 0.5)
        })
        .collect();
    let refs: Vec<&str> = holes.iter().map(|s| s.as_str()).collect();
    let e = err(&slice(SQUARE, &refs, ""));
    assert_eq!(
        e,
        "invalid slice: the slice has 65 hollow features; at most 64: split the slice"
    );
    // A valid slice too fine for the planner's buffers is refused, not truncated.
    let f = parse(&slice(
        "[[-60,-60],[60,-60],[60,60],[-60,60]]",
        &[SMALL],
        r#""road_width": 0.1"#,
    ))
    .unwrap();
    let mut planner = Box::new(hollowpath::Planner::new());
    match planner.plan(&f.slice) {
        Err(hollowpath::Error::Capacity { .. } | hollowpath::Error::SliceTooLarge { .. }) => {}
        other => panic!(
            "expected a capacity error, got {:?}",
            other.map(|p| p.mcls.len())
        ),
    }
    assert!(
        planner.last_plan().mcls.is_empty(),
        "a failed run left a partial plan"
    );
}

#[test]
fn errors_are_typed() {
    match parse(&slice(SQUARE, &[SMALL, SMALL], "")) {
        Err(SliceFileError::Slice(hollowpath::Error::HolesOverlap { a: 0, b: 1 })) => {}
        other => panic!("{other:?}"),
    }
}

#[test]
fn unknown_keys_anywhere_are_named_with_where_and_what_is_expected() {
    let good = slice(SQUARE, &[SMALL], "");
    let e = err(&good.replace("\"settings\"", "\"setings\""));
    assert_eq!(
        e,
        "unknown key \"setings\" at the top level; expected one of name, description, units, outer, holes, settings"
    );
    let e = err(&good.replace("\"holes\"", "\"hole\""));
    assert!(
        e.starts_with("unknown key \"hole\" at the top level"),
        "{e}"
    );
    let e = err(&good.replace(
        r#""material": [0, 1, 0, 0]"#,
        r#""material": [0, 1, 0, 0], "colour": 3"#,
    ));
    assert_eq!(
        e,
        "unknown key \"colour\" in hole 0; expected one of points, material"
    );
    let e = err(&good.replace(r#""material": [1, 0, 0, 0]"#, r#""materail": [1, 0, 0, 0]"#));
    assert!(e.starts_with("unknown key \"materail\" in the wall"), "{e}");
    // The documented free-text keys are accepted.
    let f = parse(&good.replace("\"name\"", "\"description\": \"d\", \"name\"")).unwrap();
    assert_eq!(f.name, "t");
}

#[test]
fn a_byte_order_mark_is_ignored() {
    let text = format!("\u{feff}{}", slice(SQUARE, &[SMALL], ""));
    assert_eq!(parse(&text).unwrap().slice.holes().len(), 1);
}

#[test]
fn a_huge_coordinate_is_out_of_range_not_infinite() {
    let e = err(&slice(SQUARE, &[SMALL, "[[3,3],[4,3],[1e308,4]]"], ""));
    assert_eq!(
        e,
        "invalid slice: hole 1: vertex 2 has a coordinate out of range (coordinates must lie from -1000 to 1000 mm)"
    );
}

#[test]
fn a_key_given_twice_is_refused_not_the_last_kept() {
    // A second "holes" silently replaced the first's holes.
    let text =
        slice(SQUARE, &[SMALL], "").replacen(r#""holes": ["#, r#""holes": [], "holes": ["#, 1);
    let e = err(&text);
    assert!(
        e.contains(r#"the key "holes" appears twice in one object"#) && e.contains("line 1"),
        "{e}"
    );
    let e = err(&slice(
        SQUARE,
        &[SMALL],
        r#""road_width": 0.4, "road_width": 0.5"#,
    ));
    assert!(e.contains(r#""road_width" appears twice"#), "{e}");
}

#[test]
fn a_huge_setting_is_out_of_range_as_written_not_infinite() {
    let e = err(&slice(SQUARE, &[SMALL], r#""w_n": 1e308"#));
    assert_eq!(e, "setting w_n: 1e308 is out of range (0 to 16)");
}

#[test]
fn a_bow_tie_hole_is_self_intersecting() {
    let e = err(&slice(SQUARE, &["[[0,0],[2,2],[2,0],[0,2]]"], ""));
    assert!(e.contains("hole 0: edges 0 and 2 intersect"), "{e}");
}

#[test]
fn setting_value_errors_name_the_key_and_range() {
    let e = err(&slice(SQUARE, &[SMALL], r#""relax_iterations": 256"#));
    assert_eq!(
        e,
        "invalid slice: setting relax_iterations: 256 is out of range (allowed: a whole number from 0 to 64)"
    );
    let e = err(&slice(SQUARE, &[SMALL], r#""relax_iterations": 2.5"#));
    assert!(
        e.contains("setting relax_iterations: 2.5 is out of range"),
        "{e}"
    );
    let e = err(&slice(SQUARE, &[SMALL], r#""road_width": "0.4""#));
    assert_eq!(
        e,
        "setting road_width: expected a number (0.01 to 10 mm), found a string"
    );
    let e = err(&slice(SQUARE, &[SMALL], r#""delta": null"#));
    assert!(e.starts_with("setting delta: expected a number"), "{e}");
    let e = err(&slice(SQUARE, &[SMALL], r#""road_width": 0"#));
    assert!(e.ends_with("(allowed: 0.01 to 10 mm)"), "{e}");
    let e = err(&slice(SQUARE, &[SMALL], r#""w_n": 1e300"#));
    assert!(
        e.contains("setting w_n:") && e.contains("out of range"),
        "{e}"
    );
}

#[test]
fn values_that_are_not_numbers_name_where_they_are() {
    let e = err(&slice(SQUARE, &["[[-1,-1],[1,null],[1,1]]"], ""));
    assert_eq!(e, "hole 0: point 1: y is not a number (found null)");
    let e = err(&slice(SQUARE, &[SMALL], "").replace("[0, 1, 0, 0]", r#"[0, "1", 0, 0]"#));
    assert_eq!(
        e,
        "hole 0: material fraction 1 is not a number (found a string)"
    );
}

#[test]
fn a_closed_contour_of_the_vertex_limit_fits() {
    let n = hollowpath::config::MAX_VERTICES;
    let mut ring: Vec<String> = (0..n)
        .map(|k| {
            let a = k as f64 / n as f64 * std::f64::consts::TAU;
            format!("[{},{}]", 9.0 * a.cos(), 9.0 * a.sin())
        })
        .collect();
    ring.push(ring[0].clone());
    // Not simplified (a big contour would be, within simplify_tolerance, before planning).
    let f = parse(&slice(
        &format!("[{}]", ring.join(",")),
        &[SMALL],
        r#""simplify_tolerance": 0"#,
    ))
    .unwrap();
    assert_eq!(f.slice.wall().points().len(), n);
}

#[test]
fn an_oversized_file_is_refused_without_reading_it_all() {
    let path = std::env::temp_dir().join(format!("hollowpath-big-{}.json", std::process::id()));
    std::fs::write(&path, " ".repeat(1025)).unwrap();
    let e = host_sim::slice_file::load_with_limit(&path, 1024).unwrap_err();
    assert_eq!(
        e.to_string(),
        format!("slice file {} is larger than 1024 bytes", path.display())
    );
    let _ = std::fs::remove_file(&path);
    if std::path::Path::new("/dev/zero").exists() {
        let e = host_sim::slice_file::load(std::path::Path::new("/dev/zero")).unwrap_err();
        assert_eq!(e.to_string(), "slice file /dev/zero is larger than 64 MiB");
    }
}
