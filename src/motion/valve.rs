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
//! ([`planner`](super::planner)'s essay). Where the flow asked for steps down faster than the
//! valve can shed it (a road narrowing move by move towards a keep-out curve, an MCL fan
//! closing), the command follows its *envelope* instead (`envelopes`): the largest flow
//! from which the valve, shut as far as it goes, still reaches every later segment's flow in
//! time (`min over j` of `q(j) exp((t_j - t) / tau)`, over [`SHED_HORIZON_TAU`] time
//! constants). The valve starts shedding before the step, so the bead narrows a little early
//! instead of running wide past it (into the keep-out band, or doubling its neighbour);
//! where the flow never falls that fast the envelope is the flow itself. Mid-road (the road
//! still deposits a time constant on) the command is never below [`HOLD`] of the flow asked
//! for: where the flow still falls faster than the valve sheds it, the valve dips rather than
//! shutting and reopening. At a road's end it shuts as early as `q + tau dq/dt` says (of the
//! road's own flow), and a channel opens `lead_s` earlier still at a road's start and shuts
//! `lag_s` earlier at its end.
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
use crate::geometry::primitives::MinMax;
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
    /// Segments the envelope looks past the commanded one ([`SHED_HORIZON_TAU`]).
    shed_horizon: usize,
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

/// How far ahead the envelope looks, in time constants: a drop to `exp(-3)` (5 %) of the flow
/// within it is shed in time; a deeper one is shed as far as the lag allows.
pub const SHED_HORIZON_TAU: f32 = 3.0;

/// Segment `k` ahead of `current` (0: `current` itself) in a ring given as its two slices
/// (`Deque::as_slices`, taken once per frame), `None` past the end of what is prepared.
fn ahead_of<'a>(
    current: &'a Segment,
    (front, back): (&'a [Segment], &'a [Segment]),
    k: usize,
) -> Option<&'a Segment> {
    match k {
        0 => Some(current),
        k if k <= front.len() => front.get(k - 1),
        k => back.get(k - 1 - front.len()),
    }
}

/// Every channel's flow at segments `k - 1`, `k` and `k + 1` as the valves can follow it (the
/// module's essay), over the `horizon` segments after `k + 1`.
///
/// Each channel's *envelope* is the flow asked for where it never falls faster than the lag
/// sheds it (a factor `r` per segment), otherwise lowered ahead of the fall: `min over
/// j >= i` of `q(j) / r^(j - i)`. A segment of no flow bounds nothing before it (the valve
/// shuts there as before), and one of less than [`STOP_SHARE`] of the road's flow now (the
/// nozzle coming to rest) bounds it only down to that share. Where a channel sheds early only
/// because its share of the composition runs out, the road's total would fall short of what
/// the total's own envelope allows; that deficit goes to the channels that are not shedding, in
/// proportion to their flows (a composition blends anyway; a road's width is geometry), so
/// the bead narrows early only where the road itself narrows or slows faster than the lag.
fn envelopes<const R: usize>(
    current: &Segment,
    ring: &heapless::Deque<Segment, R>,
    k: usize,
    r: f32,
    horizon: usize,
    channels: usize,
) -> [[f32; 3]; CHANNELS] {
    let slices = ring.as_slices();
    let flows = |j: usize| -> [f32; CHANNELS] {
        ahead_of(current, slices, j).map_or([0.0; CHANNELS], |s| s.flow)
    };
    let first = k.saturating_sub(1);
    let pos = [first, k, k + 1];
    let mut out = [[0.0f32; 3]; CHANNELS];
    if r <= 0.0 {
        for (i, &j) in pos.iter().enumerate() {
            let q = flows(j);
            for c in 0..channels {
                out[c][i] = q[c];
            }
        }
        return out;
    }
    let grow = 1.0 / r;
    // The road's flow where it is commanded: a segment ahead with less than STOP_SHARE of
    // it is the nozzle coming to rest, which bounds the flow no lower than that share.
    let stop = STOP_SHARE * flows(k)[..channels].iter().sum::<f32>();
    // The bound each channel's (and the total's, last) successors put on a segment, from
    // the far end back.
    let mut bound = [f32::INFINITY; CHANNELS + 1];
    let step = |flow: &[f32; CHANNELS], bound: &mut [f32; CHANNELS + 1]| -> [f32; CHANNELS + 1] {
        let mut q = [0.0f32; CHANNELS + 1];
        q[..channels].copy_from_slice(&flow[..channels]);
        q[CHANNELS] = flow[..channels].iter().sum();
        // Coming to rest, each flow bounds no lower than its share of `stop`.
        let rest = if q[CHANNELS] < stop {
            stop / q[CHANNELS]
        } else {
            1.0
        };
        for (b, &qc) in bound.iter_mut().zip(q.iter()) {
            *b = if qc > 0.0 {
                (qc * rest).fmin(*b * grow)
            } else {
                f32::INFINITY
            };
        }
        q
    };
    // Segments k + 2 ..= k + 1 + horizon are ring entries k + 1 .. k + horizon, walked back.
    let far = ring.len().min(k + 1 + horizon);
    if far > k + 1 {
        for s in ring.iter().take(far).skip(k + 1).rev() {
            step(&s.flow, &mut bound);
        }
    }
    for i in (0..3).rev() {
        if i == 0 && first == k {
            // At the dead time 0 the segment "before" is the current one itself.
            for o in out.iter_mut() {
                o[0] = o[1];
            }
            break;
        }
        let q = step(&flows(pos[i]), &mut bound);
        let env = |c: usize| if q[c] > 0.0 { bound[c] } else { 0.0 };
        let total = env(CHANNELS);
        let (mut sum, mut free) = (0.0f32, 0.0f32);
        for (c, &qc) in q.iter().enumerate().take(channels) {
            sum += env(c);
            if qc > 0.0 && env(c) >= qc {
                free += qc;
            }
        }
        let deficit = (total - sum).fmax(0.0);
        for (c, o) in out.iter_mut().enumerate().take(channels) {
            let e = env(c);
            o[i] = if deficit > 0.0 && free > 0.0 && q[c] > 0.0 && e >= q[c] {
                e + deficit * q[c] / free
            } else if deficit > 0.0 && free <= 0.0 && sum > 0.0 {
                e * (1.0 + deficit / sum)
            } else {
                e
            };
        }
    }
    out
}

