//! Why a model could not be sliced: every fault named in the user's terms (where the open edge
//! is, which layer a contour fails in), never a panic.

use std::fmt;

/// A point in the model, mm, as printed in messages.
fn p3(p: &[f64; 3]) -> String {
    format!("({:.4}, {:.4}, {:.4})", p[0], p[1], p[2])
}

/// Why a model file could not be read, or the model could not be sliced.
#[derive(Debug)]
pub enum ModelError {
    /// The file could not be read (path, error).
    Io(String, std::io::Error),
    /// The file is larger than the limit (path, limit in bytes).
    TooLarge(String, u64),
    /// The bytes are not an STL file (why).
    NotStl(String),
    /// The file is an STL file that ends early (what was expected).
    Truncated(String),
    /// A triangle has a coordinate that is not a finite number or is out of range.
    BadCoordinate {
        /// The triangle, counted from 0 in the file.
        triangle: usize,
        /// The offending value.
        value: f32,
    },
    /// No triangle with an area is left once degenerate and repeated ones are dropped.
    Empty,
    /// An edge belongs to one face only: the model has a hole in its surface there.
    OpenEdge {
        /// One end of the edge.
        from: [f64; 3],
        /// The other end.
        to: [f64; 3],
    },
    /// An edge belongs to more than two faces: the surface does not bound one solid there.
    NonManifoldEdge {
        /// One end of the edge.
        from: [f64; 3],
        /// The other end.
        to: [f64; 3],
        /// How many faces share it.
        faces: usize,
    },
    /// A cut contour does not close (only for surfaces that are not closed).
    ChainOpen {
        /// The layer, from 0 at the bed.
        layer: usize,
        /// The cut's height, mm.
        z: f64,
        /// Where the chain stops.
        at: [f64; 2],
    },
    /// Two cut contours cross: the model holds solids that overlap (or a surface that passes
    /// through itself), which would print twice where they overlap.
    Overlap {
        /// The layer, from 0 at the bed.
        layer: usize,
        /// The cut's height, mm.
        z: f64,
        /// Where two contours cross.
        at: [f64; 2],
    },
    /// The layer height is not a positive number up to the road width.
    LayerHeight(f64),
    /// The road width is out of the core's range.
    RoadWidth(f64),
    /// The model is too tall for the layer height (layers needed, at most).
    TooManyLayers(usize, usize),
    /// The model is less than half a layer tall (its height, the layer height), mm.
    TooThin(f64, f64),
    /// A layer's contours do not make a slice the planner accepts (the core's verdict).
    Layer {
        /// The layer, from 0 at the bed.
        layer: usize,
        /// The cut's height, mm.
        z: f64,
        /// The island within the layer, from 0.
        island: usize,
        /// The core's error.
        error: hollowpath::Error,
    },
    /// A layer's roads could not be planned (the core's verdict).
    Plan {
        /// The layer, from 0 at the bed.
        layer: usize,
        /// The island within the layer, from 0.
        island: usize,
        /// The core's error.
        error: hollowpath::Error,
    },
    /// The materials file is wrong (why, naming the key).
    Materials(String),
}

impl fmt::Display for ModelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ModelError::Io(path, e) => write!(f, "cannot read {path}: {e}"),
            ModelError::TooLarge(path, limit) => write!(
                f,
                "model file {path} is larger than {}",
                crate::json_file::size(*limit)
            ),
            ModelError::NotStl(why) => write!(f, "not an STL file: {why}"),
            ModelError::Truncated(why) => write!(f, "truncated STL file: {why}"),
            ModelError::BadCoordinate { triangle, value } => write!(
                f,
                "triangle {triangle} has a coordinate {value} that is not a finite number within {} mm",
                hollowpath::config::MAX_COORD_MM
            ),
            ModelError::Empty => f.write_str("the model has no triangle with an area"),
            ModelError::OpenEdge { from, to } => write!(
                f,
                "the model is not closed: the edge from {} to {} belongs to one face only",
                p3(from),
                p3(to)
            ),
            ModelError::NonManifoldEdge { from, to, faces } => write!(
                f,
                "the model is not one solid: the edge from {} to {} belongs to {faces} faces",
                p3(from),
                p3(to)
            ),
            ModelError::ChainOpen { layer, z, at } => write!(
                f,
                "layer {layer} (z {z:.4} mm): the cut contour does not close at ({:.4}, {:.4})",
                at[0], at[1]
            ),
            ModelError::Overlap { layer, z, at } => write!(
                f,
                "layer {layer} (z {z:.4} mm): the model's surfaces cross at ({:.4}, {:.4}): it holds \
                 overlapping solids or a surface through itself; join them into one solid (a \
                 boolean union) before slicing",
                at[0], at[1]
            ),
            ModelError::LayerHeight(h) => write!(
                f,
                "layer height {h} mm is out of range ({} to {} mm)",
                hollowpath::config::MIN_ROAD_WIDTH_MM,
                hollowpath::config::MAX_ROAD_WIDTH_MM
            ),
            ModelError::RoadWidth(w) => write!(
                f,
                "road width {w} mm is out of range ({} to {} mm)",
                hollowpath::config::MIN_ROAD_WIDTH_MM,
                hollowpath::config::MAX_ROAD_WIDTH_MM
            ),
            ModelError::TooManyLayers(n, max) => write!(
                f,
                "the model needs {n} layers at this layer height, at most {max} are sliced in one run"
            ),
            ModelError::TooThin(height, h) => write!(
                f,
                "the model is {height:.4} mm tall, less than half a layer of {h} mm: nothing to print"
            ),
            ModelError::Layer {
                layer,
                z,
                island,
                error,
            } => write!(f, "layer {layer} (z {z:.4} mm), island {island}: {error}"),
            ModelError::Plan {
                layer,
                island,
                error,
            } => write!(f, "layer {layer}, island {island}: planning failed: {error}"),
            ModelError::Materials(why) => write!(f, "materials: {why}"),
        }
    }
}

impl std::error::Error for ModelError {}
