//! Look-ahead: a fixed ring of [`Block`]s whose speed profiles are replanned as blocks arrive.
//!
//! Each block is one straight move in whole steps ([`BlockMaker`] rounds the absolute target,
//! so rounding never accumulates). Its *nominal* speed is the print or travel speed, lowered
//! until no axis exceeds its `max_speed`; its acceleration is the largest no axis' `max_accel`
//! is exceeded by. Where two blocks meet, the corner speed follows grbl's junction deviation:
//! the speed at which the centripetal acceleration on a circle that deviates
//! `junction_deviation` from the corner equals the acceleration,
//! `v^2 = a * jd * sin(theta/2) / (1 - sin(theta/2))`. Where the nozzle switches between
//! depositing and travel it stops (the valves open and shut from rest).
//!
//! After every push the profiles are recomputed, grbl-style: a reverse pass from the tail
//! (whose exit is always 0, so the machine can always stop on what it holds) caps each entry
//! by what can still be braked away, then a forward pass from the head's fixed entry caps each
//! exit by what can be reached. Each block gets a trapezoid: entry, cruise, exit at constant
//! acceleration. All math is `f32` through `libm`, deterministic.
//!
//! **Narrowing the valves can follow.** The same lag holds for a road that narrows at
//! constant speed: a step from width `w0` to `w1` takes the valve `tau ln(w0 / w1)` to shed,
//! during which the bead runs wider than planned. So a depositing block narrower than the one
//! before runs no faster than lets it last `1 / BRAKE_MARGIN` of that ([`narrowing_speed`],
//! at least `NARROWING_FLOOR` of its nominal speed): the roads that taper into a keep-out
//! curve or close up in an MCL fan slow down there, and the valve follows them.
//!
//! **Braking the valves can follow.** A pneumatic valve sheds flow at most at `q / tau` (its
//! first-order lag, [`ChannelConfig::time_constant_s`](super::config::ChannelConfig)), and the
//! flow a depositing block needs is proportional to its speed, so a depositing block may brake
//! at most at `v / tau`: faster, and the valve command `q + tau dq/dt` goes below zero, the
//! valve shuts and reopens mid-road and the bead swells into the corner. So a depositing block
//! that brakes to a corner speed `v1 > 0` brakes at `min(accel, BRAKE_MARGIN v1 / tau)`
//! ([`Block::decel`]): along its ramp the speed is at least `v1`, so the command stays at
//! least `(1 - BRAKE_MARGIN) q`. A block that ends at rest (a road's end, a pause, a reversal,
//! and the tail, which the planner must be able to stop on) brakes as if into
//! `STOP_BRAKE_SHARE` of its nominal speed: `min(accel, BRAKE_MARGIN STOP_BRAKE_SHARE v_nom /
//! tau)`. Braking into rest at the full acceleration instead would make the planner
//! non-monotone: the tail's assumed stop at full acceleration allows a faster entry than the
//! gentle braking into the slow corner that a block appended behind it may reveal, so a block
//! already taken by the step generator would have an exit its successor could no longer
//! brake from, and its profile would stand still for milliseconds mid-road (the valves shut
//! there). With braking that never weakens as the exit speed rises, appending a block only
//! ever raises the bounds, and every profile taken is one that can be driven.

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

/// Share of `v / tau` a depositing block brakes at, at most (the module's essay): the valve
/// command stays at least `1 - BRAKE_MARGIN` of the flow along the ramp, room for the
/// segments' sampling of the ramp.
pub const BRAKE_MARGIN: f32 = 0.5;

/// A depositing block braking to rest brakes as if into this share of its nominal speed (the
/// module's essay): never harder than into a slow corner, so the braking bound only grows
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

/// A full ring hands the block back (as `heapless` does).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Full<T>(pub T);

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

/// The look-ahead ring of up to `N` blocks.
#[derive(Clone, Debug)]
pub struct Planner<const N: usize> {
    ring: [Block; N],
    head: usize,
    len: usize,
    /// The head's entry speed, fixed when the block before it was taken.
    fixed_entry: f32,
    deviation: f32,
    /// The slowest valve's time constant, s (0: braking is not limited by the valves).
    valve_tau: f32,
}

