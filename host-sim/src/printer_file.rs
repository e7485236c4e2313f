//! Printer files: the [`PrinterConfig`] as JSON on the host. Every key is optional (the
//! default printer's value stands in), an unknown key is refused by name, and the values are
//! checked by [`PrinterConfig::validate`], whose error names the key.
//!
//! ```json
//! {
//!   "axes": {
//!     "x": {"steps_per_mm": 400, "invert_dir": false, "max_speed": 30, "max_accel": 100,
//!           "endstop": {"active_high": true}},
//!     "y": {"steps_per_mm": 400},
//!     "z": {"steps_per_mm": 3200, "max_speed": 5, "endstop": null}
//!   },
//!   "junction_deviation": 0.01, "print_speed": 10, "travel_speed": 25,
//!   "homing_speed": 5, "homing_travel": 300, "step_pulse_ns": 2000, "dir_setup_ns": 1000,
//!   "channels": 4,
//!   "channel": [{"full_flow": 2.5, "curve": [[0, 0], [0.15, 0], [1, 1]], "dead_time_s": 0.02,
//!                "time_constant_s": 0.03, "lead_s": 0, "lag_s": 0, "pwm_hz": 100}],
//!   "layer_height": 0.3, "home": [0, 0, 0], "estop_active_high": true, "tick_hz": 1000000
//! }
//! ```
//!
//! `channel` lists the channels from 0; channels it leaves out keep the default.

use std::fmt;
use std::path::Path;

use hollowpath::config::CHANNELS;
use hollowpath::motion::config::{AXES, CURVE_POINTS};
use hollowpath::motion::PrinterError;
use hollowpath::motion::{AxisConfig, ChannelConfig, CurvePoint, Endstop, PrinterConfig};
use serde_json::{Map, Value};

use crate::json_file::{self, kind, ReadError};

/// The largest printer file read.
pub const MAX_FILE_BYTES: u64 = 1 << 20;

/// Why a printer file was refused.
#[derive(Debug)]
pub enum PrinterFileError {
    /// The file could not be read.
    Io(String, std::io::Error),
    /// Not JSON (with the key nearest the fault, if one precedes it).
    Json(serde_json::Error, Option<String>),
    /// A key the format does not have, or a value of the wrong kind (the key's path, what is
    /// wrong).
    Key(String, String),
    /// The printer itself is invalid (the core's verdict, which names the key).
    Printer(PrinterError),
    /// The file is larger than the limit (path, limit in bytes).
    TooLarge(String, u64),
}

impl fmt::Display for PrinterFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PrinterFileError::Io(p, e) => write!(f, "cannot read {p}: {e}"),
            PrinterFileError::Json(e, Some(key)) => {
                write!(
                    f,
                    "{key}: not valid JSON here ({e}; NaN and infinities are not JSON numbers)"
                )
            }
            PrinterFileError::Json(e, None) => write!(f, "malformed printer file: {e}"),
            PrinterFileError::Key(key, what) => write!(f, "{key}: {what}"),
            PrinterFileError::Printer(e) => write!(f, "{e}"),
            PrinterFileError::TooLarge(p, limit) => {
                write!(
                    f,
                    "printer file {p} is larger than {}",
                    json_file::size(*limit)
                )
            }
        }
    }
}

impl std::error::Error for PrinterFileError {}

/// Reads a printer file.
pub fn load(path: &Path) -> Result<PrinterConfig, PrinterFileError> {
    let shown = path.display().to_string();
    let text = json_file::read_text(path, MAX_FILE_BYTES).map_err(|e| match e {
        ReadError::Io(e) => PrinterFileError::Io(shown.clone(), e),
        ReadError::TooLarge(limit) => PrinterFileError::TooLarge(shown.clone(), limit),
        ReadError::NotUtf8(at) => PrinterFileError::Io(
            shown.clone(),
            std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!("not UTF-8 text (invalid byte at offset {at})"),
            ),
        ),
    })?;
    parse(&text)
}

/// The last `"key":` before byte `offset` of `text`.
fn key_before(text: &str, offset: usize) -> Option<String> {
    let head = &text[..offset.min(text.len())];
    let colon = head.rfind(':')?;
    let before = head[..colon].trim_end();
    let before = before.strip_suffix('"')?;
    let open = before.rfind('"')?;
    Some(before[open + 1..].to_string())
}

