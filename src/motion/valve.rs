//! The valves: one PWM output per material channel, commanded ahead of the motion.
//!
//! **Flow.** Each segment carries the flow per channel its motion needs: road width x layer
//! height x the distance it covers / its duration, times the channel's share of the
//! composition. So the deposit per millimetre stays what the layer asked for while the nozzle
//! slows into a corner and speeds out of it.
//!
//! **Duty.** A pneumatic valve is not linear in its duty: each channel's calibration curve
//! ([`ChannelConfig::curve`]) maps duty to a fraction of the flow at full duty, with a dead band
//! (flow 0) at low duty. [`duty_for`] inverts it piecewise linearly: a flow above 0 gets the
//! smallest duty that gives it (just above the dead band for the smallest flows), 0 gets duty 0
//! (shut, not idling at the band's edge), more than full flow saturates at duty 1 (counted).
//!
//! **Lead.** The valve is modelled as a dead time `Td` followed by a first-order lag `tau`:
//! the flow follows `curve(duty(t - Td))` through `dq/dt = (target - q) / tau`. The controller
//! inverts that model ahead on the path: while segment `j` is stepped, channel `c` is
//! commanded `q(j + k) + tau dq/dt(j + k)`, `q` the segments' flows, `k` the dead time in
//! whole segments, the slope a central difference. On a ramp that is the same as commanding
//! `Td + tau` ahead; where the flow turns (braking into a corner, then speeding out) it keeps
//! the deposit where a plain `Td + tau` advance would smear it. The command is never below 0
//! (the valve cannot pull material back): braking faster than `v / tau` would outrun the
//! valve, so the look-ahead never brakes a depositing block faster than that into a corner
//! ([`planner`](super::planner)'s essay). Mid-road (the road still deposits a time constant
//! on) the command is never below [`HOLD`] of the flow asked for: where the flow steps down
//! faster than the valve sheds it (a narrower road) the valve dips rather than shutting and
//! reopening. At a road's end it shuts as early as `q + tau dq/dt` says, and a channel opens
//! `lead_s` earlier still at a road's start and shuts `lag_s` earlier at its end.
//!
//! **Closed.** A road that starts from rest (the first, after travel, after a pause) is
//! preceded by a dwell as long as the largest advance, so the valves open while the nozzle
//! stands at the road's start, never while it travels. Every travel, pause and dwell segment
//! carries flow 0, so with the advance looking at most a dwell ahead every valve is shut
//! while travelling; on pause, abort, fault and emergency stop
//! [`Valves::close_all`] shuts them at once.

use super::config::{ChannelConfig, CurvePoint, PrinterConfig, CURVE_POINTS, SEGMENT_S};
use super::stepper::Segment;
use super::Board;
use crate::config::CHANNELS;
use embedded_hal::pwm::SetDutyCycle;

/// The duty (0 to 1) that makes the channel deliver `fraction` of its full flow, by the
/// inverse of its calibration curve (a validated one: from (0, 0) to (1, 1), duty rising, flow
/// never falling).
pub fn duty_for(curve: &[CurvePoint], fraction: f32) -> f32 {
    if fraction.is_nan() || fraction <= 0.0 {
        return 0.0;
    }
    for w in curve.windows(2) {
        let (a, b) = (w[0], w[1]);
        if b.flow >= fraction && b.flow > a.flow {
            let t = (fraction - a.flow) / (b.flow - a.flow);
            return (a.duty + t * (b.duty - a.duty)).clamp(0.0, 1.0);
        }
    }
    1.0
}

/// The fraction of full flow the curve gives at `duty` (the forward model, for simulators).
pub fn flow_for(curve: &[CurvePoint], duty: f32) -> f32 {
    if duty.is_nan() || duty <= 0.0 {
        return 0.0;
    }
    for w in curve.windows(2) {
        let (a, b) = (w[0], w[1]);
        if duty <= b.duty {
            let t = (duty - a.duty) / (b.duty - a.duty);
            return a.flow + t * (b.flow - a.flow);
        }
    }
    curve.last().map_or(0.0, |p| p.flow)
}

