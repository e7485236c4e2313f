//! The layers of a print: zigzag and spiral alternating along the MCLs (or the raster
//! baseline), each a path of vertices from the core's generators.

use hollowpath::field::GridMemory;
use hollowpath::toolpath::offset::OffsetSpiral;
use hollowpath::toolpath::spiral::{spiral, ControlFunction};
use hollowpath::toolpath::zigzag::zigzag;
use hollowpath::toolpath::{raster::raster, Pattern, Vertex};
use hollowpath::{Error, Plan, Slice};

/// The most layers one run builds (`--layers`): every layer is held in memory and previewed
/// before anything is written, so the count is bounded (1000 layers of 0.3 mm is 300 mm).
pub const MAX_LAYERS: usize = 1000;

/// What fills the layers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fill {
    /// Zigzag on even layers, spiral (with this control function) on odd ones.
    Mcl(ControlFunction),
    /// Zigzag on even layers, the offset spiral (turns a road width apart, one closed road)
    /// on odd ones.
    Offset,
    /// The Cartesian raster baseline on every layer (45 and 135 degrees alternating).
    Raster,
}

/// One layer: its index (0 first), pattern, path and a line about how it was built.
#[derive(Clone, Debug)]
pub struct Layer {
    /// Index from the bed up.
    pub index: usize,
    /// Its pattern.
    pub pattern: Pattern,
    /// The path.
    pub path: Vec<Vertex>,
    /// How the generator fared (pieces, jumps, turns).
    pub note: String,
}

/// Builds layer `index` of `fill`. A slice without holes (a cap) has no MCLs to lay a zigzag
/// or an MCL spiral along: every one of its layers is the offset spiral, from the wall inwards.
pub fn layer(slice: &Slice, plan: &Plan, fill: Fill, index: usize) -> Result<Layer, Error> {
    let mut path = Vec::new();
    let fill = if slice.holes().is_empty() && fill != Fill::Raster {
        Fill::Offset
    } else {
        fill
    };
    let wall_only = slice.holes().is_empty() && fill == Fill::Offset;
    let (pattern, note) = match fill {
        Fill::Raster => {
            raster(slice, plan, index, &mut path)?;
            (Pattern::Raster, String::from("raster baseline"))
        }
        Fill::Mcl(_) | Fill::Offset if index % 2 == 0 && !wall_only => {
            let s = zigzag(slice, plan, &mut path)?;
            (
                Pattern::Zigzag,
                format!(
                    "zigzag: {} piece(s) after splicing {} loops and bridging {} across a stretch of keep-out curve, {} MCLs left out for parity, {} pairs turning short of a hole, {} stretches in lanes{}",
                    s.pieces,
                    s.splices,
                    s.bridges,
                    s.dropped,
                    s.turns,
                    s.lanes,
                    if s.pieces > 1 {
                        "; the other pieces start after a jump: they reach no keep-out curve that the rest of the road reaches (or all of them are paths with no free ends on one curve)"
                    } else {
                        ""
                    }
                ),
            )
        }
        Fill::Offset => {
            let mut work = Box::new(OffsetSpiral::new());
            let mut grid = Box::new(GridMemory::new());
            let s = work.build(slice, plan, &mut grid, &mut path)?;
            (
                Pattern::Spiral,
                format!(
                    "{}spiral (offset): {} turns, {} loops joined by {} bridges, {} jump(s){}, {} small loop(s) left out",
                    if wall_only { "no hollow feature, " } else { "" },
                    s.levels,
                    s.loops,
                    s.joins,
                    s.jumps,
                    if s.jumps > 0 {
                        " (loops that run beside no loop already in the road)"
                    } else {
                        ""
                    },
                    s.dropped
                ),
            )
        }
        Fill::Mcl(f) => {
            let s = spiral(slice, plan, f, &mut path)?;
            (
                Pattern::Spiral,
                format!(
                    "spiral ({}): {} jump(s), {} turns in the first cell",
                    f.name(),
                    s.jumps,
                    s.turns
                ),
            )
        }
    };
    Ok(Layer {
        index,
        pattern,
        path,
        note,
    })
}

/// Builds `count` layers of `fill`.
pub fn layers(slice: &Slice, plan: &Plan, fill: Fill, count: usize) -> Result<Vec<Layer>, Error> {
    (0..count).map(|k| layer(slice, plan, fill, k)).collect()
}
