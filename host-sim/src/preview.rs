//! Pictures of a layer's toolpath: the wall and the hollow features outlined, roads drawn at
//! the road width in the colour of their composition (a road whose composition changes along a
//! move is drawn in short pieces so the gradient shows), travel moves as thin dashed lines.
//! [`layer_svg`] writes SVG (y up, as in [`crate::render`]); [`layer_png`] paints a PNG with
//! tiny-skia.

use hollowpath::toolpath::moves::Move;
use std::fmt::Write;

use hollowpath::geometry::Point;
use hollowpath::toolpath::composition::blend;
use hollowpath::toolpath::Vertex;
use hollowpath::{Material, Slice};
use tiny_skia::{
    Color, FillRule, LineCap, LineJoin, Paint, PathBuilder, Pixmap, Stroke, StrokeDash, Transform,
};

use crate::metrics::road_runs;
use crate::render::{colour, svg_path};

/// Blank border around the wall's bounding box, mm.
pub const MARGIN_MM: f32 = 1.0;
/// Fill of the hollow features.
pub const HOLE_FILL: &str = "#eeeeee";
/// Colour of travel moves.
pub const TRAVEL_COLOUR: &str = "#555555";

/// Pieces a move of `len` mm from vertex `a` to `b` is drawn in: one if both ends show in the
/// same colour at the same width, else about one per half road width (at most 16).
fn pieces(a: &Vertex, b: &Vertex, w: f32) -> usize {
    if colour(&a.material) == colour(&b.material) && (a.width - b.width).abs() < 0.01 * w {
        1
    } else {
        ((a.at.dist(b.at) / (0.5 * w)).ceil() as usize).clamp(2, 16)
    }
}

/// Whether a road is drawn as one stroke: one colour and one width all along.
fn uniform(road: &[Vertex], w: f32) -> bool {
    let base = colour(&road[0].material);
    road.iter()
        .all(|v| colour(&v.material) == base && (v.width - road[0].width).abs() < 0.01 * w)
}

/// The pieces a road is drawn in: each move split into up to 16 pieces (one where its ends
/// look alike) with the blended composition and the width at the piece's middle.
fn shaded_pieces(
    road: &[Vertex],
    w: f32,
) -> impl Iterator<Item = (Point, Point, Material, f32)> + '_ {
    road.windows(2).flat_map(move |seg| {
        let (a, b) = (seg[0], seg[1]);
        let n = pieces(&a, &b, w);
        (0..n).map(move |k| {
            let (t0, t1) = (k as f32 / n as f32, (k + 1) as f32 / n as f32);
            let t = 0.5 * (t0 + t1);
            (
                a.at.lerp(b.at, t0),
                a.at.lerp(b.at, t1),
                blend(&a.material, &b.material, t),
                a.width + (b.width - a.width) * t,
            )
        })
    })
}

/// `(x0, y1, width, height)` of the picture in mm: the wall's box grown by [`MARGIN_MM`]
/// (`x0` its left edge, `y1` its top).
fn frame(slice: &Slice) -> (f32, f32, f32, f32) {
    let (lo, hi) = slice.wall().bbox();
    (
        lo.x - MARGIN_MM,
        hi.y + MARGIN_MM,
        hi.x - lo.x + 2.0 * MARGIN_MM,
        hi.y - lo.y + 2.0 * MARGIN_MM,
    )
}

/// The layer as SVG: one `<path class="road">` per road (a maximal run of depositing moves),
/// with `<line class="shade">` pieces over it where its composition changes, and one dashed
/// `<line class="travel">` per travel move.
pub fn layer_svg(slice: &Slice, path: &[Vertex]) -> String {
    let (x0, y1, fw, fh) = frame(slice);
    let w = slice.settings().road_width;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="{x0} {} {fw} {fh}" width="{}" height="{}">"#,
        -y1,
        (fw * 25.0) as u32,
        (fh * 25.0) as u32
    );
    let _ = writeln!(
        s,
        r#"<rect x="{x0}" y="{}" width="100%" height="100%" fill="white"/>"#,
        -y1
    );
    for h in slice.holes() {
        let _ = writeln!(
            s,
            r#"<path class="hole" d="{}" fill="{HOLE_FILL}" stroke="{}" stroke-width="0.08"/>"#,
            svg_path(h.points(), true),
            colour(&h.material())
        );
    }
    for run in road_runs(path) {
        let road = &path[run];
        let pts: Vec<Point> = road.iter().map(|v| v.at).collect();
        // The narrowest width all along; pieces over it show where it is wider.
        let narrow = road.iter().map(|v| v.width).fold(f32::INFINITY, f32::min);
        let _ = writeln!(
            s,
            r#"<path class="road" d="{}" fill="none" stroke="{}" stroke-width="{narrow}" stroke-linecap="round" stroke-linejoin="round"/>"#,
            svg_path(&pts, false),
            colour(&road[0].material)
        );
        if uniform(road, w) {
            continue;
        }
        for (p, q, m, width) in shaded_pieces(road, w) {
            let _ = writeln!(
                s,
                r#"<line class="shade" x1="{:.4}" y1="{:.4}" x2="{:.4}" y2="{:.4}" stroke="{}" stroke-width="{width:.4}" stroke-linecap="round"/>"#,
                p.x,
                -p.y,
                q.x,
                -q.y,
                colour(&m)
            );
        }
    }
    for (k, v) in path.iter().enumerate().skip(1) {
        if v.deposit {
            continue;
        }
        let p = path[k - 1].at;
        let _ = writeln!(
            s,
            r#"<line class="travel" x1="{:.4}" y1="{:.4}" x2="{:.4}" y2="{:.4}" stroke="{TRAVEL_COLOUR}" stroke-width="0.05" stroke-dasharray="0.3,0.2"/>"#,
            p.x, -p.y, v.at.x, -v.at.y
        );
    }
    let _ = writeln!(
        s,
        r#"<path class="wall" d="{}" fill="none" stroke="{}" stroke-width="0.12"/>"#,
        svg_path(slice.wall().points(), true),
        colour(&slice.wall().material())
    );
    s.push_str("</svg>\n");
    s
}

