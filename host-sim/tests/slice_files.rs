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
    let e = err(r#"{"holes": []}"#);
    assert!(e.contains("missing field `outer`"), "{e}");
    let e = err(r#"{"outer": {"points": "square", "material": [1]}, "holes": []}"#);
    assert!(e.contains("not a slice file"), "{e}");
    let e = err(&slice("[[0,0,1],[1,0],[0,1]]", &[SMALL], ""));
    assert_eq!(e, "the wall: point 0 has 3 coordinates, expected [x, y]");
}

#[test]
fn format_errors() {
    let e = err(&slice(SQUARE, &[SMALL], r#""road_widht": 0.4"#));
    assert!(e.contains("unknown field `road_widht`"), "{e}");
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
            "hole 1: vertex 3 has a coordinate that is not a finite number",
        ),
        (
            slice(SQUARE, &["[[0,0],[1,1],[2,2]]"], ""),
            "hole 0: the polygon encloses no area",
        ),
        (
            slice(SQUARE, &["[[0,0],[4,4],[4,0],[0,2]]"], ""),
            "hole 0: edges 0 and 2 intersect",
        ),
        (
            slice(SQUARE, &["[[5,5],[12,5],[5,8]]"], ""),
            "hole 0: vertex 1 is not strictly inside the wall",
        ),
        (
            slice(SQUARE, &[SMALL, "[[0,0],[3,0],[3,3]]"], ""),
            "holes 0 and 1 overlap",
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
        (slice(SQUARE, &[], ""), "no hollow feature"),
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
            "the wall: vertex 2 lies beyond 1000 mm",
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
