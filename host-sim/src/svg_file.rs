//! Drawings as slices (`hollowpath plan DRAWING.svg`), through `usvg`: every shape's outline,
//! with its transforms applied and its curves flattened within [`FLATNESS_MM`], in millimetres
//! (the drawing's own units: `width="60mm"` with a `viewBox` scales user units to mm; plain
//! user units are CSS pixels, 96 to the inch), y pointing up. Outlines are sorted into a wall
//! and holes by nesting, as a model's cut is. Each shape's material is its `data-material`
//! (a channel letter `A`-`D`, or fractions `"0, 0.5, 0.5, 0"`) on the shape or a group around
//! it, which needs an `id` (usvg keeps the ids of the elements it keeps); otherwise its fill
//! colour (or stroke colour) matched to the previews' channel colours within [`PALETTE_TOL`].

use std::collections::HashMap;
use std::fmt;
use std::path::Path;

use hollowpath::config::CHANNELS;
use hollowpath::geometry::{polygon, Point};
use hollowpath::{Material, Settings, Slice};

use crate::model::{cut, nest};
use crate::render::CHANNEL_COLOURS;
use crate::slice_file::SliceFile;

/// Largest distance between a curve and its flattened polyline, mm.
pub const FLATNESS_MM: f64 = 0.005;
/// Largest distance (0-255 per component, Euclidean) between a fill colour and a channel's
/// colour for the fill to name that channel.
pub const PALETTE_TOL: f64 = 60.0;
/// The largest drawing read.
pub const MAX_FILE_BYTES: u64 = 64 << 20;

/// Why a drawing could not be turned into a slice.
#[derive(Debug)]
pub enum SvgError {
    /// The file could not be read.
    Io(String, std::io::Error),
    /// Not SVG (usvg's reason).
    Svg(String),
    /// A shape's material is missing or wrong (the shape, why).
    Material(String, String),
    /// The drawing is not one wall with holes (why).
    Shape(String),
    /// The slice is invalid (the core's verdict).
    Slice(hollowpath::Error),
}

impl fmt::Display for SvgError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SvgError::Io(p, e) => write!(f, "cannot read {p}: {e}"),
            SvgError::Svg(e) => write!(f, "not an SVG drawing: {e}"),
            SvgError::Material(shape, why) => write!(f, "{shape}: {why}"),
            SvgError::Shape(why) => f.write_str(why),
            SvgError::Slice(e) => write!(f, "invalid slice: {e}"),
        }
    }
}

impl std::error::Error for SvgError {}

/// Reads a drawing.
pub fn load(path: &Path) -> Result<SliceFile, SvgError> {
    let shown = path.display().to_string();
    let text = crate::json_file::read_text(path, MAX_FILE_BYTES).map_err(|e| match e {
        crate::json_file::ReadError::Io(e) => SvgError::Io(shown.clone(), e),
        crate::json_file::ReadError::TooLarge(l) => {
            SvgError::Svg(format!("larger than {}", crate::json_file::size(l)))
        }
        crate::json_file::ReadError::NotUtf8(at) => {
            SvgError::Svg(format!("not UTF-8 text (invalid byte at offset {at})"))
        }
    })?;
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    parse(&text, &name)
}

/// A `data-material` value.
fn material_value(v: &str) -> Result<Material, String> {
    let v = v.trim();
    if let Some(c) = ["A", "B", "C", "D"]
        .iter()
        .position(|l| l.eq_ignore_ascii_case(v))
    {
        let mut m = [0.0; CHANNELS];
        m[c] = 1.0;
        return Ok(m);
    }
    let parts: Vec<&str> = v.split([',', ' ']).filter(|s| !s.is_empty()).collect();
    if parts.is_empty() || parts.len() > CHANNELS {
        return Err(format!(
            "data-material \"{v}\" is neither a channel letter A-D nor 1 to {CHANNELS} fractions"
        ));
    }
    let mut m = [0.0f32; CHANNELS];
    for (c, p) in parts.iter().enumerate() {
        m[c] = p
            .parse::<f32>()
            .ok()
            .filter(|x| (0.0..=1.0).contains(x))
            .ok_or_else(|| {
                format!("data-material \"{v}\": fraction {c} \"{p}\" is not a number from 0 to 1")
            })?;
    }
    let sum: f32 = m.iter().sum();
    if (sum - 1.0).abs() > 1e-3 {
        return Err(format!(
            "data-material \"{v}\": the fractions sum to {sum}, not 1"
        ));
    }
    Ok(m)
}

