//! The printer: its axes, valves and timer, and the check that refuses a printer the motion
//! code cannot drive.
//!
//! A [`PrinterConfig`] is plain data (pub fields), serde-derived so that the link
//! ([`link`](crate::link)) carries it as it is.
//! [`PrinterConfig::default`] is a pneumatic four-channel bioprinter on leadscrew axes;
//! [`PrinterConfig::validate`] refuses every value the planner, the step engine or the valves
//! could not honour, with a [`PrinterError`] that names the key.

use serde::{Deserialize, Serialize};

use crate::config::CHANNELS;

pub use super::error::PrinterError;
use crate::geometry::primitives::{fmax, MinMax};

/// Motion axes: X, Y, Z.
pub const AXES: usize = 3;
/// Points of one channel's calibration curve (duty -> flow).
pub const CURVE_POINTS: usize = 8;
/// Nominal length of one constant-rate step segment, seconds. The last segment of a block
/// takes up to one and a half of these.
pub const SEGMENT_S: f32 = 0.001;
/// Longest segment, seconds (a block's last segment absorbs a remainder shorter than half a
/// segment).
pub const MAX_SEGMENT_S: f32 = 1.5 * SEGMENT_S;
/// Segments prepared ahead of the one being stepped: the valves are commanded from this
/// look-ahead, so a channel's total advance (dead time + time constant + lead) must fit in it.
pub const SEGMENT_RING: usize = 128;
/// Fastest step rate of one axis the engine accepts, steps per second.
pub const MAX_STEP_RATE_HZ: f32 = 200_000.0;
/// Fastest timer the engine accepts, ticks per second (so that a segment's ticks fit a `u32`
/// with room, and a wrapping deadline is unambiguous for minutes).
pub const MAX_TICK_HZ: u32 = 100_000_000;
/// Finest axis the engine accepts, steps per millimetre (so that every position within
/// [`MAX_POSITION_MM`](super::block::MAX_POSITION_MM) is an `i32` of steps).
pub const MAX_STEPS_PER_MM: f32 = 100_000.0;
/// Coarsest axis the engine accepts, steps per millimetre: coarser cannot place a road a tenth
/// of a millimetre wide anywhere near where it belongs (printers have 80 to 3 200; a value
/// like 1e-9, a slip of the exponent, would move nothing at all).
pub const MIN_STEPS_PER_MM: f32 = 1.0;
/// Longest step pulse or direction setup accepted, ns.
pub const MAX_PULSE_NS: u32 = 100_000;
/// Slowest timer the engine accepts, ticks per second.
pub const MIN_TICK_HZ: u32 = 100_000;

// A segment's step count per axis is a `u16`: at most the fastest rate over the longest
// segment (plus one for rounding).
const _: () = assert!(MAX_STEP_RATE_HZ * MAX_SEGMENT_S + 1.0 < u16::MAX as f32);
// A segment's duration in ticks is a `u32`, far from wrapping.
const _: () = assert!((MAX_TICK_HZ as f32) * MAX_SEGMENT_S * 4.0 < u32::MAX as f32);
// An absolute position in steps is an `i32` (both ways, with room for a displacement).
const _: () = assert!(MAX_STEPS_PER_MM * super::block::MAX_POSITION_MM * 2.0 < i32::MAX as f32);
// A pulse in ticks is a `u32`: at most MAX_PULSE_NS at MAX_TICK_HZ.
const _: () =
    assert!((MAX_PULSE_NS as u64) * (MAX_TICK_HZ as u64) / 1_000_000_000 < u32::MAX as u64);
// Axis and curve-point indices are `u8` in errors and faults.
const _: () = assert!(AXES <= u8::MAX as usize);
const _: () = assert!(CURVE_POINTS <= u8::MAX as usize);
// Channel indices are `u8` in errors.
const _: () = assert!(CHANNELS <= u8::MAX as usize);

/// One motion axis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AxisConfig {
    /// Full (micro)steps per millimetre of travel.
    pub steps_per_mm: f32,
    /// Whether the direction pin is low for positive motion.
    pub invert_dir: bool,
    /// Fastest speed along this axis, mm/s.
    pub max_speed: f32,
    /// Largest acceleration along this axis, mm/s^2.
    pub max_accel: f32,
    /// The endstop homing runs into (at the axis' negative end), if the axis has one.
    pub endstop: Option<Endstop>,
}

