//! Blocks: one straight move in whole steps and its speed profile, and the speeds where two
//! meet.
//!
//! Each block is one straight move in whole steps ([`BlockMaker`] rounds the absolute target,
//! so rounding never accumulates). Its *nominal* speed is the print or travel speed, lowered
//! until no axis exceeds its `max_speed`; its acceleration is the largest no axis' `max_accel`
//! is exceeded by. Where two blocks meet, the corner speed follows grbl's junction deviation
//! ([`junction_speed`]): the speed at which the centripetal acceleration on a circle that
//! deviates `junction_deviation` from the corner equals the acceleration,
//! `v^2 = a * jd * sin(theta/2) / (1 - sin(theta/2))`. Where the nozzle switches between
//! depositing and travel it stops (the valves open and shut from rest). Each block gets a
//! trapezoid ([`Profile`]): entry, cruise, exit at constant acceleration; the look-ahead ring
//! that plans them is [`planner`](super::planner).
//!
//! **Narrowing the valves can follow.** The same lag holds for a road that narrows at
//! constant speed: a step from width `w0` to `w1` takes the valve `tau ln(w0 / w1)` to shed,
//! during which the bead runs wider than planned. So a depositing block narrower than the one
//! before runs no faster than lets it last `1 / BRAKE_MARGIN` of that ([`narrowing_speed`],
//! at least `NARROWING_FLOOR` of its nominal speed): the roads that taper into a keep-out
//! curve or close up in an MCL fan slow down there, and the valve follows them.

use super::config::{PrinterConfig, AXES};
use crate::geometry::primitives::MinMax;
use crate::toolpath::moves::Move;
use crate::Material;

/// Largest absolute position accepted, mm (a block target outside is refused).
pub const MAX_POSITION_MM: f32 = crate::config::MAX_COORD_MM + 100.0;

/// One straight move in whole steps with its speed profile.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Block {
    /// Signed steps per axis.
    pub steps: [i32; AXES],
    /// The absolute position it ends at, steps.
    pub target: [i32; AXES],
    /// Length, mm (of the displacement in whole steps).
    pub length: f32,
    /// Unit direction.
    pub unit: [f32; AXES],
    /// Nominal (cruise) speed, mm/s.
    pub nominal: f32,
    /// Acceleration along the block, mm/s^2.
    pub accel: f32,
    /// Deceleration of its braking ramp, mm/s^2: `accel`, or less where the valves could not
    /// follow (the module's essay).
    pub decel: f32,
    /// Largest entry speed (the junction with the block before), mm/s.
    pub max_entry: f32,
    /// The fastest entry from which the blocks after it can still stop (the reverse pass),
    /// mm/s.
    pub rev: f32,
    /// Entry speed of the profile, mm/s.
    pub entry: f32,
    /// Cruise (peak) speed of the profile, mm/s.
    pub cruise: f32,
    /// Exit speed of the profile, mm/s.
    pub exit: f32,
    /// Road width, mm.
    pub width: f32,
    /// Composition.
    pub material: Material,
    /// Whether the valves deposit along it.
    pub deposit: bool,
    /// Whether the machine pauses after it (its exit is 0).
    pub pause_after: bool,
}

impl Block {
    /// A block that moves nowhere (ring filler).
    pub const EMPTY: Block = Block {
        steps: [0; AXES],
        target: [0; AXES],
        length: 0.0,
        unit: [0.0; AXES],
        nominal: 0.0,
        accel: 0.0,
        decel: 0.0,
        max_entry: 0.0,
        rev: 0.0,
        entry: 0.0,
        cruise: 0.0,
        exit: 0.0,
        width: 0.0,
        material: [0.0; 4],
        deposit: false,
        pause_after: false,
    };

    /// Its trapezoid.
    pub fn profile(&self) -> Profile {
        Profile::new(
            [self.entry, self.cruise, self.exit],
            self.accel,
            self.decel,
            self.length,
        )
    }
}

/// Share of `v / tau` a depositing block brakes at, at most (the [`planner`](super::planner)'s essay): the valve
/// command stays at least `1 - BRAKE_MARGIN` of the flow along the ramp, room for the
/// segments' sampling of the ramp.
pub const BRAKE_MARGIN: f32 = 0.5;

/// A depositing block braking to rest brakes as if into this share of its nominal speed (the
/// [`planner`](super::planner)'s essay): never harder than into a slow corner, so the braking bound only grows
/// with the exit speed.
pub const STOP_BRAKE_SHARE: f32 = 0.3;

