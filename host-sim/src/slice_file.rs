//! Slice files (`../shared/SLICE_FORMAT.md`): JSON on the host, converted to the core's
//! validated [`Slice`].

use std::fmt;
use std::path::Path;

use hollowpath::config::CHANNELS;
use hollowpath::geometry::Point;
use hollowpath::{FeatureId, Material, SettingId, Settings, Slice};
use serde_json::{Map, Value};

use crate::json_file::{self, kind, ReadError};

/// Why a slice file could not be turned into a slice.
#[derive(Debug)]
pub enum SliceFileError {
    /// The file could not be read.
    Io(String, std::io::Error),
    /// The text is not valid JSON, or not of the slice format's shape.
    Json(serde_json::Error),
    /// A value the JSON carries that the format does not allow.
    Format(String),
    /// The slice itself is invalid (the core's verdict).
    Slice(hollowpath::Error),
    /// The file is larger than the limit (path, limit in bytes).
    TooLarge(String, u64),
}

impl fmt::Display for SliceFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SliceFileError::Io(path, e) => write!(f, "cannot read {path}: {e}"),
            SliceFileError::Json(e) => match e.classify() {
                serde_json::error::Category::Eof => {
                    write!(f, "truncated slice file: the JSON ends early ({e})")
                }
                serde_json::error::Category::Syntax => write!(f, "malformed JSON: {e}"),
                _ => write!(f, "not a slice file: {e}"),
            },
            SliceFileError::Format(s) => f.write_str(s),
            SliceFileError::Slice(e) => write!(f, "invalid slice: {e}"),
            SliceFileError::TooLarge(path, limit) => {
                write!(
                    f,
                    "slice file {path} is larger than {}",
                    json_file::size(*limit)
                )
            }
        }
    }
}

impl std::error::Error for SliceFileError {}

impl From<hollowpath::Error> for SliceFileError {
    fn from(e: hollowpath::Error) -> Self {
        SliceFileError::Slice(e)
    }
}

/// A slice read from a file, with its name.
#[derive(Clone, Debug)]
pub struct SliceFile {
    /// `name` from the file (or empty).
    pub name: String,
    /// The validated slice.
    pub slice: Slice,
}

/// The largest slice file read (64 MiB): far more than [`MAX_HOLES`] polygons of
/// [`MAX_VERTICES`] points need, and small enough that an endless input (`/dev/zero`) is
/// refused before it fills memory.
///
/// [`MAX_HOLES`]: hollowpath::config::MAX_HOLES
/// [`MAX_VERTICES`]: hollowpath::config::MAX_VERTICES
pub const MAX_FILE_BYTES: u64 = 64 << 20;

/// Reads and validates a slice file of at most [`MAX_FILE_BYTES`].
pub fn load(path: &Path) -> Result<SliceFile, SliceFileError> {
    load_with_limit(path, MAX_FILE_BYTES)
}

/// Reads and validates a slice file of at most `limit` bytes, reading no more than that.
pub fn load_with_limit(path: &Path, limit: u64) -> Result<SliceFile, SliceFileError> {
    parse(&read(path, limit)?)
}

fn read(path: &Path, limit: u64) -> Result<String, SliceFileError> {
    let shown = path.display().to_string();
    json_file::read_text(path, limit).map_err(|e| match e {
        ReadError::Io(e) => SliceFileError::Io(shown.clone(), e),
        ReadError::TooLarge(limit) => SliceFileError::TooLarge(shown.clone(), limit),
        ReadError::NotUtf8(at) => SliceFileError::Format(format!(
            "slice file {shown} is not UTF-8 text (invalid byte at offset {at})"
        )),
    })
}

const TOP_KEYS: &[&str] = &["name", "description", "units", "outer", "holes", "settings"];
const FEATURE_KEYS: &[&str] = &["points", "material"];
const SETTING_KEYS: &[&str] = &[
    "road_width",
    "layer_height",
    "w_n",
    "w_d",
    "delta",
    "mcl_spacing",
    "relax_iterations",
    "relax_spacing",
    "min_width",
    "max_width",
    "simplify_tolerance",
];

fn format_err(s: String) -> SliceFileError {
    SliceFileError::Format(s)
}

/// The object `v`, every key of it one of `allowed`.
fn object<'a>(
    v: &'a Value,
    what: &str,
    where_: &str,
    allowed: &[&str],
) -> Result<&'a Map<String, Value>, SliceFileError> {
    let Value::Object(map) = v else {
        return Err(format_err(format!(
            "{what} must be a JSON object {{...}}, found {}",
            kind(v)
        )));
    };
    if let Some(k) = map.keys().find(|k| !allowed.contains(&k.as_str())) {
        return Err(format_err(format!(
            "unknown key \"{k}\" {where_}; expected one of {}",
            allowed.join(", ")
        )));
    }
    Ok(map)
}

fn required<'a>(
    map: &'a Map<String, Value>,
    key: &str,
    where_: &str,
) -> Result<&'a Value, SliceFileError> {
    map.get(key)
        .ok_or_else(|| format_err(format!("missing key \"{key}\" {where_}")))
}

