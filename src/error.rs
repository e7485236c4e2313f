//! The one error type of the core.

use core::fmt;

use serde::{Deserialize, Serialize};

/// Which feature of a slice an error is about.
///
/// ```
/// use hollowpath::FeatureId;
/// assert_eq!(format!("{}", FeatureId::Hole(2)), "hole 2");
/// assert_eq!(format!("{}", FeatureId::Wall), "the wall");
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FeatureId {
    /// The outer wall.
    Wall,
    /// Hollow feature `i`, counted from 0 in the order of the slice file.
    Hole(u8),
}

impl fmt::Display for FeatureId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FeatureId::Wall => f.write_str("the wall"),
            FeatureId::Hole(i) => write!(f, "hole {i}"),
        }
    }
}

/// A setting of the slice, named in [`Error::InvalidSetting`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SettingId {
    /// `road_width`
    RoadWidth,
    /// `layer_height`
    LayerHeight,
    /// `w_n`
    WeightNormal,
    /// `w_d`
    WeightDistance,
    /// `delta`
    Delta,
    /// `mcl_spacing`
    MclSpacing,
    /// `relax_spacing`
    RelaxSpacing,
    /// `min_width`
    MinWidth,
    /// `max_width`
    MaxWidth,
    /// `relax_iterations`
    RelaxIterations,
    /// `simplify_tolerance`
    SimplifyTolerance,
}

impl SettingId {
    /// The key of the setting in a slice file.
    pub const fn key(self) -> &'static str {
        match self {
            SettingId::RoadWidth => "road_width",
            SettingId::LayerHeight => "layer_height",
            SettingId::WeightNormal => "w_n",
            SettingId::WeightDistance => "w_d",
            SettingId::Delta => "delta",
            SettingId::MclSpacing => "mcl_spacing",
            SettingId::RelaxSpacing => "relax_spacing",
            SettingId::MinWidth => "min_width",
            SettingId::MaxWidth => "max_width",
            SettingId::RelaxIterations => "relax_iterations",
            SettingId::SimplifyTolerance => "simplify_tolerance",
        }
    }
}

impl SettingId {
    /// The values the setting allows, in words (as [`Settings`](crate::Settings) checks them).
    pub const fn allowed(self) -> &'static str {
        match self {
            SettingId::RoadWidth => "0.01 to 10 mm",
            SettingId::LayerHeight => "0.01 to 10 mm",
            SettingId::WeightNormal | SettingId::WeightDistance => "0 to 16",
            SettingId::Delta => "a finite number of mm, more than 0",
            SettingId::MclSpacing => "0.25 to 4 road widths",
            SettingId::RelaxSpacing => "more than 0, at most 4 road widths",
            SettingId::MinWidth => "more than 0, at most the road width",
            SettingId::MaxWidth => "the road width to 3 road widths",
            SettingId::RelaxIterations => "a whole number from 0 to 64",
            SettingId::SimplifyTolerance => "0 to a tenth of the road width, mm",
        }
    }
}

/// A fixed capacity of the core (see [`config`](crate::config)), named in [`Error::Capacity`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Limit {
    /// [`MAX_HOLES`](crate::config::MAX_HOLES)
    Holes,
    /// [`MAX_VERTICES`](crate::config::MAX_VERTICES)
    Vertices,
    /// [`GRID_NODES`](crate::config::GRID_NODES)
    GridNodes,
    /// [`BOUNDARY_NODES`](crate::config::BOUNDARY_NODES)
    BoundaryNodes,
    /// [`MAX_BISECTORS`](crate::config::MAX_BISECTORS)
    Bisectors,
    /// [`BISECTOR_POINTS`](crate::config::BISECTOR_POINTS)
    BisectorPoints,
    /// [`MAX_BRANCH_POINTS`](crate::config::MAX_BRANCH_POINTS)
    BranchPoints,
    /// [`BISECTOR_SEEDS`](crate::config::BISECTOR_SEEDS)
    BisectorSeeds,
    /// [`MAX_HALVES`](crate::config::MAX_HALVES)
    Halves,
    /// [`TRACE_POINTS`](crate::config::TRACE_POINTS)
    TracePoints,
    /// [`HALF_POINTS`](crate::config::HALF_POINTS)
    HalfPoints,
    /// [`MAX_MCLS`](crate::config::MAX_MCLS)
    Mcls,
    /// [`PATH_VERTICES`](crate::config::PATH_VERTICES): the capacity of the sink a layer is
    /// written into.
    PathVertices,
    /// [`CONTOUR_POINTS`](crate::config::CONTOUR_POINTS)
    ContourPoints,
    /// [`MAX_LOOPS`](crate::config::MAX_LOOPS)
    ContourLoops,
    /// [`MAX_SITES`](crate::config::MAX_SITES)
    ContourSites,
    /// [`HALF_POOL_POINTS`](crate::config::HALF_POOL_POINTS)
    HalfPoolPoints,
}