/// A trapezoidal speed profile along one block.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Profile {
    /// Entry, cruise and exit speeds, mm/s.
    pub v: [f32; 3],
    /// Acceleration, mm/s^2.
    pub accel: f32,
    /// Deceleration of the braking ramp, mm/s^2.
    pub decel: f32,
    /// Length, mm.
    pub length: f32,
    /// Accelerating distance, mm.
    pub d_acc: f32,
    /// Braking distance, mm.
    pub d_dec: f32,
    /// Accelerating, cruising and braking times, s.
    pub t: [f32; 3],
}

impl Profile {
    /// The trapezoid from `v0` up to `vc` at `accel` and down to `v1` at `decel` over
    /// `length`; speeds that do not fit (rounding) are pulled in so the distances add up.
    pub fn new([v0, vc, v1]: [f32; 3], accel: f32, decel: f32, length: f32) -> Profile {
        let (a, d) = (accel, decel);
        let vc = vc.fmax(v0).fmax(v1);
        let mut d_acc = ((vc * vc - v0 * v0) / (2.0 * a)).clamp(0.0, length);
        let mut d_dec = ((vc * vc - v1 * v1) / (2.0 * d)).clamp(0.0, length);
        if d_acc + d_dec > length {
            let over = d_acc + d_dec - length;
            // Take the excess off the longer ramp (a rounding-level correction).
            if d_acc > d_dec {
                d_acc -= over;
            } else {
                d_dec -= over;
            }
        }
        let cruise_len = (length - d_acc - d_dec).fmax(0.0);
        let t_acc = (vc - v0) / a;
        let t_dec = (vc - v1) / d;
        let t_cruise = if vc > 0.0 { cruise_len / vc } else { 0.0 };
        Profile {
            v: [v0, vc, v1],
            accel: a,
            decel: d,
            length,
            d_acc,
            d_dec,
            t: [t_acc, t_cruise, t_dec],
        }
    }

    /// Total time, s.
    pub fn duration(&self) -> f32 {
        self.t[0] + self.t[1] + self.t[2]
    }

    /// Distance covered after `t` seconds, mm (clamped to the length).
    pub fn position(&self, t: f32) -> f32 {
        let [v0, vc, _] = self.v;
        let a = self.accel;
        let s = if t <= self.t[0] {
            v0 * t + 0.5 * a * t * t
        } else if t <= self.t[0] + self.t[1] {
            self.d_acc + vc * (t - self.t[0])
        } else {
            let u = (t - self.t[0] - self.t[1]).fmin(self.t[2]);
            self.length - self.d_dec + vc * u - 0.5 * self.decel * u * u
        };
        s.clamp(0.0, self.length)
    }

    /// Speed after `t` seconds, mm/s.
    pub fn speed(&self, t: f32) -> f32 {
        let [v0, vc, v1] = self.v;
        if t <= self.t[0] {
            v0 + self.accel * t
        } else if t <= self.t[0] + self.t[1] {
            vc
        } else {
            (vc - self.decel * (t - self.t[0] - self.t[1])).fmax(v1)
        }
    }
}

/// A target outside [`MAX_POSITION_MM`] or not a finite number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OutOfRange;

/// Turns moves into blocks: knows the axes and the absolute position in steps at the end of
/// the last block made.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BlockMaker {
    /// Where the last block ends, steps.
    pub position: [i32; AXES],
    steps_per_mm: [f32; AXES],
    max_speed: [f32; AXES],
    max_accel: [f32; AXES],
    print_speed: f32,
    travel_speed: f32,
}

impl BlockMaker {
    /// For a validated printer, at its home position.
    pub fn new(cfg: &PrinterConfig) -> BlockMaker {
        let mut m = BlockMaker {
            position: [0; AXES],
            steps_per_mm: [0.0; AXES],
            max_speed: [0.0; AXES],
            max_accel: [0.0; AXES],
            print_speed: cfg.print_speed,
            travel_speed: cfg.travel_speed,
        };
        for (i, a) in cfg.axes.iter().enumerate() {
            m.steps_per_mm[i] = a.steps_per_mm;
            m.max_speed[i] = a.max_speed;
            m.max_accel[i] = a.max_accel;
        }
        m.position = m.to_steps(cfg.home).unwrap_or([0; AXES]);
        m
    }