/// Parses and validates a printer file's text.
pub fn parse(text: &str) -> Result<PrinterConfig, PrinterFileError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let doc: Value = json_file::parse_unique(text).map_err(|e| {
        let key = key_before(text, json_file::offset_of(text, e.line(), e.column()));
        PrinterFileError::Json(e, key)
    })?;
    let mut cfg = PrinterConfig::default();
    let top = object(&doc, "the printer file", TOP_KEYS)?;
    if let Some(v) = top.get("axes") {
        let axes = object(v, "axes", &["x", "y", "z"])?;
        for (a, name) in ["x", "y", "z"].iter().enumerate() {
            if let Some(v) = axes.get(*name) {
                axis(v, &format!("axes.{name}"), &mut cfg.axes[a])?;
            }
        }
    }
    for (key, dst) in [
        ("junction_deviation", &mut cfg.junction_deviation),
        ("print_speed", &mut cfg.print_speed),
        ("travel_speed", &mut cfg.travel_speed),
        ("homing_speed", &mut cfg.homing_speed),
        ("homing_travel", &mut cfg.homing_travel),
        ("layer_height", &mut cfg.layer_height),
    ] {
        if let Some(v) = top.get(key) {
            *dst = float(v, key)?;
        }
    }
    for (key, dst) in [
        ("step_pulse_ns", &mut cfg.step_pulse_ns),
        ("dir_setup_ns", &mut cfg.dir_setup_ns),
        ("tick_hz", &mut cfg.tick_hz),
    ] {
        if let Some(v) = top.get(key) {
            *dst = whole(v, key, u32::MAX as u64)? as u32;
        }
    }
    if let Some(v) = top.get("channels") {
        cfg.channels = whole(v, "channels", u8::MAX as u64)? as u8;
    }
    if let Some(v) = top.get("estop_active_high") {
        cfg.estop_active_high = boolean(v, "estop_active_high")?;
    }
    if let Some(v) = top.get("home") {
        let list = list(v, "home")?;
        if list.len() != AXES {
            return Err(key_err(
                "home",
                format!("expected [x, y, z], found {} values", list.len()),
            ));
        }
        for (a, v) in list.iter().enumerate() {
            cfg.home[a] = float(v, &format!("home[{a}]"))?;
        }
    }
    if let Some(v) = top.get("channel") {
        let list = list(v, "channel")?;
        if list.len() > CHANNELS {
            return Err(key_err(
                "channel",
                format!("{} channels listed, at most {CHANNELS}", list.len()),
            ));
        }
        for (c, v) in list.iter().enumerate() {
            channel(v, &format!("channel[{c}]"), &mut cfg.channel[c])?;
        }
    }
    cfg.validate().map_err(PrinterFileError::Printer)?;
    Ok(cfg)
}

const TOP_KEYS: &[&str] = &[
    "axes",
    "junction_deviation",
    "print_speed",
    "travel_speed",
    "homing_speed",
    "homing_travel",
    "step_pulse_ns",
    "dir_setup_ns",
    "channels",
    "channel",
    "layer_height",
    "home",
    "estop_active_high",
    "tick_hz",
];
const AXIS_KEYS: &[&str] = &[
    "steps_per_mm",
    "invert_dir",
    "max_speed",
    "max_accel",
    "endstop",
];
const CHANNEL_KEYS: &[&str] = &[
    "full_flow",
    "curve",
    "dead_time_s",
    "time_constant_s",
    "lead_s",
    "lag_s",
    "pwm_hz",
];

fn key_err(key: &str, what: String) -> PrinterFileError {
    PrinterFileError::Key(key.to_string(), what)
}

/// The object `v` (at `key`), every key of it one of `allowed`.
fn object<'a>(
    v: &'a Value,
    key: &str,
    allowed: &[&str],
) -> Result<&'a Map<String, Value>, PrinterFileError> {
    let Value::Object(map) = v else {
        return Err(key_err(
            key,
            format!("expected an object {{...}}, found {}", kind(v)),
        ));
    };
    if let Some(k) = map.keys().find(|k| !allowed.contains(&k.as_str())) {
        let at = if key.starts_with("the ") {
            k.clone()
        } else {
            format!("{key}.{k}")
        };
        return Err(key_err(
            &at,
            format!("unknown key; expected one of {}", allowed.join(", ")),
        ));
    }
    Ok(map)
}