impl Limit {
    /// The configured value of the limit.
    pub const fn value(self) -> usize {
        use crate::config::*;
        match self {
            Limit::Holes => MAX_HOLES,
            Limit::Vertices => MAX_VERTICES,
            Limit::GridNodes => GRID_NODES,
            Limit::BoundaryNodes => BOUNDARY_NODES,
            Limit::Bisectors => MAX_BISECTORS,
            Limit::BisectorPoints => BISECTOR_POINTS,
            Limit::BranchPoints => MAX_BRANCH_POINTS,
            Limit::BisectorSeeds => BISECTOR_SEEDS,
            Limit::Halves => MAX_HALVES,
            Limit::TracePoints => TRACE_POINTS,
            Limit::HalfPoints => HALF_POINTS,
            Limit::Mcls => MAX_MCLS,
            Limit::PathVertices => PATH_VERTICES,
            Limit::ContourPoints => CONTOUR_POINTS,
            Limit::ContourLoops => MAX_LOOPS,
            Limit::ContourSites => MAX_SITES,
            Limit::HalfPoolPoints => HALF_POOL_POINTS,
        }
    }

    /// The [`Error::Capacity`] of this limit, with no feature named.
    pub(crate) const fn error(self) -> Error {
        Error::Capacity {
            limit: self,
            feature: None,
        }
    }

    /// What to change in the slice or its settings to plan within this limit.
    const fn remedy(self) -> &'static str {
        match self {
            Limit::Holes => "merge or leave out hollow features, or split the slice",
            Limit::Vertices => "simplify the contour (raise simplify_tolerance) or split the slice",
            Limit::GridNodes | Limit::BoundaryNodes | Limit::PathVertices => {
                "use a wider road_width or split the slice"
            }
            Limit::Bisectors
            | Limit::BisectorPoints
            | Limit::BranchPoints
            | Limit::BisectorSeeds => {
                "use fewer hollow features or smoother outlines (raise \
                 simplify_tolerance), or split the slice"
            }
            Limit::Halves | Limit::Mcls | Limit::HalfPoolPoints => {
                "use a wider road_width (fewer MCLs) or fewer hollow features, or split the slice"
            }
            Limit::TracePoints | Limit::HalfPoints => {
                "an outline too winding for an MCL to follow from it: smooth it (raise \
                 simplify_tolerance, or fewer, blunter spikes) or use a wider road_width"
            }
            Limit::ContourPoints | Limit::ContourLoops | Limit::ContourSites => {
                "use a wider road_width or smoother outlines, or split the slice"
            }
        }
    }

    const fn what(self) -> &'static str {
        match self {
            Limit::Holes => "hollow features",
            Limit::Vertices => "vertices in one polygon",
            Limit::GridNodes => "field grid nodes",
            Limit::BoundaryNodes => "field nodes next to a boundary",
            Limit::Bisectors => "bisector pieces",
            Limit::BisectorPoints => "points in one bisector",
            Limit::BranchPoints => "branch points",
            Limit::BisectorSeeds => "bisector seeds",
            Limit::Halves => "traced MCL halves",
            Limit::TracePoints => "points in one traced MCL",
            Limit::HalfPoints => "points in one simplified MCL half",
            Limit::Mcls => "material changing lines",
            Limit::PathVertices => "vertices in one layer's path",
            Limit::ContourPoints => "points of the offset spiral's loops",
            Limit::ContourLoops => "loops of the offset spiral",
            Limit::ContourSites => "side-by-side pairs of the offset spiral's loops",
            Limit::HalfPoolPoints => "points of all the MCL halves",
        }
    }
}