    /// `mm` in whole steps (rounded to nearest), or [`OutOfRange`].
    pub fn to_steps(&self, mm: [f32; AXES]) -> Result<[i32; AXES], OutOfRange> {
        let mut s = [0; AXES];
        for i in 0..AXES {
            if !mm[i].is_finite() || libm::fabsf(mm[i]) > MAX_POSITION_MM {
                return Err(OutOfRange);
            }
            // Bounded by MAX_POSITION_MM x MAX_STEPS_PER_MM (asserted in `config`).
            s[i] = libm::roundf(mm[i] * self.steps_per_mm[i]) as i32;
        }
        Ok(s)
    }

    /// The block from the current position to `to` (mm) at `speed`, or `None` if it moves no
    /// whole step. Does not move the position: [`commit`](Self::commit) the block once it is
    /// queued.
    pub fn block(
        &self,
        to: [f32; AXES],
        speed: f32,
        width: f32,
        material: Material,
        deposit: bool,
    ) -> Result<Option<Block>, OutOfRange> {
        let target = self.to_steps(to)?;
        let mut steps = [0; AXES];
        let mut mm = [0.0; AXES];
        let mut len2 = 0.0;
        for i in 0..AXES {
            steps[i] = target[i] - self.position[i];
            mm[i] = steps[i] as f32 / self.steps_per_mm[i];
            len2 += mm[i] * mm[i];
        }
        if steps == [0; AXES] {
            return Ok(None);
        }
        let length = hollowpath_fpu::sqrtf(len2);
        let mut unit = [0.0; AXES];
        let mut nominal = speed;
        let mut accel = f32::INFINITY;
        for i in 0..AXES {
            unit[i] = mm[i] / length;
            let u = libm::fabsf(unit[i]);
            if u > 0.0 {
                nominal = nominal.fmin(self.max_speed[i] / u);
                accel = accel.fmin(self.max_accel[i] / u);
            }
        }
        Ok(Some(Block {
            steps,
            target,
            length,
            unit,
            nominal,
            accel,
            decel: accel,
            width,
            material,
            deposit,
            ..Block::EMPTY
        }))
    }

    /// The block of a layer's move at height `z`: depositing moves at the print speed, travel
    /// at the travel speed.
    pub fn from_move(&self, m: &Move, z: f32) -> Result<Option<Block>, OutOfRange> {
        let speed = if m.deposit {
            self.print_speed
        } else {
            self.travel_speed
        };
        self.block([m.to.x, m.to.y, z], speed, m.width, m.material, m.deposit)
    }

    /// Moves the position to the end of `b` (once it is queued).
    pub fn commit(&mut self, b: &Block) {
        self.position = b.target;
    }
}

/// The corner speed from `a` into `b` (grbl's junction deviation), mm/s.
pub fn junction_speed(a: &Block, b: &Block, deviation: f32) -> f32 {
    let mut cos = 0.0;
    for i in 0..AXES {
        cos -= a.unit[i] * b.unit[i];
    }
    let limit = a.nominal.fmin(b.nominal);
    if cos > 0.999_999 {
        // A reversal: stop.
        return 0.0;
    }
    if cos < -0.999_999 {
        // Straight on.
        return limit;
    }
    let sin_half = hollowpath_fpu::sqrtf(0.5 * (1.0 - cos));
    let accel = a.accel.fmin(b.accel);
    let v2 = accel * deviation * sin_half / (1.0 - sin_half);
    hollowpath_fpu::sqrtf(v2).fmin(limit)
}

/// The fastest a depositing block `b` may run after `a` where its road is narrower: the
/// valves shed the flow of the step `a.width -> b.width` (the bead's width at constant speed)
/// in `tau ln(a.width / b.width)`, and the block lasts at least `1 / BRAKE_MARGIN` of that
/// (the module's essay). Never below `NARROWING_FLOOR` of the block's nominal speed;
/// unlimited where the road does not narrow or the valves have no lag.
pub fn narrowing_speed(a: &Block, b: &Block, tau: f32) -> f32 {
    if !(a.deposit && b.deposit) || tau <= 0.0 || b.width <= 0.0 || a.width <= b.width {
        return f32::INFINITY;
    }
    let shed = tau * libm::logf(a.width / b.width);
    (BRAKE_MARGIN * b.length / shed).fmax(NARROWING_FLOOR * b.nominal)
}

/// The slowest [`narrowing_speed`] goes, as a share of the block's nominal speed: steeper
/// steps are left to the valves' envelope ([`valve`](super::valve)).
pub const NARROWING_FLOOR: f32 = 0.2;
