//! Layer pictures: the PNG decodes to the right size with roads where they were drawn, and the
//! SVG has one path per road.

mod common;

use common::{two_holes, v, A, B, C};
use hollowpath::geometry::Point;
use hollowpath::toolpath::composition::blend;
use hollowpath::toolpath::Vertex;
use hollowpath::Slice;
use host_sim::preview::{layer_png, layer_svg, png_size, MARGIN_MM};
use host_sim::render::colour;
use tiny_skia::Pixmap;

/// Three roads: one in C, a gradient from A to B, an L in A; travel between them.
fn path() -> Vec<Vertex> {
    vec![
        v(-2.0, -7.0, C, false),
        v(4.0, -7.0, C, true),
        v(-2.0, -9.0, A, false),
        v(4.0, -9.0, B, true),
        v(-6.0, 6.0, A, false),
        v(0.0, 6.0, A, true),
        v(0.0, 8.0, A, true),
    ]
}

fn rgb(hex: &str) -> [u8; 3] {
    let c = |k: usize| u8::from_str_radix(&hex[k..k + 2], 16).unwrap();
    [c(1), c(3), c(5)]
}

struct Picture {
    pixmap: Pixmap,
    x0: f32,
    y1: f32,
    s: f32,
}

impl Picture {
    fn new(slice: &Slice, path: &[Vertex], s: f32) -> Picture {
        let png = layer_png(slice, path, s);
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        let pixmap = Pixmap::decode_png(&png).expect("the PNG decodes");
        let (lo, hi) = slice.wall().bbox();
        Picture {
            pixmap,
            x0: lo.x - MARGIN_MM,
            y1: hi.y + MARGIN_MM,
            s,
        }
    }

    /// The colour of the pixel under the point (x, y) mm.
    fn at(&self, x: f32, y: f32) -> [u8; 3] {
        let i = ((x - self.x0) * self.s).floor() as u32;
        let j = ((self.y1 - y) * self.s).floor() as u32;
        let c = self.pixmap.pixel(i, j).unwrap().demultiply();
        assert_eq!(c.alpha(), 255);
        [c.red(), c.green(), c.blue()]
    }
}

fn near(a: [u8; 3], b: [u8; 3], tol: u8) -> bool {
    a.iter().zip(b).all(|(x, y)| x.abs_diff(y) <= tol)
}

#[test]
fn the_png_has_the_frame_size_and_roads_in_their_colours() {
    let slice = two_holes();
    let s = 10.0;
    let pic = Picture::new(&slice, &path(), s);
    let (lo, hi) = slice.wall().bbox();
    let want_w = ((hi.x - lo.x + 2.0 * MARGIN_MM) * s).ceil() as u32;
    let want_h = ((hi.y - lo.y + 2.0 * MARGIN_MM) * s).ceil() as u32;
    assert_eq!((pic.pixmap.width(), pic.pixmap.height()), (want_w, want_h));
    assert_eq!(png_size(&slice, s), (want_w, want_h));

    // On the C road, across its width; just beyond its edge, white. (Past x = 2.5 the travel
    // to the next road is drawn over it.)
    for x in [-1.5, 0.0, 1.0, 2.0] {
        for dy in [-0.1, 0.0, 0.1] {
            assert_eq!(
                pic.at(x, -7.0 + dy),
                rgb(&colour(&C)),
                "C road at ({x}, {dy})"
            );
        }
        assert_eq!(pic.at(x, -7.0 + 0.35), [255, 255, 255]);
        assert_eq!(pic.at(x, -7.0 - 0.35), [255, 255, 255]);
    }
    // The round cap reaches past the end by half a road width, no further.
    assert_eq!(pic.at(4.05, -6.95), rgb(&colour(&C)));
    assert_eq!(pic.at(4.35, -7.0), [255, 255, 255]);
    // The L road in A along both legs.
    assert_eq!(pic.at(-3.0, 6.0), rgb(&colour(&A)));
    assert_eq!(pic.at(0.0, 7.5), rgb(&colour(&A)));
    // Inside a hole: its fill.
    assert_eq!(pic.at(-8.0, 0.0), rgb("#eeeeee"));
}

#[test]
fn a_gradient_road_shows_its_gradient() {
    let slice = two_holes();
    let pic = Picture::new(&slice, &path(), 10.0);
    // The road from A at x = -2 to B at x = 4: near each end its end colour, and in between
    // the blend of about that point (drawn in pieces of half a road width).
    // (The end pieces are coloured at their middles, t = 1/32 and 31/32.)
    assert!(near(pic.at(-2.05, -9.05), rgb(&colour(&A)), 10));
    assert!(near(pic.at(4.05, -9.05), rgb(&colour(&B)), 10));
    for x in [-1.0f32, 0.5, 1.0, 2.5] {
        let t = (x + 2.0) / 6.0;
        let got = pic.at(x, -9.0);
        let ok = [-0.05f32, 0.0, 0.05]
            .iter()
            .any(|dt| near(got, rgb(&colour(&blend(&A, &B, t + dt))), 8));
        assert!(ok, "at x = {x}: {got:?} is not the blend at t = {t}");
    }
    assert_ne!(pic.at(-1.0, -9.0), pic.at(2.5, -9.0));
}

