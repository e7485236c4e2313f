//! Which material each hollow feature of a model gets: channels tracked from layer to layer,
//! and the lab's materials file (`--materials MAP.json`).
//!
//! A hole of layer `k` and a hole of layer `k - 1` that overlap (seen from above) are the same
//! channel, so a channel that bends keeps one material on every layer; channels that split or
//! merge are one channel system. Each channel takes the first rule of the map that it matches:
//!
//! ```json
//! {
//!   "wall": "A",
//!   "channels": [
//!     { "at": [1.5, 4.5], "material": "C" },
//!     { "at": [3.0, 3.0, 1.2], "material": [0, 0, 0.5, 0.5] },
//!     { "diameter_mm": [0.5, 1.0], "material": "B" }
//!   ],
//!   "default": "D"
//! }
//! ```
//!
//! `at` `[x, y]` matches a channel one of whose holes contains the point, on any layer;
//! `[x, y, z]` only on the layer cut through height `z` (mm above the model's bottom).
//! `diameter_mm` `[min, max]` (or `area_mm2`) matches by the channel's median size (the
//! diameter of the circle of the same area). A material is a channel letter (`"A"` to `"D"`:
//! that reservoir alone) or a list of fractions summing to 1. A channel no rule matches takes
//! `default`; without one it is an error naming the channel. Unknown keys are errors naming
//! the key.

use hollowpath::config::CHANNELS;
use hollowpath::Material;
use serde_json::{Map, Value};

use super::cut::contains;
use super::error::ModelError;
use super::nest::Island;
use crate::json_file::kind;

/// Channel letters, as `M165` names them.
const LETTERS: [&str; 4] = ["A", "B", "C", "D"];

/// How a rule picks channels.
#[derive(Clone, Debug, PartialEq)]
pub enum Select {
    /// A point inside one of the channel's holes (on the layer through `z`, if given).
    At([f64; 2], Option<f64>),
    /// The channel's median equivalent diameter within `[min, max]`, mm.
    Diameter(f64, f64),
}

/// One rule of a materials file.
#[derive(Clone, Debug, PartialEq)]
pub struct Rule {
    /// What it matches.
    pub select: Select,
    /// The material it gives.
    pub material: Material,
}

/// A materials file.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialMap {
    /// The wall's material.
    pub wall: Material,
    /// The rules, first match wins.
    pub rules: Vec<Rule>,
    /// For channels no rule matches.
    pub default: Option<Material>,
}

impl MaterialMap {
    /// Without a file: the wall channel A, every hollow feature channel B.
    pub fn two_channel() -> MaterialMap {
        MaterialMap {
            wall: channel(0),
            rules: Vec::new(),
            default: Some(channel(1)),
        }
    }
}

/// Channel `c` alone.
fn channel(c: usize) -> Material {
    let mut m = [0.0; CHANNELS];
    m[c] = 1.0;
    m
}

fn err(s: String) -> ModelError {
    ModelError::Materials(s)
}

fn keys<'a>(
    v: &'a Value,
    where_: &str,
    allowed: &[&str],
) -> Result<&'a Map<String, Value>, ModelError> {
    let Value::Object(map) = v else {
        return Err(err(format!(
            "{where_} must be a JSON object {{...}}, found {}",
            kind(v)
        )));
    };
    if let Some(k) = map.keys().find(|k| !allowed.contains(&k.as_str())) {
        return Err(err(format!(
            "unknown key \"{k}\" in {where_}; expected one of {}",
            allowed.join(", ")
        )));
    }
    Ok(map)
}

fn material(v: &Value, where_: &str) -> Result<Material, ModelError> {
    match v {
        Value::String(s) => LETTERS
            .iter()
            .position(|l| l.eq_ignore_ascii_case(s))
            .map(channel)
            .ok_or_else(|| {
                err(format!(
                    "{where_}: unknown channel \"{s}\"; expected A, B, C or D"
                ))
            }),
        Value::Array(xs) => {
            if xs.len() > CHANNELS {
                return Err(err(format!(
                    "{where_}: {} fractions, the printer has {CHANNELS} channels",
                    xs.len()
                )));
            }
            let mut m = [0.0f32; CHANNELS];
            for (c, x) in xs.iter().enumerate() {
                let Some(f) = x.as_f64() else {
                    return Err(err(format!(
                        "{where_}: fraction {c} is not a number (found {})",
                        kind(x)
                    )));
                };
                if !(0.0..=1.0).contains(&f) {
                    return Err(err(format!(
                        "{where_}: fraction {c} is {f}, not between 0 and 1"
                    )));
                }
                m[c] = f as f32;
            }
            let sum: f32 = m.iter().sum();
            if (sum - 1.0).abs() > 1e-3 {
                return Err(err(format!("{where_}: the fractions sum to {sum}, not 1")));
            }
            Ok(m)
        }
        v => Err(err(format!(
            "{where_}: a material is a channel letter or a list of fractions, found {}",
            kind(v)
        ))),
    }
}

