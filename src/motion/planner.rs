//! Look-ahead: a fixed ring of [`Block`]s whose speed profiles are replanned as blocks arrive.
//!
//! The blocks, their corner speeds and trapezoids are [`block`](super::block)'s.
//!
//! After every push the profiles are recomputed, grbl-style: a reverse pass from the tail
//! (whose exit is always 0, so the machine can always stop on what it holds) caps each entry
//! by what can still be braked away, then a forward pass from the head's fixed entry caps each
//! exit by what can be reached. All math is `f32` through `libm`, deterministic.
//!
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

use super::block::{junction_speed, narrowing_speed, Block, BRAKE_MARGIN, STOP_BRAKE_SHARE};
use crate::geometry::primitives::MinMax;

/// A full ring hands the block back (as `heapless` does).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Full<T>(pub T);

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
    use crate::motion::block::BlockMaker;
    use crate::motion::config::PrinterConfig;
    use crate::toolpath::moves::Move;

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