#[test]
fn travel_is_a_thin_dashed_line() {
    let slice = two_holes();
    let pic = Picture::new(&slice, &path(), 20.0);
    // The travel from (4, -9) to (-6, 6): sample along it, away from the roads.
    let (a, b) = (Point::new(4.0, -9.0), Point::new(-6.0, 6.0));
    let (mut ink, mut bare) = (0, 0);
    for k in 20..=180 {
        let p = a.lerp(b, k as f32 / 200.0);
        if slice.holes().iter().any(|h| h.signed_distance(p) < 0.2) {
            continue;
        }
        let c = pic.at(p.x, p.y);
        if c.iter().all(|&x| x < 200) {
            ink += 1;
        } else if c == [255, 255, 255] {
            bare += 1;
        }
    }
    assert!(ink > 20, "travel drawn: {ink} dark samples");
    assert!(bare > 10, "travel dashed: {bare} blank samples");
    // Thin: a road width off the line is blank.
    let mid = a.lerp(b, 0.3);
    let n = (b - a).perp().normalized();
    let off = mid + n * 0.4;
    assert_eq!(pic.at(off.x, off.y), [255, 255, 255]);
}

#[test]
fn the_svg_has_one_path_per_road() {
    let slice = two_holes();
    let path = path();
    let svg = layer_svg(&slice, &path);
    assert!(svg.starts_with("<svg"));
    assert!(svg.trim_end().ends_with("</svg>"));
    let roads: Vec<&str> = svg
        .lines()
        .filter(|l| l.starts_with(r#"<path class="road""#))
        .collect();
    assert_eq!(roads.len(), 3);
    let paths = svg.matches("<path").count();
    assert_eq!(paths, 1 + slice.holes().len() + 3, "wall, holes, roads");
    // Roads in order, at the road width, y flipped, coloured by their first composition.
    assert!(
        roads[0].contains(r#"d="M-2.0000,7.0000 L4.0000,7.0000""#),
        "{}",
        roads[0]
    );
    assert!(roads[0].contains(&format!(r#"stroke="{}""#, colour(&C))));
    assert!(roads[2].contains(r#"d="M-6.0000,-6.0000 L0.0000,-6.0000 L0.0000,-8.0000""#));
    for r in &roads {
        assert!(r.contains(r#"stroke-width="0.4""#), "{r}");
    }
    // Only the gradient road is shaded, in pieces running from A's colour to B's.
    let shades: Vec<&str> = svg
        .lines()
        .filter(|l| l.starts_with(r#"<line class="shade""#))
        .collect();
    assert!(shades.len() >= 3, "{} shade pieces", shades.len());
    assert!(shades.iter().all(|l| l.contains(r#"y1="9.0000""#)));
    let first = shades.first().unwrap();
    let last = shades.last().unwrap();
    assert!(first.contains(r#"x1="-2.0000""#) && last.contains(r#"x2="4.0000""#));
    assert_ne!(first, last);
    // Two travel moves between the roads.
    assert_eq!(svg.matches(r#"<line class="travel""#).count(), 2);
    assert!(svg.contains("stroke-dasharray"));
}

#[test]
fn an_empty_layer_draws_only_the_slice() {
    let slice = two_holes();
    let svg = layer_svg(&slice, &[]);
    assert_eq!(svg.matches("<path").count(), 1 + slice.holes().len());
    assert!(!svg.contains("class=\"road\""));
    let pic = Picture::new(&slice, &[], 5.0);
    assert_eq!(pic.at(0.0, -7.0), [255, 255, 255]);
}

/// The deposition map counts, pixel by pixel, what `metrics.json` reports: bare printable
/// ground is red, ground covered twice blue, so their shares of the printable region are the
/// layer's `1 - coverage` and `overfill`.
#[test]
fn the_deposit_map_shows_the_layer_metrics() {
    use host_sim::layers::{layer, Fill};
    use host_sim::metrics::{Meter, Options};
    use host_sim::preview::deposit_png;
    host_sim::run_on_large_stack(|| {
        let slice = common::reference("three_holes");
        let plan = host_sim::plan(&slice).unwrap();
        let plan = plan.last_plan();
        let mut meter = Meter::new(&slice, Options::with_cell(0.025));
        for k in 0..2 {
            let l = layer(&slice, plan, Fill::Offset, k).unwrap();
            let m = meter.measure(l.pattern, &l.path, &|_| None);
            let png = deposit_png(meter.raster());
            let pixmap = Pixmap::decode_png(&png).expect("the PNG decodes");
            let raster = meter.raster();
            assert_eq!(
                (pixmap.width() as usize, pixmap.height() as usize),
                (raster.nx, raster.ny)
            );
            let count = |c: [u8; 3]| {
                pixmap
                    .pixels()
                    .iter()
                    .filter(|p| {
                        let p = p.demultiply();
                        [p.red(), p.green(), p.blue()] == c
                    })
                    .count() as f64
            };
            let printable = raster.printable_cells() as f64;
            let bare = count(host_sim::preview::BARE) / printable;
            let twice = count(host_sim::preview::TWICE) / printable;
            assert!(bare > 0.0 && twice > 0.0, "layer {k}: {bare} {twice}");
            assert!(
                (bare - (1.0 - m.coverage)).abs() < 1e-9,
                "layer {k}: {bare} vs {m:?}"
            );
            assert!(
                (twice - m.overfill).abs() < 1e-9,
                "layer {k}: {twice} vs {m:?}"
            );
        }
    });
}