fn numbers<const N: usize>(v: &Value, where_: &str, what: &str) -> Result<[f64; N], ModelError> {
    let bad = || err(format!("{where_}: {what}"));
    let Value::Array(xs) = v else {
        return Err(bad());
    };
    if xs.len() != N {
        return Err(bad());
    }
    let mut out = [0.0; N];
    for (o, x) in out.iter_mut().zip(xs) {
        *o = x.as_f64().filter(|f| f.is_finite()).ok_or_else(bad)?;
    }
    Ok(out)
}

/// Reads a materials file's text.
pub fn parse(text: &str) -> Result<MaterialMap, ModelError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let doc: Value = serde_json::from_str(text).map_err(|e| err(format!("not valid JSON: {e}")))?;
    let top = keys(&doc, "the materials file", &["wall", "channels", "default"])?;
    let wall = match top.get("wall") {
        Some(v) => material(v, "\"wall\"")?,
        None => channel(0),
    };
    let default = top
        .get("default")
        .map(|v| material(v, "\"default\""))
        .transpose()?;
    let mut rules = Vec::new();
    match top.get("channels") {
        None => {}
        Some(Value::Array(list)) => {
            for (i, r) in list.iter().enumerate() {
                let where_ = format!("channels[{i}]");
                let map = keys(
                    r,
                    &where_,
                    &["at", "diameter_mm", "area_mm2", "material", "name"],
                )?;
                let m = material(
                    map.get("material")
                        .ok_or_else(|| err(format!("{where_}: missing key \"material\"")))?,
                    &where_,
                )?;
                let selectors = ["at", "diameter_mm", "area_mm2"]
                    .iter()
                    .filter(|k| map.contains_key(**k))
                    .count();
                if selectors != 1 {
                    return Err(err(format!(
                        "{where_}: give exactly one of \"at\", \"diameter_mm\", \"area_mm2\" (found {selectors})"
                    )));
                }
                let select = if let Some(v) = map.get("at") {
                    match v.as_array().map(Vec::len) {
                        Some(3) => {
                            let [x, y, z] = numbers::<3>(
                                v,
                                &where_,
                                "\"at\" must be [x, y] or [x, y, z] in mm",
                            )?;
                            Select::At([x, y], Some(z))
                        }
                        _ => {
                            let [x, y] = numbers::<2>(
                                v,
                                &where_,
                                "\"at\" must be [x, y] or [x, y, z] in mm",
                            )?;
                            Select::At([x, y], None)
                        }
                    }
                } else {
                    let (key, v) = map
                        .get_key_value("diameter_mm")
                        .or_else(|| map.get_key_value("area_mm2"))
                        .ok_or_else(|| err(format!("{where_}: no selector")))?;
                    let [lo, hi] =
                        numbers::<2>(v, &where_, &format!("\"{key}\" must be [min, max]"))?;
                    if !(lo >= 0.0 && hi >= lo) {
                        return Err(err(format!(
                            "{where_}: \"{key}\" [{lo}, {hi}] is not a range 0 <= min <= max"
                        )));
                    }
                    if key == "area_mm2" {
                        let d = |a: f64| 2.0 * (a / std::f64::consts::PI).sqrt();
                        Select::Diameter(d(lo), d(hi))
                    } else {
                        Select::Diameter(lo, hi)
                    }
                };
                rules.push(Rule {
                    select,
                    material: m,
                });
            }
        }
        Some(v) => {
            return Err(err(format!(
                "\"channels\" must be a list of rules, found {}",
                kind(v)
            )))
        }
    }
    Ok(MaterialMap {
        wall,
        rules,
        default,
    })
}

/// The channels of a model: for every layer, island and hole, its channel number (0 first, in
/// the order the channels first appear from the bed up) and every channel's material.
#[derive(Clone, Debug, PartialEq)]
pub struct Channels {
    /// `of[layer][island][hole]`: the channel.
    pub of: Vec<Vec<Vec<usize>>>,
    /// Each channel's material.
    pub material: Vec<Material>,
    /// Each channel's first layer and a point inside it there (for messages).
    pub first: Vec<(usize, [f64; 2])>,
    /// Each channel's layers (first, last).
    pub span: Vec<(usize, usize)>,
    /// Which rule gave each channel its material (`None`: the default).
    pub rule: Vec<Option<usize>>,
}

fn bbox(p: &[[f64; 2]]) -> ([f64; 2], [f64; 2]) {
    p.iter().fold(
        ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
        |(lo, hi), q| {
            (
                [lo[0].min(q[0]), lo[1].min(q[1])],
                [hi[0].max(q[0]), hi[1].max(q[1])],
            )
        },
    )
}