/// The size in pixels of [`layer_png`]'s picture of `slice` at `px_per_mm`.
pub fn png_size(slice: &Slice, px_per_mm: f32) -> (u32, u32) {
    let (_, _, fw, fh) = frame(slice);
    (
        ((fw * px_per_mm).ceil() as u32).max(1),
        ((fh * px_per_mm).ceil() as u32).max(1),
    )
}

/// `#rrggbb` as an opaque colour.
fn parse_colour(hex: &str) -> Color {
    let c = |k: usize| u8::from_str_radix(hex.get(k..k + 2).unwrap_or("00"), 16).unwrap_or(0);
    Color::from_rgba8(c(1), c(3), c(5), 255)
}

fn paint_of(hex: &str, anti_alias: bool) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color(parse_colour(hex));
    p.anti_alias = anti_alias;
    p
}

/// The layer as a PNG at `px_per_mm` pixels per millimetre (same picture as [`layer_svg`]).
/// Roads are painted without anti-aliasing, so roads that abut leave no pale seam that would
/// read as a gap; outlines and travel are anti-aliased.
pub fn layer_png(slice: &Slice, path: &[Vertex], px_per_mm: f32) -> Vec<u8> {
    islands_png(&[(slice, path)], px_per_mm)
}

/// A layer of several islands (each a slice and its path, in printing order) as one PNG
/// framing them all, as [`layer_png`] draws one, with the travel from each island's road to
/// the next one's dashed.
pub fn islands_png(islands: &[(&Slice, &[Vertex])], px_per_mm: f32) -> Vec<u8> {
    let (mut x0, mut y1, mut x1, mut y0) = (f32::MAX, f32::MIN, f32::MIN, f32::MAX);
    for (slice, _) in islands {
        let (fx, fy, fw, fh) = frame(slice);
        x0 = x0.min(fx);
        y1 = y1.max(fy);
        x1 = x1.max(fx + fw);
        y0 = y0.min(fy - fh);
    }
    let (width, height) = match islands {
        [(slice, _)] => png_size(slice, px_per_mm),
        _ => (
            (((x1 - x0) * px_per_mm).ceil() as u32).max(1),
            (((y1 - y0) * px_per_mm).ceil() as u32).max(1),
        ),
    };
    let mut pixmap = Pixmap::new(width, height).expect("picture size is positive");
    pixmap.fill(Color::WHITE);
    let s = px_per_mm;
    let px = |p: Point| ((p.x - x0) * s, (y1 - p.y) * s);
    let polyline = |pts: &[Point], close: bool| {
        let mut b = PathBuilder::new();
        for (k, &p) in pts.iter().enumerate() {
            let (x, y) = px(p);
            if k == 0 {
                b.move_to(x, y);
            } else {
                b.line_to(x, y);
            }
        }
        if close {
            b.close();
        }
        b.finish()
    };
    let outline = Stroke {
        width: (0.08 * s).max(1.0),
        ..Stroke::default()
    };
    let id = Transform::identity();
    for h in islands.iter().flat_map(|(slice, _)| slice.holes()) {
        if let Some(p) = polyline(h.points(), true) {
            pixmap.fill_path(&p, &paint_of(HOLE_FILL, true), FillRule::Winding, id, None);
        }
    }
    for (slice, path) in islands {
        let w = slice.settings().road_width;
        let stroke = |width: f32| Stroke {
            width: width * s,
            line_cap: LineCap::Round,
            line_join: LineJoin::Round,
            ..Stroke::default()
        };
        for run in road_runs(path) {
            let verts = &path[run];
            let base = colour(&verts[0].material);
            if uniform(verts, w) {
                let road = stroke(verts[0].width);
                let pts: Vec<Point> = verts.iter().map(|v| v.at).collect();
                // A road of one zero-length move is a dot: a round cap needs a direction.
                let pts = if pts.len() == 2 && pts[0] == pts[1] {
                    vec![pts[0], Point::new(pts[0].x + 1e-4, pts[0].y)]
                } else {
                    pts
                };
                if let Some(p) = polyline(&pts, false) {
                    pixmap.stroke_path(&p, &paint_of(&base, false), &road, id, None);
                }
                continue;
            }
            for (p, q, m, width) in shaded_pieces(verts, w) {
                if let Some(line) = polyline(&[p, q], false) {
                    pixmap.stroke_path(
                        &line,
                        &paint_of(&colour(&m), false),
                        &stroke(width),
                        id,
                        None,
                    );
                }
            }
        }
    }
    let travel = Stroke {
        width: 1.0,
        dash: StrokeDash::new(vec![0.3 * s, 0.2 * s], 0.0),
        ..Stroke::default()
    };
    for (i, (_, path)) in islands.iter().enumerate() {
        let from = i
            .checked_sub(1)
            .and_then(|j| islands[j].1.last())
            .zip(path.first());
        if let Some((a, b)) = from {
            if let Some(p) = polyline(&[a.at, b.at], false) {
                pixmap.stroke_path(&p, &paint_of(TRAVEL_COLOUR, true), &travel, id, None);
            }
        }
        for (k, v) in path.iter().enumerate().skip(1) {
            if v.deposit || v.at == path[k - 1].at {
                continue;
            }
            if let Some(p) = polyline(&[path[k - 1].at, v.at], false) {
                pixmap.stroke_path(&p, &paint_of(TRAVEL_COLOUR, true), &travel, id, None);
            }
        }
    }
    for (slice, _) in islands {
        for (pts, m) in slice
            .holes()
            .iter()
            .map(|h| (h.points(), h.material()))
            .chain([(slice.wall().points(), slice.wall().material())])
        {
            if let Some(p) = polyline(pts, true) {
                pixmap.stroke_path(&p, &paint_of(&colour(&m), true), &outline, id, None);
            }
        }
    }
    pixmap
        .encode_png()
        .expect("encoding an in-memory PNG cannot fail")
}