/// A PWM output refused a duty.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PwmFault {
    /// The channel.
    pub channel: u8,
}

/// One channel's controller.
#[derive(Clone, Debug)]
struct Channel {
    curve: heapless::Vec<CurvePoint, CURVE_POINTS>,
    full_flow: f32,
    /// Time constant of the lag, s.
    tau: f32,
    /// Dead time, lead and lag in segments.
    dead: usize,
    lead: usize,
    lag: usize,
    /// Segments of a time constant (at least 1): how far on a road must still deposit for
    /// a dip in the command to be held at [`HOLD`].
    hold_horizon: usize,
    /// The lag's decay over one segment, `exp(-SEGMENT_S / tau)` (0 without a lag), and the
    /// share of a step's distance its mean over that segment still lies from the target,
    /// `tau / SEGMENT_S (1 - r)` (0 without a lag).
    r: f32,
    g: f32,
    /// The model of the valve: its flow at the start of the segment commanded next, and the
    /// last command (mm^3/s, within 0 and full flow).
    y: f32,
    last: f32,
    /// The duty last written, in the output's units.
    duty: Option<u16>,
}

/// The least command mid-road, as a share of the flow asked for. Where the flow asked for
/// falls faster than the valve sheds it (a narrower road, sharper braking than `v / tau`),
/// `q + tau dq/dt` goes below 0; shutting the valve there would cost an opening (and, with a
/// dead band, a restart) for a dip the valve cannot follow anyway. Holding a quarter of the
/// flow sheds nearly as fast (the lag decays towards the hold instead of 0).
pub const HOLD: f32 = 0.01;

fn segments(s: f32) -> usize {
    // Validated: at most the look-ahead of SEGMENT_RING segments.
    libm::roundf(s / SEGMENT_S) as usize
}

impl Channel {
    fn new(cfg: &ChannelConfig) -> Channel {
        let tau = cfg.time_constant_s;
        let (r, g) = if tau > 0.0 {
            let r = libm::expf(-SEGMENT_S / tau);
            (r, tau / SEGMENT_S * (1.0 - r))
        } else {
            (0.0, 0.0)
        };
        Channel {
            curve: cfg.curve.clone(),
            full_flow: cfg.full_flow,
            dead: segments(cfg.dead_time_s),
            tau: cfg.time_constant_s,
            lead: segments(cfg.lead_s),
            lag: segments(cfg.lag_s),
            hold_horizon: segments(cfg.time_constant_s).max(1),
            r,
            g,
            y: 0.0,
            last: 0.0,
            duty: None,
        }
    }
}

/// Figures of the valves over a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ValveStats {
    /// Times each channel opened (duty from 0 to more).
    pub openings: [u32; CHANNELS],
    /// Commands that asked for more than full flow (duty 1 was set).
    pub saturated: u32,
    /// Timer ticks each channel was open (a duty above 0), segment by segment.
    pub open_ticks: [u64; CHANNELS],
}

/// Every channel's controller.
#[derive(Clone, Debug)]
pub struct Valves {
    ch: heapless::Vec<Channel, CHANNELS>,
    /// The flow the held channels delivered beyond their shares in the segment before.
    excess_prev: f32,
    /// Figures so far.
    pub stats: ValveStats,
}

impl Valves {
    /// For a validated printer.
    pub fn new(cfg: &PrinterConfig) -> Valves {
        let mut ch = heapless::Vec::new();
        for c in cfg.channels() {
            // At most CHANNELS channels (`channels()` is a slice of the CHANNELS configs).
            if ch.push(Channel::new(c)).is_err() {
                break;
            }
        }
        Valves {
            ch,
            excess_prev: 0.0,
            stats: ValveStats::default(),
        }
    }