/// The channel whose preview colour is nearest `c`, if within [`PALETTE_TOL`].
fn palette(c: usvg::Color) -> Result<Material, String> {
    let d = |k: usize| {
        let p = CHANNEL_COLOURS[k].map(|x| x as f64 * 255.0);
        ((c.red as f64 - p[0]).powi(2)
            + (c.green as f64 - p[1]).powi(2)
            + (c.blue as f64 - p[2]).powi(2))
        .sqrt()
    };
    let best = (0..CHANNEL_COLOURS.len().min(CHANNELS))
        .min_by(|a, b| d(*a).total_cmp(&d(*b)))
        .unwrap_or(0);
    if d(best) > PALETTE_TOL {
        return Err(format!(
            "colour #{:02x}{:02x}{:02x} is near no channel's colour (A #d62629, B #1f78b5, C #2ba12b, D #ff800d); give it a data-material",
            c.red, c.green, c.blue
        ));
    }
    let mut m = [0.0; CHANNELS];
    m[best] = 1.0;
    Ok(m)
}

/// Flattens a cubic from `p0` to `p3` into `out` (without `p0`) within `tol`.
fn cubic(
    p0: [f64; 2],
    p1: [f64; 2],
    p2: [f64; 2],
    p3: [f64; 2],
    tol: f64,
    depth: u32,
    out: &mut Vec<[f64; 2]>,
) {
    let dist = |p: [f64; 2]| {
        let (dx, dy) = (p3[0] - p0[0], p3[1] - p0[1]);
        let l = dx.hypot(dy);
        if l < 1e-12 {
            (p[0] - p0[0]).hypot(p[1] - p0[1])
        } else {
            ((p[0] - p0[0]) * dy - (p[1] - p0[1]) * dx).abs() / l
        }
    };
    // The curve lies within the hull of its control points: 3/4 of their distance bounds it.
    if depth >= 18 || 0.75 * dist(p1).max(dist(p2)) <= tol {
        out.push(p3);
        return;
    }
    let mid = |a: [f64; 2], b: [f64; 2]| [(a[0] + b[0]) * 0.5, (a[1] + b[1]) * 0.5];
    let (a, b, c) = (mid(p0, p1), mid(p1, p2), mid(p2, p3));
    let (d, e) = (mid(a, b), mid(b, c));
    let m = mid(d, e);
    cubic(p0, a, d, m, tol, depth + 1, out);
    cubic(m, e, c, p3, tol, depth + 1, out);
}

/// One outline and the shape it came from.
struct Outline {
    points: Vec<[f64; 2]>,
    material: Result<Material, String>,
    shape: String,
}

fn collect(
    group: &usvg::Group,
    inherited: Option<&str>,
    mats: &HashMap<String, String>,
    scale: f64,
    height: f64,
    out: &mut Vec<Outline>,
) {
    let here = if !group.id().is_empty() && mats.contains_key(group.id()) {
        Some(group.id())
    } else {
        inherited
    };
    for node in group.children() {
        match node {
            usvg::Node::Group(g) => collect(g, here, mats, scale, height, out),
            usvg::Node::Path(p) => {
                let id = p.id();
                let shape = if id.is_empty() {
                    "a shape without id".to_string()
                } else {
                    format!("shape \"{id}\"")
                };
                let key = if mats.contains_key(id) {
                    Some(id)
                } else {
                    here
                };
                let material = match key {
                    Some(k) => material_value(&mats[k]),
                    None => match (p.fill().map(|f| f.paint()), p.stroke().map(|s| s.paint())) {
                        (Some(usvg::Paint::Color(c)), _) | (None, Some(usvg::Paint::Color(c))) => {
                            palette(*c)
                        }
                        _ => Err("no data-material and no plain fill colour".to_string()),
                    },
                };
                let t = p.abs_transform();
                let map = |q: usvg::tiny_skia_path::Point| {
                    let mut q = q;
                    t.map_point(&mut q);
                    [q.x as f64, q.y as f64]
                };
                let tol = FLATNESS_MM / scale;
                let mut pts: Vec<[f64; 2]> = Vec::new();
                let mut last = [0.0, 0.0];
                let flush = |pts: &mut Vec<[f64; 2]>, out: &mut Vec<Outline>| {
                    if pts.len() >= 3 {
                        let points = pts
                            .iter()
                            .map(|q| [q[0] * scale, (height - q[1]) * scale])
                            .collect();
                        out.push(Outline {
                            points,
                            material: material.clone(),
                            shape: shape.clone(),
                        });
                    }
                    pts.clear();
                };
                for seg in p.data().segments() {
                    use usvg::tiny_skia_path::PathSegment as S;
                    match seg {
                        S::MoveTo(q) => {
                            flush(&mut pts, out);
                            last = map(q);
                            pts.push(last);
                        }
                        S::LineTo(q) => {
                            last = map(q);
                            pts.push(last);
                        }
                        S::QuadTo(c, q) => {
                            let (c, q) = (map(c), map(q));
                            let c1 = [
                                last[0] + 2.0 / 3.0 * (c[0] - last[0]),
                                last[1] + 2.0 / 3.0 * (c[1] - last[1]),
                            ];
                            let c2 = [
                                q[0] + 2.0 / 3.0 * (c[0] - q[0]),
                                q[1] + 2.0 / 3.0 * (c[1] - q[1]),
                            ];
                            cubic(last, c1, c2, q, tol, 0, &mut pts);
                            last = q;
                        }
                        S::CubicTo(c1, c2, q) => {
                            let q2 = map(q);
                            cubic(last, map(c1), map(c2), q2, tol, 0, &mut pts);
                            last = q2;
                        }
                        S::Close => flush(&mut pts, out),
                    }
                }
                flush(&mut pts, out);
            }
            _ => {}
        }
    }
}