/// Whether two holes overlap seen from above: their boxes meet and a vertex or the centroid of
/// one lies inside the other.
fn overlap(a: &[[f64; 2]], b: &[[f64; 2]]) -> bool {
    let ((alo, ahi), (blo, bhi)) = (bbox(a), bbox(b));
    if alo[0] > bhi[0] || blo[0] > ahi[0] || alo[1] > bhi[1] || blo[1] > ahi[1] {
        return false;
    }
    a.iter().any(|&p| contains(b, p))
        || b.iter().any(|&p| contains(a, p))
        || contains(b, centroid(a))
        || contains(a, centroid(b))
}

/// Area centroid of a polygon.
pub fn centroid(p: &[[f64; 2]]) -> [f64; 2] {
    let n = p.len();
    let (mut cx, mut cy, mut a) = (0.0, 0.0, 0.0);
    for k in 0..n {
        let (u, v) = (p[k], p[(k + 1) % n]);
        let c = u[0] * v[1] - v[0] * u[1];
        a += c;
        cx += (u[0] + v[0]) * c;
        cy += (u[1] + v[1]) * c;
    }
    if a.abs() < 1e-18 {
        return p[0];
    }
    [cx / (3.0 * a), cy / (3.0 * a)]
}

fn find(parent: &mut [usize], mut x: usize) -> usize {
    while parent[x] != x {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    x
}

/// Tracks the holes of `layers` (each layer's islands) into channels and gives each channel
/// its material from `map`; `layer_height` places an `at` rule's `z`.
pub fn assign(
    layers: &[Vec<Island>],
    map: &MaterialMap,
    layer_height: f64,
) -> Result<Channels, ModelError> {
    // Every hole, numbered in order.
    let mut ids: Vec<Vec<Vec<usize>>> = Vec::with_capacity(layers.len());
    let mut holes: Vec<(usize, &[[f64; 2]])> = Vec::new();
    for (l, islands) in layers.iter().enumerate() {
        ids.push(
            islands
                .iter()
                .map(|isl| {
                    isl.holes
                        .iter()
                        .map(|h| {
                            holes.push((l, h));
                            holes.len() - 1
                        })
                        .collect()
                })
                .collect(),
        );
    }
    let mut parent: Vec<usize> = (0..holes.len()).collect();
    for l in 1..layers.len() {
        for &a in ids[l].iter().flatten() {
            for &b in ids[l - 1].iter().flatten() {
                if overlap(holes[a].1, holes[b].1) {
                    let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
                    if ra != rb {
                        parent[ra.max(rb)] = ra.min(rb);
                    }
                }
            }
        }
    }
    // Channels numbered by their first hole (roots are their group's lowest hole number).
    let mut channel_of_root = vec![usize::MAX; holes.len()];
    let mut members: Vec<Vec<usize>> = Vec::new();
    let mut of_hole = Vec::with_capacity(holes.len());
    for h in 0..holes.len() {
        let r = find(&mut parent, h);
        if channel_of_root[r] == usize::MAX {
            channel_of_root[r] = members.len();
            members.push(Vec::new());
        }
        of_hole.push(channel_of_root[r]);
        members[channel_of_root[r]].push(h);
    }
    let mut out = Channels {
        of: ids
            .iter()
            .map(|isl| {
                isl.iter()
                    .map(|hs| hs.iter().map(|&h| of_hole[h]).collect())
                    .collect()
            })
            .collect(),
        material: Vec::new(),
        first: Vec::new(),
        span: Vec::new(),
        rule: Vec::new(),
    };
    for (c, list) in members.iter().enumerate() {
        let (l0, first) = holes[list[0]];
        let l1 = list.iter().map(|&h| holes[h].0).max().unwrap_or(l0);
        let mut diameters: Vec<f64> = list
            .iter()
            .map(|&h| 2.0 * (super::cut::area(holes[h].1).abs() / std::f64::consts::PI).sqrt())
            .collect();
        diameters.sort_by(f64::total_cmp);
        let median = diameters[diameters.len() / 2];
        let matched = map.rules.iter().position(|r| match r.select {
            Select::At(p, None) => list.iter().any(|&h| contains(holes[h].1, p)),
            Select::At(p, Some(z)) => {
                let layer = (z / layer_height).floor();
                list.iter()
                    .any(|&h| holes[h].0 as f64 == layer && contains(holes[h].1, p))
            }
            Select::Diameter(lo, hi) => (lo..=hi).contains(&median),
        });
        let material = match (matched, map.default) {
            (Some(r), _) => map.rules[r].material,
            (None, Some(d)) => d,
            (None, None) => {
                let p = centroid(first);
                return Err(err(format!(
                    "channel {c} (from layer {l0}, around ({:.3}, {:.3}), {median:.3} mm across) matches no rule and the file has no \"default\"",
                    p[0], p[1]
                )));
            }
        };
        out.material.push(material);
        out.first.push((l0, centroid(first)));
        out.span.push((l0, l1));
        out.rule.push(matched);
    }
    Ok(out)
}