    /// Dwell segments a road from rest needs: the farthest any channel looks ahead (dead
    /// time, one segment for the lag's slope, lead).
    pub fn dwell_segments(&self) -> u32 {
        let most = self
            .ch
            .iter()
            .map(|c| c.dead + 1 + c.lead)
            .max()
            .unwrap_or(0);
        // At most SEGMENT_RING (validated).
        most as u32
    }

    /// The flow each channel is to be commanded while `current` is stepped, `ring` the
    /// segments after it (mm^3/s). Called once per segment: it advances each channel's model
    /// of its own valve by the segment that passed.
    pub fn frame<const R: usize>(
        &mut self,
        current: &Segment,
        ring: &heapless::Deque<Segment, R>,
    ) -> [f32; CHANNELS] {
        let (front, back) = ring.as_slices();
        // Segment `k` ahead of the current one's flow in channel `c` (0 past the end of what
        // is prepared).
        let at = |c: usize, k: usize| -> f32 {
            let s = match k {
                0 => Some(current),
                k if k <= front.len() => front.get(k - 1),
                k => back.get(k - 1 - front.len()),
            };
            s.map_or(0.0, |s| s.flow[c])
        };
        let slope = |q: [f32; 3], k: usize| -> f32 {
            if k > 0 {
                (q[2] - q[0]) / (2.0 * SEGMENT_S)
            } else {
                (q[2] - q[1]) / SEGMENT_S
            }
        };
        // Pass 1: each channel's own command, and what a channel that cannot shed its flow
        // fast enough delivers beyond its share (now, `dead`, and a segment later).
        let mut own = [0.0f32; CHANNELS];
        let mut held = [false; CHANNELS];
        let mut excess = [0.0f32; 2];
        let mut free_flow = 0.0f32;
        for (c, ch) in self.ch.iter_mut().enumerate() {
            // The valve's flow at the start of the segment now commanded, after the last
            // command acted for one segment.
            ch.y = ch.last + (ch.y - ch.last) * ch.r;
            let k = ch.dead;
            let q = [at(c, k.saturating_sub(1)), at(c, k), at(c, k + 1)];
            let raw = q[1] + ch.tau * slope(q, k);
            // Mid-road (the road, in any channel, still deposits a time constant on) never
            // below HOLD of the flow asked for: a dip, not a shut valve (the module's essay).
            // So where the composition hands over from one channel to another, the one
            // leaving holds until its share is 0 and the road never has every valve shut.
            let road_on = (0..CHANNELS).any(|d| at(d, k + ch.hold_horizon) > 0.0);
            let floor = if q[1] > 0.0 && road_on {
                HOLD * q[1]
            } else {
                0.0
            };
            if raw < floor && ch.y > q[1] {
                // Shedding as fast as it can: its mean flow over this segment and the next,
                // from `y` towards `floor` (a first-order lag's mean over one segment is
                // `floor + (y - floor) g`).
                held[c] = true;
                own[c] = floor;
                let y1 = floor + (ch.y - floor) * ch.r;
                excess[0] += (floor + (ch.y - floor) * ch.g - q[1]).max(0.0);
                excess[1] += (floor + (y1 - floor) * ch.g - q[2]).max(0.0);
            } else {
                own[c] = raw.max(floor);
                free_flow += q[1];
            }
        }
        // Pass 2: the other channels give up that excess, in proportion to their flows, so
        // the bead keeps its width while its composition lags (a road's width is geometry; a
        // composition blends anyway). Their targets are lowered by the excess and commanded
        // through the same inverse lag.
        let mut out = own;
        let total = [self.excess_prev, excess[0], excess[1]];
        if (total[0] > 0.0 || total[1] > 0.0) && free_flow > 0.0 {
            for (c, ch) in self.ch.iter().enumerate() {
                let k = ch.dead;
                let q1 = at(c, k);
                if held[c] || q1 <= 0.0 {
                    continue;
                }
                let share = q1 / free_flow;
                // Lowered by what the held channels will deliver beyond their shares a
                // segment on (the lag carries the lowering over as the excess decays),
                // never below the hold.
                out[c] = (own[c] - share * total[2]).max(HOLD * q1);
            }
        }
        self.excess_prev = excess[0];
        for (c, ch) in self.ch.iter_mut().enumerate() {
            // A channel about to shut shuts `lag` segments early; one about to open opens
            // `lead` segments early (the stateless command of those segments).
            let ahead = |k: usize| -> f32 {
                let q = [at(c, k.saturating_sub(1)), at(c, k), at(c, k + 1)];
                (q[1] + ch.tau * slope(q, k)).max(0.0)
            };
            if ch.lag > 0 && out[c] > 0.0 && ahead(ch.dead + ch.lag) == 0.0 {
                out[c] = 0.0;
            } else if ch.lead > 0 && out[c] == 0.0 {
                out[c] = ahead(ch.dead + ch.lead);
            }
            ch.last = out[c].clamp(0.0, ch.full_flow);
        }
        out
    }

