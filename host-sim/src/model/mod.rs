//! From a scaffold model to a printed part (`hollowpath slice`): an STL mesh ([`stl`]) welded,
//! cleaned and checked closed ([`mesh`]), cut at the mid-height of every layer and chained into
//! contours ([`cut`]), sorted into islands of walls and holes by nesting ([`nest`]), each hole
//! given its channel's material ([`materials`]), and every island of every layer planned with
//! the core as `hollowpath plan` plans a slice file ([`part`]). [`scaffold`] builds models in
//! code (the demo's, the tests').

pub mod cut;
pub mod error;
pub mod materials;
pub mod mesh;
pub mod nest;
pub mod part;
pub mod run;
pub mod scaffold;
pub mod stl;
pub mod view3d;

use rayon::prelude::*;

pub use error::ModelError;
use hollowpath::Material;
use materials::{Channels, MaterialMap};
use mesh::Mesh;
use nest::Island;

/// The most layers one run slices (a 300 mm part at 0.3 mm, or 10 mm at 0.005 mm).
pub const MAX_LAYERS: usize = 60_000;

/// One island of a layer as the planner will get it: the wall and each hole with its
/// material and channel, mm.
#[derive(Clone, Debug, PartialEq)]
pub struct IslandContours {
    /// The wall.
    pub outer: Vec<[f64; 2]>,
    /// The wall's material.
    pub wall_material: Material,
    /// The holes: points, material, channel.
    pub holes: Vec<(Vec<[f64; 2]>, Material, usize)>,
}

/// One layer of a sliced model.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelLayer {
    /// From 0 at the bed.
    pub index: usize,
    /// The height of the cut (the layer's mid-height), mm above the model's bottom.
    pub z: f64,
    /// Its islands, ordered by the lower left corner of their walls.
    pub islands: Vec<IslandContours>,
}

/// A sliced model: its layers and channels.
#[derive(Clone, Debug, PartialEq)]
pub struct SlicedModel {
    /// The layers from the bed up.
    pub layers: Vec<ModelLayer>,
    /// The channels found and their materials.
    pub channels: Channels,
}

/// The number of layers of height `h` for a model `height` tall (a last partial layer of at
/// least half a layer counts).
pub fn layer_count(height: f64, h: f64) -> usize {
    (height / h + 0.5 - 1e-9).floor().max(0.0) as usize
}

/// Cuts `mesh` into layers of `layer_height` (layer `k` cut at `(k + 1/2) h` above the mesh's
/// bottom), on the current rayon pool, and gives every hole its channel's material from
/// `map`. The result does not depend on the number of threads.
pub fn slice_mesh(
    mesh: &Mesh,
    layer_height: f64,
    map: &MaterialMap,
    on_layer: &(dyn Fn() + Sync),
) -> Result<SlicedModel, ModelError> {
    // The core's range of a slice's layer height (the G-code's `Z` tells 0.01 mm apart).
    let range =
        hollowpath::config::MIN_ROAD_WIDTH_MM as f64..=hollowpath::config::MAX_ROAD_WIDTH_MM as f64;
    if !range.contains(&layer_height) {
        return Err(ModelError::LayerHeight(layer_height));
    }
    let (lo, hi) = mesh.bounds();
    let n = layer_count(hi[2] - lo[2], layer_height);
    if n == 0 {
        return Err(ModelError::TooThin(hi[2] - lo[2], layer_height));
    }
    if n > MAX_LAYERS {
        return Err(ModelError::TooManyLayers(n, MAX_LAYERS));
    }
    let cutter = cut::Cutter::new(mesh);
    let cuts: Vec<Result<(f64, Vec<Island>), ModelError>> = (0..n)
        .into_par_iter()
        .map(|k| {
            let z = (k as f64 + 0.5) * layer_height;
            let contours = cutter.contours(lo[2] + z, k)?;
            if let Some(at) = nest::crossing(&contours) {
                return Err(ModelError::Overlap { layer: k, z, at });
            }
            on_layer();
            Ok((z, nest::islands(contours)))
        })
        .collect();
    let mut cut_layers = Vec::with_capacity(n);
    for c in cuts {
        cut_layers.push(c?);
    }
    let islands: Vec<Vec<Island>> = cut_layers.iter().map(|(_, i)| i.clone()).collect();
    let channels = materials::assign(&islands, map, layer_height)?;
    let layers = cut_layers
        .into_iter()
        .enumerate()
        .map(|(k, (z, islands))| ModelLayer {
            index: k,
            z,
            islands: islands
                .into_iter()
                .enumerate()
                .map(|(i, isl)| IslandContours {
                    outer: isl.outer,
                    wall_material: map.wall,
                    holes: isl
                        .holes
                        .into_iter()
                        .enumerate()
                        .map(|(j, h)| {
                            let c = channels.of[k][i][j];
                            (h, channels.material[c], c)
                        })
                        .collect(),
                })
                .collect(),
        })
        .collect();
    Ok(SlicedModel { layers, channels })
}