/// Where the road's flow ahead falls below this share of the flow now commanded, the nozzle
/// is coming to rest (a road's end, a reversal, a pause): the envelope sheds ahead of that
/// only down to this share, or it would narrow the last time constants of every road to
/// nothing (the rest of the fall is the bead's end, as without the envelope).
pub const STOP_SHARE: f32 = 0.3;

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
            shed_horizon: segments(SHED_HORIZON_TAU * cfg.time_constant_s),
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
        // Segment `k` ahead of the current one's flow in channel `c` (0 past the end of what
        // is prepared).
        let slices = ring.as_slices();
        let at =
            |c: usize, k: usize| -> f32 { ahead_of(current, slices, k).map_or(0.0, |s| s.flow[c]) };
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
        let n = self.ch.len();
        // The envelopes for one dead time and valve, computed again only for a channel with
        // another.
        let mut env = [[0.0f32; 3]; CHANNELS];
        let mut env_k = None;
        for (c, ch) in self.ch.iter_mut().enumerate() {
            // The valve's flow at the start of the segment now commanded, after the last
            // command acted for one segment.
            ch.y = ch.last + (ch.y - ch.last) * ch.r;
            let k = ch.dead;
            // Channels of one dead time and one valve share their envelopes.
            let key = (k, ch.r.to_bits(), ch.shed_horizon);
            if env_k != Some(key) {
                env = envelopes(current, ring, k, ch.r, ch.shed_horizon, n);
                env_k = Some(key);
            }
            let q = env[c];
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
                excess[0] += (floor + (ch.y - floor) * ch.g - q[1]).fmax(0.0);
                excess[1] += (floor + (y1 - floor) * ch.g - q[2]).fmax(0.0);
            } else {
                own[c] = raw.fmax(floor);
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
                out[c] = (own[c] - share * total[2]).fmax(HOLD * q1);
            }
        }
        self.excess_prev = excess[0];
        for (c, ch) in self.ch.iter_mut().enumerate() {
            // A channel about to shut shuts `lag` segments early; one about to open opens
            // `lead` segments early (the stateless command of those segments).
            let ahead = |k: usize| -> f32 {
                // The road's own flow: the lead and lag are timed on it, not on its envelope.
                let q = [at(c, k.saturating_sub(1)), at(c, k), at(c, k + 1)];
                (q[1] + ch.tau * slope(q, k)).fmax(0.0)
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