/// An endstop switch.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Endstop {
    /// Whether the input reads high when the switch is hit.
    pub active_high: bool,
}

/// One point of a valve's calibration curve: at this PWM duty the channel delivers this
/// fraction of its flow at full duty.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CurvePoint {
    /// PWM duty, 0 to 1.
    pub duty: f32,
    /// Flow as a fraction of [`ChannelConfig::full_flow`], 0 to 1.
    pub flow: f32,
}

/// One material channel: a reservoir, a pneumatic valve, a nozzle.
///
/// The valve's response is modelled as a dead time followed by a first-order lag: after the
/// duty changes, nothing happens for `dead_time_s`, then the flow approaches the curve's value
/// for the new duty as `1 - exp(-t / time_constant_s)`. The valves are commanded a dead time
/// ahead on the path with the lag inverted (see [`valve`](super::valve)).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ChannelConfig {
    /// Flow at full duty, mm^3/s.
    pub full_flow: f32,
    /// Calibration, duty -> fraction of `full_flow`: from (0, 0) to (1, 1), duty strictly and
    /// flow never decreasing. A dead band is a run of points at flow 0.
    pub curve: heapless::Vec<CurvePoint, CURVE_POINTS>,
    /// Dead time of the valve's response, s.
    pub dead_time_s: f32,
    /// Time constant of the first-order lag after the dead time, s.
    pub time_constant_s: f32,
    /// Extra advance when a road starts (pressurising the nozzle), s.
    pub lead_s: f32,
    /// How much earlier than the compensated time the valve shuts at a road's end (the bead
    /// keeps oozing after the valve closes), s.
    pub lag_s: f32,
    /// PWM frequency, Hz (below the valve's bandwidth it pulses; the firmware sets it).
    pub pwm_hz: f32,
}

/// The whole printer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PrinterConfig {
    /// X, Y, Z.
    pub axes: [AxisConfig; AXES],
    /// Junction deviation, mm (grbl's cornering tolerance).
    pub junction_deviation: f32,
    /// Speed along depositing moves, mm/s.
    pub print_speed: f32,
    /// Speed along travel moves, mm/s.
    pub travel_speed: f32,
    /// Speed of homing moves, mm/s.
    pub homing_speed: f32,
    /// Longest homing move before an axis is declared broken, mm.
    pub homing_travel: f32,
    /// Step pulse width, ns.
    pub step_pulse_ns: u32,
    /// Direction setup time before a step, ns.
    pub dir_setup_ns: u32,
    /// Material channels in use (1 to [`CHANNELS`]).
    pub channels: u8,
    /// Per channel (the first `channels` are used).
    pub channel: [ChannelConfig; CHANNELS],
    /// Layer height, mm.
    pub layer_height: f32,
    /// Where the nozzle is after homing, mm.
    pub home: [f32; AXES],
    /// Whether the emergency-stop input reads high when pressed.
    pub estop_active_high: bool,
    /// The step timer's rate, ticks per second.
    pub tick_hz: u32,
}

impl ChannelConfig {
    /// The default pneumatic channel: 2.5 mm^3/s at full duty (a 0.64 mm road of 0.3 mm at
    /// 13 mm/s from one channel alone), a dead band below 15 % duty, 20 ms dead time and 30 ms
    /// time constant, 100 Hz PWM.
    pub fn pneumatic() -> ChannelConfig {
        let mut curve = heapless::Vec::new();
        for (duty, flow) in [
            (0.0, 0.0),
            (0.15, 0.0),
            (0.3, 0.15),
            (0.5, 0.42),
            (0.75, 0.74),
            (1.0, 1.0),
        ] {
            // Six points in a capacity of eight (checked at compile time below).
            if curve.push(CurvePoint { duty, flow }).is_err() {
                break;
            }
        }
        ChannelConfig {
            full_flow: 2.5,
            curve,
            dead_time_s: 0.020,
            time_constant_s: 0.030,
            lead_s: 0.0,
            lag_s: 0.0,
            pwm_hz: 100.0,
        }
    }
}

const _: () = assert!(CURVE_POINTS >= 6);