/// A slice file's contours as written, before the core validated them (`hollowpath print
/// --no-check` sends them so, for the controller's own verdict).
#[derive(Clone, Debug)]
pub struct Contours {
    /// `name` from the file (or empty).
    pub name: String,
    /// The wall's points and material.
    pub wall: (Vec<Point>, Material),
    /// Each hole's points and material.
    pub holes: Vec<(Vec<Point>, Material)>,
    /// The settings.
    pub settings: Settings,
}

impl Contours {
    /// The holes as the core's [`Slice::from_contours`] and the link's upload take them.
    pub fn hole_refs(&self) -> Vec<(&[Point], Material)> {
        self.holes.iter().map(|(p, m)| (&p[..], *m)).collect()
    }
}

/// Parses and validates slice JSON (a UTF-8 byte-order mark at the start is ignored).
pub fn parse(text: &str) -> Result<SliceFile, SliceFileError> {
    let c = parse_contours(text)?;
    // Contours of more than SIMPLIFY_ABOVE_VERTICES vertices are simplified in the core.
    let slice = Slice::from_contours(&c.wall.0, c.wall.1, &c.hole_refs(), c.settings)?;
    Ok(SliceFile {
        name: c.name,
        slice,
    })
}

/// Reads a slice file's contours (at most [`MAX_FILE_BYTES`]) without validating the slice.
pub fn load_contours(path: &Path) -> Result<Contours, SliceFileError> {
    parse_contours(&read(path, MAX_FILE_BYTES)?)
}

/// Parses slice JSON into its contours and settings: the format checked, the slice not.
pub fn parse_contours(text: &str) -> Result<Contours, SliceFileError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let doc: Value = crate::json_file::parse_unique(text).map_err(|e| {
        if json_file::at_non_finite(text, e.line(), e.column()) {
            SliceFileError::Format(format!(
                "malformed JSON: {e}: NaN and infinities are not JSON numbers; every coordinate \
                 and setting is a finite number"
            ))
        } else {
            SliceFileError::Json(e)
        }
    })?;
    let top = object(&doc, "a slice file", "at the top level", TOP_KEYS)?;
    let mut strings = [None, None, None];
    for (slot, key) in strings.iter_mut().zip(["name", "description", "units"]) {
        match top.get(key) {
            None => {}
            Some(Value::String(s)) => *slot = Some(s.clone()),
            Some(v) => {
                return Err(format_err(format!(
                    "\"{key}\" must be a string, found {}",
                    kind(v)
                )))
            }
        }
    }
    let [name, _description, units] = strings;
    if let Some(u) = &units {
        if u != "mm" {
            return Err(SliceFileError::Format(format!(
                "units \"{u}\" are not supported: slice files are in mm"
            )));
        }
    }
    let outer = required(top, "outer", "at the top level")?;
    let holes = required(top, "holes", "at the top level")?;
    let Value::Array(holes) = holes else {
        return Err(format_err(format!(
            "\"holes\" must be a list of features, found {}",
            kind(holes)
        )));
    };
    let settings = settings(top.get("settings"))?;
    let wall = feature(FeatureId::Wall, outer)?;
    let mut features = Vec::with_capacity(holes.len().min(hollowpath::config::MAX_HOLES));
    for (i, h) in holes.iter().enumerate() {
        let id = FeatureId::Hole(u8::try_from(i).unwrap_or(u8::MAX));
        if i >= hollowpath::config::MAX_HOLES {
            return Err(hollowpath::Error::TooManyHoles {
                holes: u32::try_from(holes.len()).unwrap_or(u32::MAX),
            }
            .into());
        }
        features.push(feature(id, h)?);
    }
    Ok(Contours {
        name: name.unwrap_or_default(),
        wall,
        holes: features,
        settings,
    })
}