impl<const N: usize> Planner<N> {
    /// An empty ring for cornering at `junction_deviation` mm, depositing blocks braking no
    /// faster than valves of time constant `valve_tau` s follow (the module's essay).
    pub const fn new(junction_deviation: f32, valve_tau: f32) -> Planner<N> {
        Planner {
            ring: [Block::EMPTY; N],
            head: 0,
            len: 0,
            fixed_entry: 0.0,
            deviation: junction_deviation,
            valve_tau,
        }
    }

    /// Blocks held.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether it holds none.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Whether another push would be refused.
    pub fn is_full(&self) -> bool {
        self.len == N
    }

    fn index(&self, k: usize) -> usize {
        (self.head + k) % N
    }

    /// Block `k` from the head, with its current profile.
    pub fn get(&self, k: usize) -> Option<&Block> {
        if k < self.len {
            Some(&self.ring[self.index(k)])
        } else {
            None
        }
    }

    /// Appends a block and replans; a full ring hands it back.
    pub fn push(&mut self, mut b: Block) -> Result<(), Full<Block>> {
        if self.len == N {
            return Err(Full(b));
        }
        b.pause_after = false;
        if self.len > 0 {
            let prev = &self.ring[self.index(self.len - 1)];
            b.nominal = narrowing_speed(prev, &b, self.valve_tau).fmin(b.nominal);
        }
        b.max_entry = match self.len {
            // The block before was taken with exit 0 (it was the tail).
            0 => 0.0,
            n => {
                let prev = &self.ring[self.index(n - 1)];
                if prev.deposit != b.deposit || prev.pause_after {
                    0.0
                } else {
                    junction_speed(prev, &b, self.deviation)
                }
            }
        };
        let at = self.index(self.len);
        self.ring[at] = b;
        self.len += 1;
        self.replan_after_push();
        Ok(())
    }

    /// Takes the head block with its final profile; its exit becomes the next head's fixed
    /// entry.
    pub fn pop(&mut self) -> Option<Block> {
        if self.len == 0 {
            return None;
        }
        let b = self.ring[self.head];
        self.head = (self.head + 1) % N;
        self.len -= 1;
        self.fixed_entry = if self.len == 0 { 0.0 } else { b.exit };
        Some(b)
    }

    /// Drops every block (after a fault).
    pub fn clear(&mut self) {
        self.len = 0;
        self.fixed_entry = 0.0;
    }