    /// Sets each channel's duty for `flows` (mm^3/s), writing only what changed.
    pub fn apply<B: Board>(
        &mut self,
        board: &mut B,
        flows: &[f32; CHANNELS],
    ) -> Result<(), PwmFault> {
        for (c, ch) in self.ch.iter_mut().enumerate() {
            let fraction = flows[c] / ch.full_flow;
            if fraction > 1.0 {
                self.stats.saturated += 1;
            }
            let duty = duty_for(&ch.curve, fraction);
            let pwm = board.valve(c);
            let max = pwm.max_duty_cycle();
            // duty is within 0..=1, so this is within 0..=max.
            let value = libm::roundf(duty * max as f32) as u16;
            if ch.duty != Some(value) {
                pwm.set_duty_cycle(value)
                    .map_err(|_| PwmFault { channel: c as u8 })?;
                if value > 0 && ch.duty.unwrap_or(0) == 0 {
                    self.stats.openings[c] += 1;
                }
                ch.duty = Some(value);
            }
        }
        Ok(())
    }

    /// Counts `ticks` of the segment now stepped as open time for every open channel.
    pub fn account(&mut self, ticks: u32) {
        for (c, ch) in self.ch.iter().enumerate() {
            if ch.duty.unwrap_or(0) > 0 {
                self.stats.open_ticks[c] += ticks as u64;
            }
        }
    }

    /// Shuts every channel, trying each even if one refuses; the first refusal is returned.
    pub fn close_all<B: Board>(&mut self, board: &mut B) -> Result<(), PwmFault> {
        let mut result = Ok(());
        for (c, ch) in self.ch.iter_mut().enumerate() {
            ch.last = 0.0;
            match board.valve(c).set_duty_cycle(0) {
                Ok(()) => ch.duty = Some(0),
                Err(_) => {
                    ch.duty = None;
                    if result.is_ok() {
                        result = Err(PwmFault { channel: c as u8 });
                    }
                }
            }
        }
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn duty_inverts_the_calibration_curve_above_its_dead_band() {
        let ch = ChannelConfig::pneumatic();
        let curve = &ch.curve;
        assert_eq!(duty_for(curve, 0.0), 0.0);
        assert_eq!(duty_for(curve, -0.1), 0.0);
        assert_eq!(duty_for(curve, f32::NAN), 0.0);
        assert_eq!(duty_for(curve, 1.5), 1.0);
        // The smallest flow needs the dead band's edge.
        let d = duty_for(curve, 1e-4);
        assert!(d > 0.15 && d < 0.151, "{d}");
        for k in 1..=100 {
            let f = k as f32 / 100.0;
            let d = duty_for(curve, f);
            assert!((flow_for(curve, d) - f).abs() < 1e-5, "{f} -> {d}");
        }
        // Inside the dead band the forward model gives nothing.
        assert_eq!(flow_for(curve, 0.1), 0.0);
        assert_eq!(flow_for(curve, 1.0), 1.0);
    }
}
