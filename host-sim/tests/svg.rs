//! Drawings as slices: `hollowpath plan DRAWING.svg` (usvg).

use std::process::Command;

use host_sim::svg_file::{parse, FLATNESS_MM};

const DRAWING: &str = r##"<svg xmlns="http://www.w3.org/2000/svg" width="20mm" height="20mm" viewBox="0 0 20 20">
  <rect x="1" y="1" width="18" height="18" rx="2" fill="#d62629"/>
  <g transform="translate(10 10) scale(0.5)">
    <circle id="vessel" cx="-8" cy="-8" r="4" data-material="C"/>
  </g>
  <path id="canal" d="M 12 12 C 14 11 17 13 16 15 S 13 17 12 12 Z" fill="#1f78b5"/>
</svg>"##;

fn on_large_stack<T: Send>(f: impl FnOnce() -> T + Send) -> T {
    host_sim::run_on_large_stack(f)
}

#[test]
fn transforms_units_and_curves_are_applied_within_the_flatness() {
    let f = on_large_stack(|| parse(DRAWING, "d").unwrap());
    let s = &f.slice;
    assert_eq!(s.holes().len(), 2);
    // The circle: centre (10 - 4, 10 - 4) in a 20 mm tall drawing, y up: (6, 14); radius 2.
    let circle = s
        .holes()
        .iter()
        .find(|h| h.material() == [0.0, 0.0, 1.0, 0.0])
        .expect("the data-material C hole");
    // A circle is drawn as four cubics, which stray up to 2.7e-4 of the radius outside it;
    // the chords of the flattened cubics lie at most FLATNESS_MM inside them.
    let bezier = 2.8e-4 * 2.0;
    for p in circle.points() {
        let r = ((p.x - 6.0) as f64).hypot((p.y - 14.0) as f64);
        assert!(
            r <= 2.0 + bezier && r >= 2.0 - bezier - FLATNESS_MM,
            "{p:?}: r {r}"
        );
    }
    let area = hollowpath::geometry::polygon::double_area(circle.points()).abs() as f64 * 0.5;
    let exact = std::f64::consts::PI * 4.0;
    assert!(
        (exact - area).abs() <= 2.0 * std::f64::consts::PI * 2.0 * FLATNESS_MM,
        "{area}"
    );
    // The canal by its fill colour (the previews' channel B), the wall by its red (A).
    assert!(s
        .holes()
        .iter()
        .any(|h| h.material() == [0.0, 1.0, 0.0, 0.0]));
    assert_eq!(s.wall().material(), [1.0, 0.0, 0.0, 0.0]);
    let (lo, hi) = s.wall().bbox();
    assert!((lo.x - 1.0).abs() < 1e-3 && (hi.y - 19.0).abs() < 1e-3);
}

#[test]
fn user_units_are_css_pixels() {
    let svg = r##"<svg xmlns="http://www.w3.org/2000/svg" width="96" height="96">
      <rect x="0" y="0" width="96" height="96" fill="#d62629"/>
      <rect x="24" y="24" width="48" height="48" fill="#2ba12b"/></svg>"##;
    let f = on_large_stack(|| parse(svg, "px").unwrap());
    let (lo, hi) = f.slice.wall().bbox();
    assert!((hi.x - lo.x - 25.4).abs() < 1e-3, "{lo:?} {hi:?}");
    assert_eq!(f.slice.holes()[0].material(), [0.0, 0.0, 1.0, 0.0]);
}

#[test]
fn drawings_that_are_not_one_slice_are_refused_naming_why() {
    let cases = [
        (DRAWING.replace("#1f78b5", "#888888"), "shape \"canal\": colour #888888 is near no channel's colour"),
        (DRAWING.replace(r#"id="vessel" "#, ""), "<circle> at line 4: data-material needs an id"),
        (DRAWING.replace(r#"data-material="C""#, r#"data-material="0.5, 0.2""#), "the fractions sum to 0.7"),
        ("plainly not xml".to_string(), "not an SVG drawing"),
        (
            r##"<svg xmlns="http://www.w3.org/2000/svg" width="20mm" height="20mm" viewBox="0 0 20 20"><rect width="5" height="5" fill="red"/><rect x="10" width="5" height="5" fill="red"/></svg>"##.to_string(),
            "2 separate walls",
        ),
        // A hole across the wall, two holes overlapping: they were '2 separate walls' too.
        (
            r##"<svg xmlns="http://www.w3.org/2000/svg" width="20mm" height="20mm" viewBox="0 0 20 20"><rect width="20" height="20" fill="#d62629"/><circle cx="19" cy="10" r="3" fill="#1f78b5"/></svg>"##.to_string(),
            "(around 19.0, 10.0 mm) cross; a slice's holes lie inside its wall",
        ),
        (
            r##"<svg xmlns="http://www.w3.org/2000/svg" width="20mm" height="20mm" viewBox="0 0 20 20"><rect width="20" height="20" fill="#d62629"/><circle cx="8" cy="10" r="3" fill="#1f78b5"/><circle cx="12" cy="10" r="3" fill="#2ba12b"/></svg>"##.to_string(),
            "(around 8.0, 10.0 mm) and a shape without id (around 12.0, 10.0 mm) cross",
        ),
        (
            r##"<svg xmlns="http://www.w3.org/2000/svg" width="20mm" height="20mm" viewBox="0 0 20 20"><rect width="20" height="20" fill="#d62629"/><rect x="4" y="4" width="12" height="12" fill="#1f78b5"/><rect x="8" y="8" width="4" height="4" fill="#d62629"/></svg>"##.to_string(),
            "(around 10.0, 10.0 mm) lies inside a hole",
        ),
    ];
    for (svg, want) in cases {
        let e = on_large_stack(|| parse(&svg, "x").unwrap_err()).to_string();
        assert!(e.contains(want), "{want}: {e}");
    }
}

#[test]
fn plan_reads_a_drawing() {
    let dir = std::env::temp_dir().join(format!("hollowpath-svg-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let svg = dir.join("scaffold.svg");
    std::fs::write(&svg, DRAWING).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_hollowpath"))
        .args(["plan", "--layers", "2", "--out"])
        .arg(dir.join("out"))
        .arg(&svg)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("out/metrics.json")).unwrap())
            .unwrap();
    let spiral = &m["layers"][1];
    assert_eq!(spiral["starts"], 1);
    assert!(spiral["coverage"].as_f64().unwrap() >= 0.97, "{spiral}");
    assert!(spiral["spill"].as_f64().unwrap() < 0.0005);
}