fn list<'a>(v: &'a Value, key: &str) -> Result<&'a Vec<Value>, PrinterFileError> {
    match v {
        Value::Array(l) => Ok(l),
        v => Err(key_err(key, format!("expected a list, found {}", kind(v)))),
    }
}

fn float(v: &Value, key: &str) -> Result<f32, PrinterFileError> {
    match v.as_f64() {
        Some(x) if x.abs() <= f32::MAX as f64 => Ok(x as f32),
        Some(x) => Err(key_err(key, format!("{x} is out of range"))),
        None => Err(key_err(
            key,
            format!("expected a number, found {}", kind(v)),
        )),
    }
}

fn whole(v: &Value, key: &str, max: u64) -> Result<u64, PrinterFileError> {
    // A whole number written with an exponent or a point (`1e9`, `2.0`) is JSON's float.
    let exact = v.as_u64().or_else(|| {
        v.as_f64()
            .filter(|x| x.fract() == 0.0 && (0.0..=max as f64).contains(x))
            .map(|x| x as u64)
    });
    match exact {
        Some(x) if x <= max => Ok(x),
        _ => Err(key_err(
            key,
            format!("expected a whole number from 0 to {max}, found {v}"),
        )),
    }
}

fn boolean(v: &Value, key: &str) -> Result<bool, PrinterFileError> {
    v.as_bool()
        .ok_or_else(|| key_err(key, format!("expected true or false, found {}", kind(v))))
}

fn axis(v: &Value, key: &str, a: &mut AxisConfig) -> Result<(), PrinterFileError> {
    let map = object(v, key, AXIS_KEYS)?;
    for (k, dst) in [
        ("steps_per_mm", &mut a.steps_per_mm),
        ("max_speed", &mut a.max_speed),
        ("max_accel", &mut a.max_accel),
    ] {
        if let Some(v) = map.get(k) {
            *dst = float(v, &format!("{key}.{k}"))?;
        }
    }
    if let Some(v) = map.get("invert_dir") {
        a.invert_dir = boolean(v, &format!("{key}.invert_dir"))?;
    }
    if let Some(v) = map.get("endstop") {
        let at = format!("{key}.endstop");
        a.endstop = match v {
            Value::Null => None,
            v => {
                let e = object(v, &at, &["active_high"])?;
                let active_high = match e.get("active_high") {
                    Some(v) => boolean(v, &format!("{at}.active_high"))?,
                    None => true,
                };
                Some(Endstop { active_high })
            }
        };
    }
    Ok(())
}

fn channel(v: &Value, key: &str, ch: &mut ChannelConfig) -> Result<(), PrinterFileError> {
    let map = object(v, key, CHANNEL_KEYS)?;
    for (k, dst) in [
        ("full_flow", &mut ch.full_flow),
        ("dead_time_s", &mut ch.dead_time_s),
        ("time_constant_s", &mut ch.time_constant_s),
        ("lead_s", &mut ch.lead_s),
        ("lag_s", &mut ch.lag_s),
        ("pwm_hz", &mut ch.pwm_hz),
    ] {
        if let Some(v) = map.get(k) {
            *dst = float(v, &format!("{key}.{k}"))?;
        }
    }
    if let Some(v) = map.get("curve") {
        let at = format!("{key}.curve");
        let points = list(v, &at)?;
        if points.len() > CURVE_POINTS {
            return Err(key_err(
                &at,
                format!("{} points, at most {CURVE_POINTS}", points.len()),
            ));
        }
        if points.len() < 2 {
            return Err(key_err(
                &at,
                format!(
                    "{} point(s): a curve runs from [0, 0] to [1, 1], at least those two",
                    points.len()
                ),
            ));
        }
        let mut curve = heapless::Vec::new();
        for (i, p) in points.iter().enumerate() {
            let pk = format!("{at}[{i}]");
            let pair = list(p, &pk)?;
            let [d, q] = &pair[..] else {
                return Err(key_err(
                    &pk,
                    format!("expected [duty, flow], found {} values", pair.len()),
                ));
            };
            let point = CurvePoint {
                duty: float(d, &pk)?,
                flow: float(q, &pk)?,
            };
            curve.push(point).map_err(|_| {
                key_err(
                    &at,
                    format!("{} points, at most {CURVE_POINTS}", points.len()),
                )
            })?;
        }
        ch.curve = curve;
    }
    Ok(())
}