impl Default for PrinterConfig {
    /// A pneumatic four-channel extrusion bioprinter on leadscrew axes:
    ///
    /// * X and Y: 400 steps/mm (a 2 mm-lead screw at 1/4 microstepping of 200 steps), 30 mm/s,
    ///   100 mm/s^2 (a pneumatic valve sheds flow at most at `q / tau`, so depositing blocks
    ///   brake into a corner no faster than `v / tau` allows: below 1.5 mm/s at 30 ms, the
    ///   look-ahead brakes more gently than this); Z: 3200 steps/mm (a 0.5 mm lead at 1/8),
    ///   5 mm/s, 50 mm/s^2. Endstops
    ///   (active high) on all three, homing to (0, 0, 0) at 5 mm/s.
    /// * 10 mm/s printing, 25 mm/s travel, junction deviation 0.01 mm.
    /// * A 1 MHz step timer, 2 us step pulses, 1 us direction setup.
    /// * Four channels of [`ChannelConfig::pneumatic`]; layers of 0.3 mm.
    fn default() -> PrinterConfig {
        let xy = AxisConfig {
            steps_per_mm: 400.0,
            invert_dir: false,
            max_speed: 30.0,
            max_accel: 100.0,
            endstop: Some(Endstop { active_high: true }),
        };
        let channel = ChannelConfig::pneumatic();
        PrinterConfig {
            axes: [
                xy,
                xy,
                AxisConfig {
                    steps_per_mm: 3200.0,
                    max_speed: 5.0,
                    max_accel: 50.0,
                    ..xy
                },
            ],
            junction_deviation: 0.01,
            print_speed: 10.0,
            travel_speed: 25.0,
            homing_speed: 5.0,
            homing_travel: 300.0,
            step_pulse_ns: 2_000,
            dir_setup_ns: 1_000,
            channels: CHANNELS as u8,
            channel: [channel.clone(), channel.clone(), channel.clone(), channel],
            layer_height: 0.3,
            home: [0.0; AXES],
            estop_active_high: true,
            tick_hz: 1_000_000,
        }
    }
}

fn positive(x: f32) -> bool {
    x.is_finite() && x > 0.0
}

fn non_negative(x: f32) -> bool {
    x.is_finite() && x >= 0.0
}

impl PrinterConfig {
    /// Timer ticks for `ns` nanoseconds, rounded up (at least one).
    pub fn ns_to_ticks(&self, ns: u32) -> u32 {
        let t = (ns as u64 * self.tick_hz as u64).div_ceil(1_000_000_000);
        // `ns` is at most MAX_PULSE_NS and `tick_hz` at most MAX_TICK_HZ (validated; the
        // product in ticks fits a u32, asserted above).
        (t as u32).max(1)
    }

    /// The fastest step rate of one axis, steps/s: the engine's cap, and room for a pulse and
    /// as long a gap between two steps.
    pub fn max_step_rate(&self) -> f32 {
        let pulse = self.ns_to_ticks(self.step_pulse_ns) as f32;
        MAX_STEP_RATE_HZ.fmin(self.tick_hz as f32 / (2.0 * pulse + 1.0))
    }

    /// The channels in use.
    pub fn channels(&self) -> &[ChannelConfig] {
        &self.channel[..(self.channels as usize).min(CHANNELS)]
    }

    /// The slowest valve's time constant in use, s: depositing moves brake no faster than it
    /// follows ([`Planner`](super::planner::Planner)).
    pub fn valve_time_constant(&self) -> f32 {
        self.channels()
            .iter()
            .map(|c| c.time_constant_s)
            .fold(0.0, fmax)
    }