    /// Marks the first block after which the machine can stop (from the head's fixed entry)
    /// to pause there, and replans. `false` if the ring is empty: then the block being
    /// stepped ends at rest already.
    pub fn request_pause(&mut self) -> bool {
        if self.len == 0 {
            return false;
        }
        let mut m = self.len - 1;
        'search: for cand in 0..self.len {
            // The fastest entry of the head from which the machine stops at the end of `cand`.
            let mut v = 0.0f32;
            for k in (0..=cand).rev() {
                let b = &self.ring[self.index(k)];
                v = hollowpath_fpu::sqrtf(v * v + 2.0 * self.decel(b, v) * b.length);
                if k > 0 {
                    v = v.fmin(b.max_entry);
                }
            }
            if v >= self.fixed_entry * (1.0 + 1e-5) + 1e-6 {
                m = cand;
                break 'search;
            }
        }
        let i = self.index(m);
        self.ring[i].pause_after = true;
        if m + 1 < self.len {
            let j = self.index(m + 1);
            self.ring[j].max_entry = 0.0;
        }
        self.replan();
        true
    }

    /// How hard `b` may brake into an exit of `exit` mm/s (the module's essay).
    fn decel(&self, b: &Block, exit: f32) -> f32 {
        if b.deposit && self.valve_tau > 0.0 {
            // Non-decreasing in `exit`: the reverse pass's bounds only rise as blocks arrive.
            let v = exit.fmax(STOP_BRAKE_SHARE * b.nominal);
            b.accel.fmin(BRAKE_MARGIN * v / self.valve_tau)
        } else {
            b.accel
        }
    }

    /// The reverse and forward passes over the whole ring.
    fn replan(&mut self) {
        self.reverse(false);
        self.forward(0);
    }

    /// The passes after a push, grbl-style: the reverse pass stops at the first block whose
    /// bound did not change (nothing before it can change either), the forward pass starts at
    /// the block before the first that changed. Bit for bit what [`replan`](Self::replan)
    /// gives, for a fraction of the work: braking reaches only a few blocks back.
    fn replan_after_push(&mut self) {
        let first = self.reverse(true);
        self.forward(first.saturating_sub(1));
    }

    /// Reverse: each block's `rev` is the fastest entry from which the rest can still stop.
    /// With `early`, stops at the first block (before the tail) whose `rev` is unchanged.
    /// Returns the first block whose `rev` was recomputed.
    fn reverse(&mut self, early: bool) -> usize {
        let mut next_entry = 0.0f32;
        for k in (0..self.len).rev() {
            let i = self.index(k);
            if self.ring[i].pause_after {
                next_entry = 0.0;
            }
            let decel = self.decel(&self.ring[i], next_entry);
            let b = &mut self.ring[i];
            let brake = hollowpath_fpu::sqrtf(next_entry * next_entry + 2.0 * decel * b.length);
            let rev = b.max_entry.fmin(brake);
            if early && k + 1 < self.len && rev.to_bits() == b.rev.to_bits() {
                return k + 1;
            }
            b.rev = rev;
            next_entry = rev;
        }
        0
    }

    /// Forward from block `from` (from the head's fixed entry, or the exit of the block
    /// before): each exit is what can be reached and what the next block can take.
    fn forward(&mut self, from: usize) {
        let mut v = if from == 0 {
            self.fixed_entry
        } else {
            self.ring[self.index(from - 1)].exit
        };
        for k in from..self.len {
            let i = self.index(k);
            let next_bound = if k + 1 < self.len {
                self.ring[self.index(k + 1)].rev
            } else {
                0.0
            };
            let b = &self.ring[i];
            let entry = if k == 0 { v } else { v.fmin(b.rev) };
            let reach = hollowpath_fpu::sqrtf(entry * entry + 2.0 * b.accel * b.length);
            let exit = if b.pause_after {
                0.0
            } else {
                next_bound.fmin(reach)
            };
            let decel = self.decel(b, exit);
            let (a, d) = (b.accel, decel);
            // The peak where the accelerating and braking ramps meet:
            // (vp^2 - v0^2) / 2a + (vp^2 - v1^2) / 2d = length.
            let peak2 = (2.0 * a * d * b.length + d * entry * entry + a * exit * exit) / (a + d);
            let b = &mut self.ring[i];
            b.entry = entry;
            b.exit = exit;
            b.decel = decel;
            b.cruise = b
                .nominal
                .fmin(hollowpath_fpu::sqrtf(peak2))
                .fmax(entry)
                .fmax(exit);
            v = exit;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Point;

    fn blocks(points: &[(f32, f32)]) -> std::vec::Vec<Block> {
        let cfg = PrinterConfig::default();
        let mut maker = BlockMaker::new(&cfg);
        let mut out = std::vec::Vec::new();
        for w in points.windows(2) {
            let m = Move {
                from: Point::new(w[0].0, w[0].1),
                to: Point::new(w[1].0, w[1].1),
                width: 0.4,
                material: [1.0, 0.0, 0.0, 0.0],
                deposit: true,
            };
            let b = maker.from_move(&m, 0.0).unwrap().unwrap();
            maker.commit(&b);
            out.push(b);
        }
        out
    }

    #[test]
    fn junction_speed_follows_grbl() {
        let b = blocks(&[
            (0.0, 0.0),
            (10.0, 0.0),
            (10.0, 10.0),
            (0.0, 10.0),
            (10.0, 10.0),
        ]);
        let jd = 0.01;
        // 90 degrees: v^2 = a jd sin45 / (1 - sin45).
        let s = hollowpath_fpu::sqrtf(0.5);
        let want = hollowpath_fpu::sqrtf(b[0].accel.fmin(b[1].accel) * jd * s / (1.0 - s));
        assert!((junction_speed(&b[0], &b[1], jd) - want).abs() < 1e-4);
        // A reversal stops; straight on keeps the nominal speed.
        assert_eq!(junction_speed(&b[2], &b[3], jd), 0.0);
        assert_eq!(junction_speed(&b[0], &b[0], jd), b[0].nominal);
    }

    #[test]
    fn a_full_ring_hands_the_block_back_and_the_tail_can_stop() {
        let pts: std::vec::Vec<(f32, f32)> = (0..10).map(|k| (k as f32, 0.0)).collect();
        let b = blocks(&pts);
        let mut p = Planner::<4>::new(0.01, 0.0);
        for blk in &b[..4] {
            p.push(*blk).unwrap();
            assert_eq!(p.get(p.len() - 1).unwrap().exit, 0.0);
        }
        assert_eq!(p.push(b[4]), Err(Full(b[4])));
        // Straight on: the inner junctions run faster than rest.
        assert!(p.get(1).unwrap().entry > 1.0);
        assert_eq!(p.get(0).unwrap().entry, 0.0);
        let head = p.pop().unwrap();
        assert_eq!(head.exit, p.get(0).unwrap().entry);
    }

    /// Whether a block's trapezoid fits its length: the ramps from its entry up to its cruise
    /// and down to its exit, at its accel and decel, need no more than it has.
    fn drivable(b: &Block) -> bool {
        let p = b.profile();
        let [v0, vc, v1] = p.v;
        let need = (vc * vc - v0 * v0) / (2.0 * p.accel) + (vc * vc - v1 * v1) / (2.0 * p.decel);
        need <= p.length * 1.001 + 1e-6
    }

    #[test]
    fn every_block_taken_from_the_ring_can_be_driven_as_planned() {
        // Short moves with a slow corner now and then, fed through a small ring the way the
        // step generator takes them (pop when full): with the valve-limited braking, a tail
        // that brakes to rest at full acceleration let the head run faster than the corner
        // behind the next arrival allowed, and the profiles taken stood still at their ends.
        let mut pts = std::vec::Vec::new();
        let (mut x, mut y, mut seed) = (0.0f32, 0.0f32, 777u32);
        let mut heading = 0.0f32;
        for _ in 0..3000 {
            seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12_345);
            let r = 0.003 + ((seed >> 4) % 64) as f32 * 0.0008;
            if (seed >> 12) % 23 == 0 {
                heading += 2.5;
            } else {
                heading += ((seed >> 16) % 100) as f32 * 0.002 - 0.1;
            }
            x += r * libm::cosf(heading);
            y += r * libm::sinf(heading);
            pts.push((x, y));
        }
        let b = blocks(&pts);
        for tau in [0.0, 0.03, 0.1] {
            let mut p = Planner::<8>::new(0.01, tau);
            let mut taken = 0;
            for blk in &b {
                if p.is_full() {
                    let h = p.pop().unwrap();
                    assert!(drivable(&h), "tau {tau} block {taken}: {:?}", h.profile());
                    taken += 1;
                }
                p.push(*blk).unwrap();
            }
            while let Some(h) = p.pop() {
                assert!(drivable(&h), "tau {tau} tail: {:?}", h.profile());
            }
        }
    }

    #[test]
    fn replanning_after_a_push_is_the_full_replan_bit_for_bit() {
        // A wandering road of short and long moves, sharp and gentle corners, reversals.
        let mut pts = std::vec::Vec::new();
        let (mut x, mut y, mut seed) = (0.0f32, 0.0f32, 12345u32);
        for _ in 0..400 {
            seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12_345);
            let a = (seed >> 8) as f32 / (1u32 << 24) as f32 * core::f32::consts::TAU;
            let r = 0.05 + ((seed >> 3) % 100) as f32 * 0.02;
            x += r * libm::cosf(a);
            y += r * libm::sinf(a);
            pts.push((x, y));
        }
        let b = blocks(&pts);
        for tau in [0.0, 0.03] {
            let mut p = Planner::<16>::new(0.01, tau);
            for (n, blk) in b.iter().enumerate() {
                if p.is_full() {
                    p.pop();
                }
                p.push(*blk).unwrap();
                if n % 37 == 0 {
                    p.request_pause();
                }
                let mut full = p.clone();
                full.replan();
                for k in 0..p.len() {
                    assert_eq!(p.get(k), full.get(k), "tau {tau} push {n} block {k}");
                }
            }
        }
    }
}
