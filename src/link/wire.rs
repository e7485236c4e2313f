//! A wire mirror of [`PrinterError`], whose keys are `&'static str`: on the wire a key is its
//! index in [`PRINTER_KEYS`], so the error converts back losslessly.

use core::fmt;

use serde::{Deserialize, Serialize};

use crate::error::FeatureId;
use crate::motion::error::PrinterError;

/// Every key a [`PrinterError`] names (its `Speed`, `Pulse` and `ChannelValue` variants).
pub const PRINTER_KEYS: [&str; 14] = [
    "print_speed",
    "travel_speed",
    "homing_speed",
    "junction_deviation",
    "homing_travel",
    "layer_height",
    "step_pulse_ns",
    "dir_setup_ns",
    "full_flow",
    "dead_time_s",
    "time_constant_s",
    "lead_s",
    "lag_s",
    "pwm_hz",
];
/// The key of an index not in [`PRINTER_KEYS`] (from a newer peer).
const UNKNOWN_KEY: &str = "(unknown key)";
// Key indices are `u8`.
const _: () = assert!(PRINTER_KEYS.len() <= u8::MAX as usize);

fn key_index(key: &str) -> u8 {
    // The index is below PRINTER_KEYS.len() (asserted to fit a u8), or u8::MAX if unknown.
    PRINTER_KEYS
        .iter()
        .position(|k| *k == key)
        .map_or(u8::MAX, |i| i as u8)
}

fn key_of(index: u8) -> &'static str {
    PRINTER_KEYS
        .get(index as usize)
        .copied()
        .unwrap_or(UNKNOWN_KEY)
}

/// [`PrinterError`] with its keys as indices into [`PRINTER_KEYS`]; [`From`] both ways.
#[allow(missing_docs)]
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum WirePrinterError {
    StepsPerMm {
        axis: u8,
        value: f32,
    },
    MaxSpeed {
        axis: u8,
        value: f32,
    },
    StepRate {
        axis: u8,
        rate: f32,
        limit: f32,
    },
    MaxAccel {
        axis: u8,
        value: f32,
    },
    Speed {
        key: u8,
        value: f32,
    },
    Home {
        axis: u8,
    },
    Pulse {
        key: u8,
        value: u32,
    },
    TickRate {
        value: u32,
    },
    Channels {
        value: u8,
    },
    ChannelValue {
        channel: u8,
        key: u8,
        value: f32,
    },
    Curve {
        channel: u8,
        point: u8,
    },
    SliceChannel {
        feature: FeatureId,
        channel: u8,
        channels: u8,
    },
    Advance {
        channel: u8,
        advance: f32,
    },
}

impl From<PrinterError> for WirePrinterError {
    fn from(e: PrinterError) -> Self {
        use PrinterError as P;
        use WirePrinterError as W;
        match e {
            P::StepsPerMm { axis, value } => W::StepsPerMm { axis, value },
            P::MaxSpeed { axis, value } => W::MaxSpeed { axis, value },
            P::StepRate { axis, rate, limit } => W::StepRate { axis, rate, limit },
            P::MaxAccel { axis, value } => W::MaxAccel { axis, value },
            P::Speed { key, value } => W::Speed {
                key: key_index(key),
                value,
            },
            P::Home { axis } => W::Home { axis },
            P::Pulse { key, value } => W::Pulse {
                key: key_index(key),
                value,
            },
            P::TickRate { value } => W::TickRate { value },
            P::Channels { value } => W::Channels { value },
            P::ChannelValue {
                channel,
                key,
                value,
            } => W::ChannelValue {
                channel,
                key: key_index(key),
                value,
            },
            P::Curve { channel, point } => W::Curve { channel, point },
            P::SliceChannel {
                feature,
                channel,
                channels,
            } => W::SliceChannel {
                feature,
                channel,
                channels,
            },
            P::Advance { channel, advance } => W::Advance { channel, advance },
        }
    }
}

impl From<WirePrinterError> for PrinterError {
    fn from(e: WirePrinterError) -> Self {
        use PrinterError as P;
        use WirePrinterError as W;
        match e {
            W::StepsPerMm { axis, value } => P::StepsPerMm { axis, value },
            W::MaxSpeed { axis, value } => P::MaxSpeed { axis, value },
            W::StepRate { axis, rate, limit } => P::StepRate { axis, rate, limit },
            W::MaxAccel { axis, value } => P::MaxAccel { axis, value },
            W::Speed { key, value } => P::Speed {
                key: key_of(key),
                value,
            },
            W::Home { axis } => P::Home { axis },
            W::Pulse { key, value } => P::Pulse {
                key: key_of(key),
                value,
            },
            W::TickRate { value } => P::TickRate { value },
            W::Channels { value } => P::Channels { value },
            W::ChannelValue {
                channel,
                key,
                value,
            } => P::ChannelValue {
                channel,
                key: key_of(key),
                value,
            },
            W::Curve { channel, point } => P::Curve { channel, point },
            W::SliceChannel {
                feature,
                channel,
                channels,
            } => P::SliceChannel {
                feature,
                channel,
                channels,
            },
            W::Advance { channel, advance } => P::Advance { channel, advance },
        }
    }
}

impl fmt::Display for WirePrinterError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        PrinterError::from(*self).fmt(f)
    }
}