    /// Checks every value; the first bad one is named.
    pub fn validate(&self) -> Result<(), PrinterError> {
        if !(MIN_TICK_HZ..=MAX_TICK_HZ).contains(&self.tick_hz) {
            return Err(PrinterError::TickRate {
                value: self.tick_hz,
            });
        }
        for (key, value) in [
            ("step_pulse_ns", self.step_pulse_ns),
            ("dir_setup_ns", self.dir_setup_ns),
        ] {
            if value == 0 || value > MAX_PULSE_NS {
                return Err(PrinterError::Pulse { key, value });
            }
        }
        let limit = self.max_step_rate();
        for (i, a) in self.axes.iter().enumerate() {
            let axis = i as u8;
            if !(MIN_STEPS_PER_MM..=MAX_STEPS_PER_MM).contains(&a.steps_per_mm) {
                return Err(PrinterError::StepsPerMm {
                    axis,
                    value: a.steps_per_mm,
                });
            }
            if !positive(a.max_speed) {
                return Err(PrinterError::MaxSpeed {
                    axis,
                    value: a.max_speed,
                });
            }
            if !positive(a.max_accel) {
                return Err(PrinterError::MaxAccel {
                    axis,
                    value: a.max_accel,
                });
            }
            let rate = a.max_speed * a.steps_per_mm;
            if rate.is_nan() || rate > limit {
                return Err(PrinterError::StepRate { axis, rate, limit });
            }
            if !self.home[i].is_finite()
                || libm::fabsf(self.home[i]) > super::block::MAX_POSITION_MM
            {
                return Err(PrinterError::Home { axis });
            }
        }
        for (key, value) in [
            ("junction_deviation", self.junction_deviation),
            ("print_speed", self.print_speed),
            ("travel_speed", self.travel_speed),
            ("homing_speed", self.homing_speed),
            ("homing_travel", self.homing_travel),
            ("layer_height", self.layer_height),
        ] {
            if !positive(value) {
                return Err(PrinterError::Speed { key, value });
            }
        }
        for (key, value) in [
            ("homing_travel", self.homing_travel),
            ("layer_height", self.layer_height),
        ] {
            if upper_bound(key).is_some_and(|max| value > max)
                || lower_bound(key).is_some_and(|min| value < min)
            {
                return Err(PrinterError::Speed { key, value });
            }
        }
        if self.channels == 0 || self.channels as usize > CHANNELS {
            return Err(PrinterError::Channels {
                value: self.channels,
            });
        }
        let look_ahead = SEGMENT_RING as f32 * SEGMENT_S;
        for (c, ch) in self.channels().iter().enumerate() {
            let channel = c as u8;
            for (key, value, ok) in [
                ("full_flow", ch.full_flow, positive(ch.full_flow)),
                ("dead_time_s", ch.dead_time_s, non_negative(ch.dead_time_s)),
                (
                    "time_constant_s",
                    ch.time_constant_s,
                    non_negative(ch.time_constant_s),
                ),
                ("lead_s", ch.lead_s, non_negative(ch.lead_s)),
                ("lag_s", ch.lag_s, non_negative(ch.lag_s)),
                ("pwm_hz", ch.pwm_hz, positive(ch.pwm_hz)),
            ] {
                if !ok {
                    return Err(PrinterError::ChannelValue {
                        channel,
                        key,
                        value,
                    });
                }
            }
            check_curve(channel, &ch.curve)?;
            let advance = ch.dead_time_s + ch.time_constant_s + ch.lead_s.fmax(ch.lag_s);
            // One segment spare: the valves look at most SEGMENT_RING - 1 segments ahead.
            if advance > look_ahead - 2.0 * SEGMENT_S {
                return Err(PrinterError::Advance { channel, advance });
            }
        }
        Ok(())
    }
}

impl PrinterConfig {
    /// Checks that the printer has every channel `slice` deposits from: each layer's
    /// composition is a blend of the features' materials, so a channel none of them uses is
    /// never needed, and one beyond [`channels`](Self::channels) is refused.
    pub fn check_slice(&self, slice: &crate::Slice) -> Result<(), PrinterError> {
        let used = self.channels().len();
        for f in core::iter::once(slice.wall()).chain(slice.holes()) {
            let m = f.material();
            if let Some(c) = (used..m.len()).find(|&c| m[c] > 0.0) {
                return Err(PrinterError::SliceChannel {
                    feature: f.id(),
                    // Below CHANNELS (asserted u8 above).
                    channel: c as u8,
                    channels: self.channels,
                });
            }
        }
        Ok(())
    }
}

/// Thickest layer a printer may be set to lay, mm: a bioprinter's are 0.1 to 1 mm (a layer of
/// 10^6 mm put the first move out of range, refused as it ran).
pub const MAX_LAYER_HEIGHT_MM: f32 = 10.0;

/// Thinnest layer a printer may be set to lay, mm: the slice's own least layer height.
pub const MIN_LAYER_HEIGHT_MM: f32 = crate::config::MIN_ROAD_WIDTH_MM;

/// The least value a positive setting `key` may take, where it has one above 0: a layer
/// thinner than any slice may ask for.
pub(crate) fn lower_bound(key: &str) -> Option<f32> {
    match key {
        "layer_height" => Some(MIN_LAYER_HEIGHT_MM),
        _ => None,
    }
}