/// Everything that can go wrong between a slice and its plan.
///
/// Small and `Copy`; [`Display`](core::fmt::Display) gives the one-line reason the host tool
/// prints.
///
/// ```
/// use hollowpath::{Error, FeatureId};
/// let e = Error::TooFewPoints { feature: FeatureId::Hole(1), distinct: 2 };
/// assert_eq!(e.to_string(), "hole 1: only 2 distinct points, a polygon needs at least 3");
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Error {
    /// A polygon has fewer than three distinct points.
    TooFewPoints {
        /// The polygon.
        feature: FeatureId,
        /// How many distinct points it has.
        distinct: u16,
    },
    /// A coordinate is NaN or infinite.
    NonFinite {
        /// The polygon.
        feature: FeatureId,
        /// Index of the vertex in the input.
        vertex: u16,
    },
    /// A coordinate is beyond [`MAX_COORD_MM`](crate::config::MAX_COORD_MM).
    OutOfRange {
        /// The polygon.
        feature: FeatureId,
        /// Index of the vertex in the input.
        vertex: u16,
    },
    /// A polygon encloses (almost) no area.
    ZeroArea {
        /// The polygon.
        feature: FeatureId,
    },
    /// Two edges of one polygon cross or touch.
    SelfIntersection {
        /// The polygon.
        feature: FeatureId,
        /// First edge (from vertex `edge_a` to the next).
        edge_a: u16,
        /// Second edge.
        edge_b: u16,
    },
    /// A vertex of a hollow feature lies on or outside the wall.
    HoleOutsideWall {
        /// The hollow feature.
        hole: u8,
        /// The vertex outside.
        vertex: u16,
    },
    /// An edge of a hollow feature crosses or touches the wall.
    HoleCrossesWall {
        /// The hollow feature.
        hole: u8,
        /// Its edge that meets the wall.
        edge: u16,
        /// The wall's edge.
        wall_edge: u16,
    },
    /// Two hollow features cross or touch.
    HolesOverlap {
        /// The first feature.
        a: u8,
        /// The second feature.
        b: u8,
    },
    /// A hollow feature lies inside another one.
    HolesNested {
        /// The enclosing feature.
        outer: u8,
        /// The enclosed feature.
        inner: u8,
    },
    /// A material fraction is negative or not finite.
    MaterialNegative {
        /// The feature.
        feature: FeatureId,
        /// The channel.
        channel: u8,
    },
    /// Material fractions do not sum to 1.
    MaterialSum {
        /// The feature.
        feature: FeatureId,
        /// What they sum to.
        sum: f32,
    },
    /// A setting is out of its range.
    InvalidSetting {
        /// The setting.
        setting: SettingId,
        /// The offending value.
        value: f32,
    },
    /// The slice has no hollow feature: there is nothing to decompose into cells, so no MCL
    /// layer (zigzag, MCL spiral) can be laid; the offset spiral lays such a slice from the
    /// wall inwards.
    NoHoles,
    /// No material changing line fits between a hollow feature and its cell boundary (the
    /// printable region around it is too thin for a road, or every line was removed).
    NoRoom {
        /// The hollow feature.
        hole: u8,
    },
    /// A polygon has more vertices than [`MAX_VERTICES`](crate::config::MAX_VERTICES).
    TooManyVertices {
        /// The polygon.
        feature: FeatureId,
        /// How many distinct consecutive vertices it was given.
        vertices: u32,
        /// Whether it had been simplified (and still has too many).
        simplified: bool,
    },
    /// The slice has more hollow features than [`MAX_HOLES`](crate::config::MAX_HOLES).
    TooManyHoles {
        /// How many it was given.
        holes: u32,
    },
    /// The slice is too large for a grid at its road width: at the coarsest spacing the road
    /// allows ([`MAX_GRID_SPACING_PER_ROAD`](crate::config::MAX_GRID_SPACING_PER_ROAD)), the
    /// grid would need more nodes than its capacity
    /// ([`GRID_NODES`](crate::config::GRID_NODES)).
    SliceTooLarge {
        /// Width of the wall's bounding box, mm.
        width: f32,
        /// Height of the wall's bounding box, mm.
        height: f32,
        /// The road width, mm.
        road_width: f32,
        /// Side of the largest square the grid holds at this road width, mm.
        holds: f32,
        /// The offset spiral's distance grid (else the planner's field grid).
        spiral: bool,
    },
    /// A fixed capacity was exceeded.
    Capacity {
        /// Which capacity.
        limit: Limit,
        /// The feature concerned, where there is one.
        feature: Option<FeatureId>,
    },
    /// No turn of road fits inside the wall: the region half a road inside it is too small
    /// to lay even one turn (a slice narrower than about a road). (Last: the link's messages
    /// number the variants.)
    WallNoRoom,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Error::TooFewPoints { feature, distinct } => write!(
                f,
                "{feature}: only {distinct} distinct point{}, a polygon needs at least 3",
                if distinct == 1 { "" } else { "s" }
            ),
            Error::NonFinite { feature, vertex } => {
                write!(f, "{feature}: vertex {vertex} has a coordinate that is not a finite number")
            }
            Error::OutOfRange { feature, vertex } => write!(
                f,
                "{feature}: vertex {vertex} has a coordinate out of range (coordinates must lie from -{0} to {0} mm)",
                crate::config::MAX_COORD_MM
            ),
            Error::ZeroArea { feature } => write!(
                f,
                "{feature}: the polygon encloses no area (less than a square micrometre)"
            ),
            Error::SelfIntersection { feature, edge_a, edge_b } => write!(
                f,
                "{feature}: edges {edge_a} and {edge_b} intersect (self-intersecting polygon)"
            ),
            Error::HoleOutsideWall { hole, vertex } => write!(
                f,
                "hole {hole}: vertex {vertex} is not strictly inside the wall"
            ),
            Error::HoleCrossesWall { hole, edge, wall_edge } => write!(
                f,
                "hole {hole}: edge {edge} meets wall edge {wall_edge} (not strictly inside the wall)"
            ),
            Error::HolesOverlap { a, b } => write!(f, "holes {a} and {b} overlap or touch"),
            Error::HolesNested { outer, inner } => {
                write!(f, "hole {inner} lies inside hole {outer} (nested holes)")
            }
            Error::MaterialNegative { feature, channel } => write!(
                f,
                "{feature}: material fraction of channel {channel} is negative or not finite"
            ),
            Error::MaterialSum { feature, sum } => {
                write!(f, "{feature}: material fractions sum to {sum}, not 1")
            }
            Error::InvalidSetting { setting, value } => {
                write!(
                    f,
                    "setting {}: {value} is out of range (allowed: {})",
                    setting.key(),
                    setting.allowed()
                )
            }
            Error::NoHoles => f.write_str(
                "the slice has no hollow feature to lay MCLs from (the offset spiral lays it)",
            ),
            Error::NoRoom { hole } => write!(
                f,
                "hole {hole}: no material changing line fits between it and its cell boundary (too little room for a road)"
            ),
            Error::TooManyVertices {
                feature,
                vertices,
                simplified: false,
            } => write!(
                f,
                "{feature} has {vertices} vertices; at most {}: simplify the polygon or split the feature",
                crate::config::MAX_VERTICES
            ),
            Error::TooManyVertices {
                feature,
                vertices,
                simplified: true,
            } => write!(
                f,
                "{feature} has more than {} vertices after simplification ({vertices} given): raise simplify_tolerance or split the feature",
                crate::config::MAX_VERTICES
            ),
            Error::TooManyHoles { holes } => write!(
                f,
                "the slice has {holes} hollow features; at most {}: split the slice",
                crate::config::MAX_HOLES
            ),
            Error::SliceTooLarge {
                width,
                height,
                road_width,
                holds,
                spiral,
            } => write!(
                f,
                "the slice is {width:.1} x {height:.1} mm; at road_width {road_width} the {} holds {holds:.1} x {holds:.1} mm: use a coarser road or split the slice",
                if spiral {
                    "offset spiral's grid"
                } else {
                    "field grid"
                }
            ),
            Error::WallNoRoom => f.write_str(
                "the wall: no road fits inside it (the slice is about a road wide or \
                 narrower): use a narrower road_width, or leave this slice out",
            ),
            Error::Capacity { limit, feature } => {
                if let Some(feature) = feature {
                    write!(f, "{feature}: ")?;
                }
                write!(
                    f,
                    "capacity exceeded: more than {} {}: {}",
                    limit.value(),
                    limit.what(),
                    limit.remedy()
                )
            }
        }
    }
}

impl core::error::Error for Error {}