fn settings(v: Option<&Value>) -> Result<Settings, SliceFileError> {
    let Some(v) = v else {
        return Ok(Settings::default());
    };
    let map = object(v, "\"settings\"", "in settings", SETTING_KEYS)?;
    let number = |id: SettingId| -> Result<Option<f64>, SliceFileError> {
        match map.get(id.key()) {
            None => Ok(None),
            Some(Value::Number(n)) => Ok(n.as_f64()),
            Some(v) => Err(format_err(format!(
                "setting {}: expected a number ({}), found {}",
                id.key(),
                id.allowed(),
                kind(v)
            ))),
        }
    };
    let out_of_range = |id: SettingId, x: f64| hollowpath::Error::InvalidSetting {
        setting: id,
        value: x as f32,
    };
    // A value beyond f32 is out of range, not infinite.
    let float = |id: SettingId| -> Result<Option<f32>, SliceFileError> {
        match number(id)? {
            // (Said here: the core's error holds an f32, which would say `inf`.)
            Some(x) if x.abs() > f32::MAX as f64 => Err(format_err(format!(
                "setting {}: {x:e} is out of range ({})",
                id.key(),
                id.allowed()
            ))),
            x => Ok(x.map(|x| x as f32)),
        }
    };
    let road = float(SettingId::RoadWidth)?.unwrap_or(hollowpath::config::defaults::ROAD_WIDTH);
    let mut s = Settings::for_road_width(road);
    for (id, dst) in [
        (SettingId::LayerHeight, &mut s.layer_height),
        (SettingId::WeightNormal, &mut s.w_n),
        (SettingId::WeightDistance, &mut s.w_d),
        (SettingId::Delta, &mut s.delta),
        (SettingId::MclSpacing, &mut s.mcl_spacing),
        (SettingId::RelaxSpacing, &mut s.relax_spacing),
        (SettingId::MinWidth, &mut s.min_width),
        (SettingId::MaxWidth, &mut s.max_width),
        (SettingId::SimplifyTolerance, &mut s.simplify_tolerance),
    ] {
        if let Some(x) = float(id)? {
            *dst = x;
        }
    }
    if let Some(x) = number(SettingId::RelaxIterations)? {
        let max = hollowpath::config::MAX_RELAX_ITERATIONS;
        if x.fract() != 0.0 || !(0.0..=max as f64).contains(&x) {
            return Err(out_of_range(SettingId::RelaxIterations, x).into());
        }
        s.relax_iterations = x as u8;
    }
    Ok(s)
}

/// The points and material of one contour, checked for shape (the core checks the rest).
fn feature(id: FeatureId, v: &Value) -> Result<(Vec<Point>, Material), SliceFileError> {
    let map = object(v, &id.to_string(), &format!("in {id}"), FEATURE_KEYS)?;
    let where_ = format!("in {id}");
    let Value::Array(material_v) = required(map, "material", &where_)? else {
        return Err(format_err(format!(
            "{id}: material must be a list of fractions, found {}",
            kind(&map["material"])
        )));
    };
    if material_v.len() > CHANNELS {
        return Err(SliceFileError::Format(format!(
            "{id}: material has {} fractions, the printer has {CHANNELS} channels",
            material_v.len()
        )));
    }
    let mut material: Material = [0.0; CHANNELS];
    for (c, (m, x)) in material.iter_mut().zip(material_v).enumerate() {
        let Some(x) = x.as_f64() else {
            return Err(format_err(format!(
                "{id}: material fraction {c} is not a number (found {})",
                kind(x)
            )));
        };
        *m = x as f32;
    }
    let Value::Array(points_v) = required(map, "points", &where_)? else {
        return Err(format_err(format!(
            "{id}: points must be a list of [x, y] pairs, found {}",
            kind(&map["points"])
        )));
    };
    let mut points: Vec<Point> = Vec::with_capacity(points_v.len().min(1 << 16));
    let max = hollowpath::config::MAX_COORD_MM as f64;
    for (k, p) in points_v.iter().enumerate() {
        let Value::Array(p) = p else {
            return Err(format_err(format!(
                "{id}: point {k} must be an [x, y] pair, found {}",
                kind(p)
            )));
        };
        let [x, y] = &p[..] else {
            return Err(SliceFileError::Format(format!(
                "{id}: point {k} has {} coordinates, expected [x, y]",
                p.len()
            )));
        };
        let mut xy = [0.0f32; 2];
        for (dst, (axis, c)) in xy.iter_mut().zip([("x", x), ("y", y)]) {
            let Some(c) = c.as_f64() else {
                return Err(format_err(format!(
                    "{id}: point {k}: {axis} is not a number (found {})",
                    kind(c)
                )));
            };
            // Checked before narrowing to f32, where 1e308 would turn infinite.
            if c.abs() > max {
                return Err(hollowpath::Error::OutOfRange {
                    feature: id,
                    vertex: k.min(u16::MAX as usize) as u16,
                }
                .into());
            }
            *dst = c as f32;
        }
        points.push(Point::new(xy[0], xy[1]));
    }
    Ok((points, material))
}

/// The slice file of `slice` (`../shared/SLICE_FORMAT.md`): its wall and holes as the core
/// holds them (counter-clockwise), their materials, and its road width and layer height; the
/// other settings are the defaults for that road width, which [`parse`] gives them back.
/// Reading it back gives the same slice.
pub fn to_json(name: &str, description: &str, slice: &Slice) -> String {
    let feature = |f: &hollowpath::Feature| {
        serde_json::json!({
            "points": f.points().iter().map(|p| [p.x, p.y]).collect::<Vec<_>>(),
            "material": f.material(),
        })
    };
    let s = slice.settings();
    let doc = serde_json::json!({
        "name": name,
        "description": description,
        "units": "mm",
        "outer": feature(slice.wall()),
        "holes": slice.holes().iter().map(feature).collect::<Vec<_>>(),
        "settings": { "road_width": s.road_width, "layer_height": s.layer_height },
    });
    serde_json::to_string_pretty(&doc).unwrap_or_default()
}