/// The largest value a positive setting `key` may take, where it has one: longer than the
/// whole range is not a homing move (and its steps fit a u32); a layer no printer lays.
pub(crate) fn upper_bound(key: &str) -> Option<f32> {
    match key {
        "homing_travel" => Some(2.0 * super::block::MAX_POSITION_MM),
        "layer_height" => Some(MAX_LAYER_HEIGHT_MM),
        _ => None,
    }
}

fn check_curve(channel: u8, curve: &[CurvePoint]) -> Result<(), PrinterError> {
    let bad = |point: usize| PrinterError::Curve {
        channel,
        point: point as u8,
    };
    let n = curve.len();
    if n < 2 {
        return Err(bad(n));
    }
    if curve[0].duty != 0.0 || curve[0].flow != 0.0 {
        return Err(bad(0));
    }
    for i in 1..n {
        let (a, b) = (curve[i - 1], curve[i]);
        let finite = b.duty.is_finite() && b.flow.is_finite();
        if !finite || b.duty <= a.duty || b.flow < a.flow || b.duty > 1.0 || b.flow > 1.0 {
            return Err(bad(i));
        }
    }
    if curve[n - 1].duty != 1.0 || curve[n - 1].flow != 1.0 {
        return Err(bad(n - 1));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::string::ToString;

    fn refused(edit: impl FnOnce(&mut PrinterConfig)) -> PrinterError {
        let mut cfg = PrinterConfig::default();
        edit(&mut cfg);
        cfg.validate().unwrap_err()
    }

    #[test]
    fn the_default_printer_is_valid() {
        PrinterConfig::default().validate().unwrap();
        assert_eq!(PrinterConfig::default().channels().len(), CHANNELS);
    }

    #[test]
    fn bad_printers_are_refused_naming_the_key() {
        let e = refused(|c| c.axes[1].steps_per_mm = 0.0);
        assert_eq!(
            e,
            PrinterError::StepsPerMm {
                axis: 1,
                value: 0.0
            }
        );
        assert!(e.to_string().starts_with("axes.y.steps_per_mm"), "{e}");
        let e = refused(|c| c.axes[2].steps_per_mm = -400.0);
        assert!(matches!(e, PrinterError::StepsPerMm { axis: 2, .. }));
        let e = refused(|c| c.axes[0].steps_per_mm = f32::NAN);
        assert!(matches!(e, PrinterError::StepsPerMm { axis: 0, .. }));
        // A slip of the exponent: no step would ever be taken.
        let e = refused(|c| c.axes[0].steps_per_mm = 1e-9);
        assert_eq!(
            e.to_string(),
            "axes.x.steps_per_mm: 0.000000001 is out of range (at least 1, at most 100000)"
        );
        let e = refused(|c| c.layer_height = 1e-9);
        assert_eq!(
            e.to_string(),
            "layer_height: 0.000000001 is out of range (at least 0.01, at most 10)"
        );
        refused(|c| c.layer_height = 0.0099);
        let mut thin = PrinterConfig {
            layer_height: MIN_LAYER_HEIGHT_MM,
            ..PrinterConfig::default()
        };
        thin.axes[2].steps_per_mm = MIN_STEPS_PER_MM;
        thin.validate().unwrap();
        let e = refused(|c| c.axes[0].max_speed = -1.0);
        assert_eq!(
            e,
            PrinterError::MaxSpeed {
                axis: 0,
                value: -1.0
            }
        );
        assert!(e.to_string().starts_with("axes.x.max_speed"), "{e}");
        let e = refused(|c| c.axes[1].max_accel = f32::NAN);
        assert!(matches!(e, PrinterError::MaxAccel { axis: 1, .. }));
        let e = refused(|c| c.print_speed = -5.0);
        assert_eq!(
            e,
            PrinterError::Speed {
                key: "print_speed",
                value: -5.0
            }
        );
        assert!(e.to_string().starts_with("print_speed: -5"), "{e}");
        let e = refused(|c| c.travel_speed = f32::NAN);
        assert!(matches!(
            e,
            PrinterError::Speed {
                key: "travel_speed",
                ..
            }
        ));
        assert!(e.to_string().starts_with("travel_speed: NaN"), "{e}");
        let e = refused(|c| c.junction_deviation = 0.0);
        assert!(matches!(
            e,
            PrinterError::Speed {
                key: "junction_deviation",
                ..
            }
        ));
        let e = refused(|c| c.layer_height = f32::INFINITY);
        assert!(matches!(
            e,
            PrinterError::Speed {
                key: "layer_height",
                ..
            }
        ));
        let e = refused(|c| c.channels = 5);
        assert_eq!(e, PrinterError::Channels { value: 5 });
        assert!(e.to_string().starts_with("channels: 5"), "{e}");
        assert_eq!(
            refused(|c| c.channels = 0),
            PrinterError::Channels { value: 0 }
        );
        let e = refused(|c| c.channel[2].full_flow = 0.0);
        assert_eq!(
            e,
            PrinterError::ChannelValue {
                channel: 2,
                key: "full_flow",
                value: 0.0
            }
        );
        assert!(e.to_string().starts_with("channel[2].full_flow"), "{e}");
        assert!(
            e.to_string().ends_with("(a finite number, more than 0)"),
            "{e}"
        );
        let e = refused(|c| c.channel[0].dead_time_s = -0.01);
        assert!(matches!(
            e,
            PrinterError::ChannelValue {
                channel: 0,
                key: "dead_time_s",
                ..
            }
        ));
        let e = refused(|c| c.channel[3].pwm_hz = f32::NAN);
        assert!(matches!(
            e,
            PrinterError::ChannelValue {
                channel: 3,
                key: "pwm_hz",
                ..
            }
        ));
        // A curve that falls, one that does not start at 0, one that stops short of full duty.
        let e = refused(|c| c.channel[1].curve[3].flow = 0.1);
        assert_eq!(
            e,
            PrinterError::Curve {
                channel: 1,
                point: 3
            }
        );
        assert!(
            e.to_string().starts_with("channel[1].curve: point 3"),
            "{e}"
        );
        let e = refused(|c| c.channel[1].curve[2].duty = 0.1);
        assert_eq!(
            e,
            PrinterError::Curve {
                channel: 1,
                point: 2
            }
        );
        let e = refused(|c| c.channel[0].curve[0].flow = 0.2);
        assert_eq!(
            e,
            PrinterError::Curve {
                channel: 0,
                point: 0
            }
        );
        let e = refused(|c| {
            c.channel[0].curve.pop();
        });
        assert_eq!(
            e,
            PrinterError::Curve {
                channel: 0,
                point: 4
            }
        );
        let e = refused(|c| c.channel[0].curve[2].flow = f32::NAN);
        assert_eq!(
            e,
            PrinterError::Curve {
                channel: 0,
                point: 2
            }
        );
        // A channel beyond `channels` is not looked at.
        let mut c = PrinterConfig {
            channels: 2,
            ..PrinterConfig::default()
        };
        c.channel[3].full_flow = -1.0;
        c.validate().unwrap();
        let e = refused(|c| c.channel[0].time_constant_s = 0.2);
        assert!(matches!(e, PrinterError::Advance { channel: 0, .. }));
        let e = refused(|c| c.axes[0].max_speed = 1000.0);
        assert!(matches!(e, PrinterError::StepRate { axis: 0, .. }), "{e:?}");
        assert!(
            e.to_string().starts_with("axes.x.max_speed x steps_per_mm"),
            "{e}"
        );
        let e = refused(|c| c.step_pulse_ns = 0);
        assert_eq!(
            e,
            PrinterError::Pulse {
                key: "step_pulse_ns",
                value: 0
            }
        );
        let e = refused(|c| c.tick_hz = 1_000);
        assert_eq!(e, PrinterError::TickRate { value: 1_000 });
        let e = refused(|c| c.homing_travel = 1e6);
        assert_eq!(
            e,
            PrinterError::Speed {
                key: "homing_travel",
                value: 1e6
            }
        );
        let e = refused(|c| c.home[2] = f32::NAN);
        assert_eq!(e, PrinterError::Home { axis: 2 });
    }

    #[test]
    fn ticks_round_up() {
        let c = PrinterConfig::default();
        assert_eq!(c.ns_to_ticks(2_000), 2);
        assert_eq!(c.ns_to_ticks(1), 1);
        assert_eq!(c.ns_to_ticks(2_001), 3);
    }
}
