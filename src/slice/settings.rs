//! The planner's settings and their ranges.

use serde::{Deserialize, Serialize};

use crate::config::{self, defaults};
use crate::geometry::primitives::MinMax;
use crate::{Error, SettingId};

/// The planner's knobs. Every field has a documented default ([`Settings::default`]); a slice
/// file may set any of them by its key.
///
/// ```
/// let s = hollowpath::Settings::for_road_width(0.5);
/// assert_eq!(s.road_width, 0.5);
/// assert_eq!(s.delta, 1.0); // 2 road widths
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Settings {
    /// `road_width`: deposited road width, mm (default 0.4; 0.01 to 10).
    pub road_width: f32,
    /// `layer_height`: layer height, mm (default 0.3).
    pub layer_height: f32,
    /// `w_n`: weight of the normal term of the matching objective (2.1) (default 1).
    pub w_n: f32,
    /// `w_d`: weight of the distance term of the matching objective (2.1) (default 1).
    pub w_d: f32,
    /// `delta`: proximity bound of Algorithm I along the bisector, mm (default 2 road widths).
    pub delta: f32,
    /// `mcl_spacing`: spacing of MCLs along a feature, mm (default 1 road width); denser where
    /// they diverge, so that neighbouring roads leave no gap wider than a road.
    pub mcl_spacing: f32,
    /// `relax_iterations`: relaxation sweeps near branch points (default 8, at most 64); 0
    /// skips the smoothing, the final spacing guarantee still holds.
    pub relax_iterations: u8,
    /// `relax_spacing`: the least distance between MCL ends on the cell boundary after
    /// relaxation, mm (default 0.75 road widths).
    pub relax_spacing: f32,
    /// `min_width`: the narrowest road a layer may deposit, mm (default 0.5 road widths; at
    /// most the road width). Where neighbouring roads converge, a road narrows to their
    /// spacing down to this, rather than piling onto them.
    pub min_width: f32,
    /// `max_width`: the widest road a layer may deposit, mm (default 1.6 road widths; from the
    /// road width to 3 road widths). Where neighbouring roads diverge, a road widens to their
    /// spacing up to this, rather than leaving a gap.
    pub max_width: f32,
    /// `simplify_tolerance`: contours of more than
    /// [`SIMPLIFY_ABOVE_VERTICES`] vertices are
    /// simplified within this, mm, before planning ([`Slice::from_contours`]; default 0.005,
    /// at most a tenth of the road width; 0 keeps every vertex).
    pub simplify_tolerance: f32,
}

impl Settings {
    /// The defaults for a given road width (spacing-like settings scale with it).
    pub fn for_road_width(road_width: f32) -> Settings {
        Settings {
            road_width,
            layer_height: defaults::LAYER_HEIGHT,
            w_n: defaults::W_N,
            w_d: defaults::W_D,
            delta: defaults::DELTA_PER_ROAD * road_width,
            mcl_spacing: defaults::MCL_SPACING_PER_ROAD * road_width,
            relax_iterations: defaults::RELAX_ITERATIONS,
            relax_spacing: defaults::RELAX_SPACING_PER_ROAD * road_width,
            min_width: defaults::MIN_WIDTH_PER_ROAD * road_width,
            max_width: defaults::MAX_WIDTH_PER_ROAD * road_width,
            simplify_tolerance: defaults::SIMPLIFY_TOLERANCE.fmin(0.1 * road_width),
        }
    }

    pub(super) fn validate(&self) -> Result<(), Error> {
        let checks = [
            (
                SettingId::RoadWidth,
                self.road_width,
                self.road_width >= config::MIN_ROAD_WIDTH_MM
                    && self.road_width <= config::MAX_ROAD_WIDTH_MM,
            ),
            (
                SettingId::LayerHeight,
                self.layer_height,
                // At least what the G-code's `Z` (four decimals) tells from the next layer.
                self.layer_height >= config::MIN_ROAD_WIDTH_MM
                    && self.layer_height <= config::MAX_ROAD_WIDTH_MM,
            ),
            (
                SettingId::WeightNormal,
                self.w_n,
                self.w_n >= 0.0 && self.w_n <= 16.0,
            ),
            (
                SettingId::WeightDistance,
                self.w_d,
                self.w_d >= 0.0 && self.w_d <= 16.0,
            ),
            (
                SettingId::Delta,
                self.delta,
                self.delta > 0.0 && self.delta.is_finite(),
            ),
            (
                SettingId::MclSpacing,
                self.mcl_spacing,
                self.mcl_spacing >= 0.25 * self.road_width
                    && self.mcl_spacing <= 4.0 * self.road_width,
            ),
            (
                SettingId::RelaxSpacing,
                self.relax_spacing,
                self.relax_spacing > 0.0 && self.relax_spacing <= 4.0 * self.road_width,
            ),
            (
                SettingId::MinWidth,
                self.min_width,
                self.min_width > 0.0 && self.min_width <= self.road_width,
            ),
            (
                SettingId::MaxWidth,
                self.max_width,
                self.max_width >= self.road_width && self.max_width <= 3.0 * self.road_width,
            ),
            (
                SettingId::SimplifyTolerance,
                self.simplify_tolerance,
                self.simplify_tolerance >= 0.0 && self.simplify_tolerance <= 0.1 * self.road_width,
            ),
        ];
        if self.relax_iterations > config::MAX_RELAX_ITERATIONS {
            return Err(Error::InvalidSetting {
                setting: SettingId::RelaxIterations,
                value: self.relax_iterations as f32,
            });
        }
        for (setting, value, ok) in checks {
            // `ok` is false for NaN as every comparison is.
            if !ok {
                return Err(Error::InvalidSetting { setting, value });
            }
        }
        Ok(())
    }
}

impl Default for Settings {
    fn default() -> Self {
        Settings::for_road_width(defaults::ROAD_WIDTH)
    }
}
