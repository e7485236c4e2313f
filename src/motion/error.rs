//! The typed refusal of a printer configuration.

use core::fmt;

use super::config::{
    AXES, MAX_PULSE_NS, MAX_STEPS_PER_MM, MAX_TICK_HZ, MIN_STEPS_PER_MM, MIN_TICK_HZ, SEGMENT_RING,
    SEGMENT_S,
};
use crate::config::CHANNELS;
use crate::FeatureId;

/// A value of a [`PrinterConfig`](super::PrinterConfig) that the motion code cannot honour.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PrinterError {
    /// `axes[axis].steps_per_mm` is below [`MIN_STEPS_PER_MM`], not finite, or above
    /// [`MAX_STEPS_PER_MM`].
    StepsPerMm {
        /// 0 = X, 1 = Y, 2 = Z.
        axis: u8,
        /// The value.
        value: f32,
    },
    /// `axes[axis].max_speed` is zero, negative or not finite.
    MaxSpeed {
        /// The axis.
        axis: u8,
        /// The value.
        value: f32,
    },
    /// `axes[axis].max_speed x steps_per_mm` needs steps faster than the engine or the pulse
    /// width allow.
    StepRate {
        /// The axis.
        axis: u8,
        /// The rate it needs, steps/s.
        rate: f32,
        /// The fastest allowed.
        limit: f32,
    },
    /// `axes[axis].max_accel` is zero, negative or not finite.
    MaxAccel {
        /// The axis.
        axis: u8,
        /// The value.
        value: f32,
    },
    /// A speed (`print_speed`, `travel_speed`, `homing_speed`, `junction_deviation`,
    /// `homing_travel`, `layer_height`) is zero, negative or not finite (or `homing_travel`
    /// longer than twice the position range).
    Speed {
        /// The key.
        key: &'static str,
        /// The value.
        value: f32,
    },
    /// `home[axis]` is not finite or beyond [`MAX_POSITION_MM`](super::block::MAX_POSITION_MM).
    Home {
        /// The axis.
        axis: u8,
    },
    /// `step_pulse_ns` or `dir_setup_ns` is zero, or longer than a segment allows.
    Pulse {
        /// The key.
        key: &'static str,
        /// The value, ns.
        value: u32,
    },
    /// `tick_hz` is out of range.
    TickRate {
        /// The value.
        value: u32,
    },
    /// `channels` is 0 or more than [`CHANNELS`].
    Channels {
        /// The value.
        value: u8,
    },
    /// A channel's `full_flow`, `dead_time_s`, `time_constant_s`, `lead_s`, `lag_s` or
    /// `pwm_hz` is negative, not finite, or (flow, PWM) zero.
    ChannelValue {
        /// The channel.
        channel: u8,
        /// The key.
        key: &'static str,
        /// The value.
        value: f32,
    },
    /// A channel's calibration curve is not a curve from (0, 0) to (1, 1) with duty strictly
    /// and flow never decreasing.
    Curve {
        /// The channel.
        channel: u8,
        /// The first offending point.
        point: u8,
    },
    /// The slice deposits a material from a channel beyond `channels` (every layer's
    /// composition blends the features' materials).
    SliceChannel {
        /// The feature whose material needs it.
        feature: FeatureId,
        /// The channel.
        channel: u8,
        /// The printer's `channels`.
        channels: u8,
    },
    /// A channel's advance (`dead_time_s + time_constant_s` and the larger of `lead_s` and
    /// `lag_s`) is longer than the segment look-ahead ([`SEGMENT_RING`] segments).
    Advance {
        /// The channel.
        channel: u8,
        /// The advance, s.
        advance: f32,
    },
}

impl fmt::Display for PrinterError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        const AXIS: [&str; AXES] = ["x", "y", "z"];
        let axis = |a: u8| AXIS.get(a as usize).copied().unwrap_or("?");
        match *self {
            PrinterError::StepsPerMm { axis: a, value } => write!(
                f,
                "axes.{}.steps_per_mm: {value} is out of range (at least {MIN_STEPS_PER_MM}, at most {MAX_STEPS_PER_MM})",
                axis(a)
            ),
            PrinterError::MaxSpeed { axis: a, value } => write!(
                f,
                "axes.{}.max_speed: {value} mm/s is not a positive finite number",
                axis(a)
            ),
            PrinterError::StepRate {
                axis: a,
                rate,
                limit,
            } => write!(
                f,
                "axes.{}.max_speed x steps_per_mm needs {rate} steps/s; at most {limit} (tick_hz, step_pulse_ns)",
                axis(a)
            ),
            PrinterError::MaxAccel { axis: a, value } => write!(
                f,
                "axes.{}.max_accel: {value} mm/s^2 is not a positive finite number",
                axis(a)
            ),
            PrinterError::Speed { key, value } => match super::config::upper_bound(key) {
                Some(max) if value.is_finite() && value > 0.0 => {
                    write!(f, "{key}: {value} is out of range (")?;
                    if let Some(min) = super::config::lower_bound(key) {
                        write!(f, "at least {min}, ")?;
                    }
                    write!(f, "at most {max})")
                }
                _ => write!(f, "{key}: {value} is not a positive finite number"),
            },
            PrinterError::Home { axis: a } => write!(
                f,
                "home.{}: not a finite number within {} mm",
                axis(a),
                super::block::MAX_POSITION_MM
            ),
            PrinterError::Pulse { key, value } => write!(
                f,
                "{key}: {value} ns is out of range (more than 0, at most {MAX_PULSE_NS})"
            ),
            PrinterError::TickRate { value } => write!(
                f,
                "tick_hz: {value} is out of range ({MIN_TICK_HZ} to {MAX_TICK_HZ})"
            ),
            PrinterError::Channels { value } => {
                write!(f, "channels: {value} is out of range (1 to {CHANNELS})")
            }
            PrinterError::ChannelValue {
                channel,
                key,
                value,
            } => write!(
                f,
                "channel[{channel}].{key}: {value} is out of range (a finite number, {})",
                // As `PrinterConfig::validate` checks them: a flow and a rate must be some.
                if matches!(key, "full_flow" | "pwm_hz") {
                    "more than 0"
                } else {
                    "not negative"
                }
            ),
            PrinterError::Curve { channel, point } => write!(
                f,
                "channel[{channel}].curve: point {point} breaks the curve (from duty 0 flow 0 to duty 1 flow 1, duty rising, flow never falling)"
            ),
            PrinterError::SliceChannel {
                feature,
                channel,
                channels,
            } => write!(
                f,
                "channels: {channels}, but the material of {feature} uses channel {channel}"
            ),
            PrinterError::Advance { channel, advance } => write!(
                f,
                "channel[{channel}]: dead_time_s + time_constant_s + max(lead_s, lag_s) = {advance} s is longer than the {} s look-ahead",
                SEGMENT_RING as f32 * SEGMENT_S
            ),
        }
    }
}

impl core::error::Error for PrinterError {}
