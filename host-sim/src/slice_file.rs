//! Slice files (`../shared/SLICE_FORMAT.md`): JSON on the host, converted to the core's
//! validated [`Slice`].

use std::fmt;
use std::path::Path;

use hollowpath::config::CHANNELS;
use hollowpath::geometry::Point;
use hollowpath::{FeatureId, Material, Settings, Slice};
use serde::Deserialize;

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
        }
    }
}

impl std::error::Error for SliceFileError {}

impl From<hollowpath::Error> for SliceFileError {
    fn from(e: hollowpath::Error) -> Self {
        SliceFileError::Slice(e)
    }
}

#[derive(Deserialize)]
struct FileFeature {
    points: Vec<Vec<f64>>,
    material: Vec<f64>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct FileSettings {
    road_width: Option<f64>,
    layer_height: Option<f64>,
    w_n: Option<f64>,
    w_d: Option<f64>,
    delta: Option<f64>,
    mcl_spacing: Option<f64>,
    relax_iterations: Option<u8>,
    relax_spacing: Option<f64>,
    min_width: Option<f64>,
    max_width: Option<f64>,
    simplify_tolerance: Option<f64>,
}

#[derive(Deserialize)]
struct FileSlice {
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    units: Option<String>,
    outer: FileFeature,
    holes: Vec<FileFeature>,
    #[serde(default)]
    settings: FileSettings,
}

/// A slice read from a file, with its name.
#[derive(Clone, Debug)]
pub struct SliceFile {
    /// `name` from the file (or empty).
    pub name: String,
    /// The validated slice.
    pub slice: Slice,
}

/// Reads and validates a slice file.
pub fn load(path: &Path) -> Result<SliceFile, SliceFileError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| SliceFileError::Io(path.display().to_string(), e))?;
    parse(&text)
}

/// Parses and validates slice JSON.
pub fn parse(text: &str) -> Result<SliceFile, SliceFileError> {
    let file: FileSlice = serde_json::from_str(text).map_err(SliceFileError::Json)?;
    if let Some(u) = &file.units {
        if u != "mm" {
            return Err(SliceFileError::Format(format!(
                "units \"{u}\" are not supported: slice files are in mm"
            )));
        }
    }
    let s = &file.settings;
    let mut settings = Settings::for_road_width(
        s.road_width
            .unwrap_or(hollowpath::config::defaults::ROAD_WIDTH as f64) as f32,
    );
    let set = |v: Option<f64>, dst: &mut f32| {
        if let Some(v) = v {
            *dst = v as f32;
        }
    };
    set(s.layer_height, &mut settings.layer_height);
    set(s.w_n, &mut settings.w_n);
    set(s.w_d, &mut settings.w_d);
    set(s.delta, &mut settings.delta);
    set(s.mcl_spacing, &mut settings.mcl_spacing);
    set(s.relax_spacing, &mut settings.relax_spacing);
    set(s.min_width, &mut settings.min_width);
    set(s.max_width, &mut settings.max_width);
    set(s.simplify_tolerance, &mut settings.simplify_tolerance);
    if let Some(n) = s.relax_iterations {
        settings.relax_iterations = n;
    }
    let wall = contour(FeatureId::Wall, &file.outer)?;
    let mut holes = Vec::with_capacity(file.holes.len());
    for (i, h) in file.holes.iter().enumerate() {
        let id = FeatureId::Hole(u8::try_from(i).unwrap_or(u8::MAX));
        if i >= hollowpath::config::MAX_HOLES {
            return Err(hollowpath::Error::TooManyHoles {
                holes: u32::try_from(file.holes.len()).unwrap_or(u32::MAX),
            }
            .into());
        }
        holes.push(contour(id, h)?);
    }
    let refs: Vec<(&[Point], Material)> = holes.iter().map(|(p, m)| (&p[..], *m)).collect();
    // Contours of more than SIMPLIFY_ABOVE_VERTICES vertices are simplified in the core.
    let slice = Slice::from_contours(&wall.0, wall.1, &refs, settings)?;
    Ok(SliceFile {
        name: file.name.unwrap_or_default(),
        slice,
    })
}

/// The points and material of one contour, checked for shape (the core checks the rest).
fn contour(id: FeatureId, f: &FileFeature) -> Result<(Vec<Point>, Material), SliceFileError> {
    if f.material.len() > CHANNELS {
        return Err(SliceFileError::Format(format!(
            "{id}: material has {} fractions, the printer has {CHANNELS} channels",
            f.material.len()
        )));
    }
    let mut material: Material = [0.0; CHANNELS];
    for (m, &x) in material.iter_mut().zip(&f.material) {
        *m = x as f32;
    }
    let mut points: Vec<Point> = Vec::with_capacity(f.points.len());
    for (k, p) in f.points.iter().enumerate() {
        let [x, y] = p[..] else {
            return Err(SliceFileError::Format(format!(
                "{id}: point {k} has {} coordinates, expected [x, y]",
                p.len()
            )));
        };
        points.push(Point::new(x as f32, y as f32));
    }
    Ok((points, material))
}