/// The moves a printer laid (constant width and mix each, e.g. rebuilt from a pin trace) as a
/// path [`layer_png`] draws: each depositing move a vertex at its end with its width and mix,
/// a travel wherever a move does not start where the last one ended.
pub fn moves_path(moves: &[Move]) -> Vec<Vertex> {
    let mut path: Vec<Vertex> = Vec::with_capacity(moves.len() + 1);
    for m in moves {
        if path.last().is_none_or(|v| v.at != m.from) {
            path.push(Vertex {
                at: m.from,
                material: m.material,
                width: m.width,
                deposit: false,
            });
        }
        path.push(Vertex {
            at: m.to,
            material: m.material,
            width: m.width,
            deposit: m.deposit,
        });
    }
    path
}

/// [`deposit_png`]'s colour of printable ground left bare.
pub const BARE: [u8; 3] = [0xe0, 0x20, 0x20];
/// [`deposit_png`]'s colour of ground covered once.
pub const ONCE: [u8; 3] = [0xe8, 0xe8, 0xe8];
/// [`deposit_png`]'s colour of ground covered twice or more (overfill).
pub const TWICE: [u8; 3] = [0x20, 0x50, 0xd0];
/// [`deposit_png`]'s colour of deposit in a hollow feature or outside the wall (spill).
pub const SPILT: [u8; 3] = [0x00, 0x00, 0x00];
/// [`deposit_png`]'s colour of the void that stays empty.
pub const VOID: [u8; 3] = [0xff, 0xff, 0xff];

/// Where the last layer measured on `raster` left ground bare (red), covered it once (grey),
/// twice or more (blue), and deposited where no material belongs (black), one pixel per
/// raster cell (north up): the picture of the layer's coverage, overfill and spill
/// (`metrics.json`). The margin (material within half a road of a feature, which no round
/// nozzle may reach without spilling) counts only when it is covered twice, as overfill does.
pub fn deposit_png(raster: &crate::raster::Raster) -> Vec<u8> {
    use crate::raster::Region;
    let (nx, ny) = (raster.nx as u32, raster.ny as u32);
    let mut pixmap = Pixmap::new(nx.max(1), ny.max(1)).expect("picture size is positive");
    let data = pixmap.data_mut();
    for j in 0..raster.ny {
        for i in 0..raster.nx {
            let k = j * raster.nx + i;
            let c = match (raster.region[k], raster.count[k]) {
                (Region::Void, 0) => VOID,
                (Region::Void, _) => SPILT,
                (_, n) if n >= 2 => TWICE,
                (Region::Printable, 0) => BARE,
                (Region::Margin, 0) => VOID,
                _ => ONCE,
            };
            let row = raster.ny - 1 - j;
            let o = 4 * (row * raster.nx + i);
            data[o..o + 4].copy_from_slice(&[c[0], c[1], c[2], 0xff]);
        }
    }
    pixmap
        .encode_png()
        .expect("encoding an in-memory PNG cannot fail")
}