/// Reads a drawing's text (`name` for the slice).
pub fn parse(text: &str, name: &str) -> Result<SliceFile, SvgError> {
    let opt = usvg::Options::default();
    let doc = usvg::roxmltree::Document::parse(text).map_err(|e| SvgError::Svg(e.to_string()))?;
    let mut mats = HashMap::new();
    for n in doc.descendants().filter(|n| n.is_element()) {
        if let Some(m) = n.attribute("data-material") {
            match n.attribute("id") {
                Some(id) if !id.is_empty() => {
                    mats.insert(id.to_string(), m.to_string());
                }
                _ => {
                    let pos = doc.text_pos_at(n.range().start);
                    return Err(SvgError::Material(
                        format!("<{}> at line {}", n.tag_name().name(), pos.row),
                        "data-material needs an id on the same element".into(),
                    ));
                }
            }
        }
    }
    let tree = usvg::Tree::from_xmltree(&doc, &opt).map_err(|e| SvgError::Svg(e.to_string()))?;
    let scale = 25.4 / opt.dpi as f64;
    let height = tree.size().height() as f64;
    let mut outlines = Vec::new();
    collect(tree.root(), None, &mats, scale, height, &mut outlines);
    if outlines.is_empty() {
        return Err(SvgError::Shape("the drawing has no closed shape".into()));
    }
    let contours: Vec<Vec<[f64; 2]>> = outlines.iter().map(|o| o.points.clone()).collect();
    // Outlines that cross would nest in no consistent way (and be named as separate walls):
    // say which cross.
    // Shapes are named by id where they have one, and by where they are (mm, the slice's
    // axes) always: usvg keeps no source lines.
    let describe = |i: usize| {
        let c = &contours[i];
        let n = c.len() as f64;
        let (x, y) = c
            .iter()
            .fold((0.0, 0.0), |(x, y), p| (x + p[0] / n, y + p[1] / n));
        format!("{} (around {x:.1}, {y:.1} mm)", outlines[i].shape)
    };
    // The outlines as the slice will hold them; crossing as the slice's own check finds.
    let points: Vec<Vec<Point>> = contours
        .iter()
        .map(|c| {
            c.iter()
                .map(|p| Point::new(p[0] as f32, p[1] as f32))
                .collect()
        })
        .collect();
    let crossing = (0..points.len()).find_map(|i| {
        (i + 1..points.len())
            .find(|&j| polygon::boundaries_meet(&points[i], &points[j]).is_some())
            .map(|j| (i, j))
    });
    if let Some((i, j)) = crossing {
        return Err(SvgError::Shape(format!(
            "{} and {} cross; a slice's holes lie inside its wall, apart from each other",
            describe(i),
            describe(j)
        )));
    }
    let islands = nest::nest(&contours);
    let [(wall, holes)] = &islands[..] else {
        // Outlines that cross none: one inside another's hole is a wall of its own to `nest`.
        let inside_other = |w: usize| {
            (0..contours.len()).any(|k| k != w && cut::contains(&contours[k], contours[w][0]))
        };
        if let Some(&(w, _)) = islands.iter().find(|(w, _)| inside_other(*w)) {
            return Err(SvgError::Shape(format!(
                "{} lies inside a hole; a slice's holes hold nothing",
                describe(w)
            )));
        }
        let walls: Vec<String> = islands.iter().map(|(w, _)| describe(*w)).collect();
        return Err(SvgError::Shape(format!(
            "the drawing has {} separate walls (outlines inside no other: {}); a slice has one",
            islands.len(),
            walls.join(", ")
        )));
    };
    let nested = contours.len() - 1 - holes.len();
    if nested > 0 {
        return Err(SvgError::Shape(format!(
            "{nested} outline(s) lie inside a hole; a slice's holes hold nothing"
        )));
    }
    let material = |i: usize| {
        outlines[i]
            .material
            .clone()
            .map_err(|why| SvgError::Material(outlines[i].shape.clone(), why))
    };
    let wall_pts = points[*wall].clone();
    let hole_pts: Vec<(Vec<Point>, Material)> = holes
        .iter()
        .map(|&h| Ok((points[h].clone(), material(h)?)))
        .collect::<Result<_, SvgError>>()?;
    let refs: Vec<(&[Point], Material)> = hole_pts.iter().map(|(p, m)| (&p[..], *m)).collect();
    let slice = Slice::from_contours(&wall_pts, material(*wall)?, &refs, Settings::default())
        .map_err(SvgError::Slice)?;
    Ok(SliceFile {
        name: name.to_string(),
        slice,
    })
}
