//! The step engine: blocks cut into short constant-rate [`Segment`]s, and the integer routine
//! the step timer's interrupt runs.
//!
//! [`SegmentGen`] walks each block's trapezoid in time slices of [`SEGMENT_S`] (the last slice
//! of a block takes the remainder, up to [`MAX_SEGMENT_S`]). A segment's steps per axis are the
//! difference of `round(s(t) / length x block steps)` at its two ends, so a block moves exactly
//! its steps, and blocks are whole steps between absolute targets, so a path moves exactly its
//! net displacement. The segment also carries the flow per valve channel that the distance it
//! covers needs (road width x layer height x distance / duration, split by the composition).
//! Floating point stays here, once per millisecond.
//!
//! [`Stepper`] runs one segment at a time, from a ring of [`SEGMENT_RING`] prepared ones (the
//! valves read that ring ahead, see [`valve`](super::valve)). Inside a segment a Bresenham DDA
//! over the axes ticks `major` times (the largest axis' steps) at evenly spread instants (the
//! remainder of `ticks / major` spread by a second Bresenham); each tick raises the step pins
//! of the axes whose accumulator overflows, and an alarm `pulse` ticks later lowers them. The
//! direction pins change only between segments, with every step pin low, and the first step
//! after a change waits the direction setup time. Per alarm: integer adds and compares, one
//! pin write per stepping axis.

use super::block::{Block, Profile};
use super::config::{PrinterConfig, AXES, MAX_SEGMENT_S, SEGMENT_RING, SEGMENT_S};
use super::planner::Planner;
use super::Board;
use crate::config::CHANNELS;
use embedded_hal::digital::OutputPin;

/// A wrapping instant of the step timer.
pub type Ticks = u32;

/// An alarm asked for an instant already past.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Late;

/// The step timer: a free-running wrapping counter and one compare alarm. The board
/// implements it with a hardware timer, the host's virtual printer with a virtual clock that
/// jumps from alarm to alarm.
pub trait StepTimer {
    /// The current instant.
    fn now(&self) -> Ticks;
    /// Fires the step interrupt at `at`; [`Late`] if `at` has already passed.
    fn set_alarm(&mut self, at: Ticks) -> Result<(), Late>;
}

/// Whether wrapping instant `a` is before `b` (they are less than 2^31 ticks apart).
pub fn before(a: Ticks, b: Ticks) -> bool {
    (a.wrapping_sub(b) as i32) < 0
}

/// What a segment does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SegmentKind {
    /// Steps along a block.
    Move,
    /// Stands still (the valves open with their lead before a road that starts from rest).
    Dwell,
    /// Stops until resumed.
    Pause,
}

/// A constant-rate piece of a block.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Segment {
    /// Steps per axis.
    pub steps: [u16; AXES],
    /// Whether each axis moves in its positive direction.
    pub forward: [bool; AXES],
    /// Duration, ticks.
    pub ticks: u32,
    /// Flow per channel this segment deposits, mm^3/s (0 on travel, dwell and pause).
    pub flow: [f32; CHANNELS],
    /// What it does.
    pub kind: SegmentKind,
}

impl Segment {
    const fn still(kind: SegmentKind, ticks: u32) -> Segment {
        Segment {
            steps: [0; AXES],
            forward: [true; AXES],
            ticks,
            flow: [0.0; CHANNELS],
            kind,
        }
    }
}

/// Cuts blocks into segments.
#[derive(Clone, Debug)]
pub struct SegmentGen {
    block: Option<(Block, Profile)>,
    /// Segments cut from the current block.
    index: u32,
    /// Steps moved along the current block per axis (unsigned, along its direction).
    done: [u32; AXES],
    /// Ticks of the current block so far.
    block_ticks: u32,
    /// Whether the next road from rest needs a dwell first (start, after travel, a pause).
    need_dwell: bool,
    /// Dwell segments still to emit.
    dwell_left: u32,
    paused: bool,
    pause_after_current: bool,
    tick_hz: f32,
    dwell_segments: u32,
    layer_height: f32,
    channels: usize,
}

impl SegmentGen {
    /// For a validated printer whose valves need `dwell_segments` of advance before a road.
    pub fn new(cfg: &PrinterConfig, dwell_segments: u32) -> SegmentGen {
        SegmentGen {
            block: None,
            index: 0,
            done: [0; AXES],
            block_ticks: 0,
            need_dwell: true,
            dwell_left: 0,
            paused: false,
            pause_after_current: false,
            tick_hz: cfg.tick_hz as f32,
            dwell_segments,
            layer_height: cfg.layer_height,
            channels: cfg.channels().len(),
        }
    }

    /// Forgets everything (after a fault).
    pub fn clear(&mut self) {
        self.block = None;
        self.need_dwell = true;
        self.dwell_left = 0;
        self.paused = false;
        self.pause_after_current = false;
    }

    /// Whether it has stopped at a pause point.
    pub fn is_paused(&self) -> bool {
        self.paused
    }

    /// Whether it is inside a block.
    pub fn is_busy(&self) -> bool {
        self.block.is_some() || self.dwell_left > 0
    }

    /// Pauses after the block being cut (which ends at rest: the planner was empty).
    pub fn pause_after_current(&mut self) {
        self.pause_after_current = true;
    }

    /// Continues after a pause.
    pub fn resume(&mut self) {
        self.paused = false;
    }

    fn ticks_at(&self, t: f32) -> u32 {
        // A block lasts at most MAX_POSITION_MM x sqrt(3) / (its slowest speed); the profile's
        // times are seconds, at most 2^32 / tick_hz (over an hour) before this saturates.
        libm::roundf(t * self.tick_hz) as u32
    }

    /// The next segment, taking blocks from `planner` as needed; `None` when there is nothing
    /// to do (out of blocks, or paused).
    pub fn next<const N: usize>(&mut self, planner: &mut Planner<N>) -> Option<Segment> {
        if self.paused {
            return None;
        }
        if self.dwell_left > 0 {
            self.dwell_left -= 1;
            return Some(Segment::still(SegmentKind::Dwell, self.ticks_at(SEGMENT_S)));
        }
        if self.block.is_none() {
            if self.pause_after_current {
                self.pause_after_current = false;
                return Some(self.pause());
            }
            let b = match planner.pop() {
                Some(b) => b,
                None => {
                    // Out of blocks: the machine stops here; a road after this starts anew.
                    self.need_dwell = true;
                    return None;
                }
            };
            self.block = Some((b, b.profile()));
            self.index = 0;
            self.done = [0; AXES];
            self.block_ticks = 0;
            if b.deposit && self.need_dwell && self.dwell_segments > 0 {
                self.need_dwell = false;
                self.dwell_left = self.dwell_segments - 1;
                return Some(Segment::still(SegmentKind::Dwell, self.ticks_at(SEGMENT_S)));
            }
        }
        let (b, p) = self.block?;
        let total = p.duration();
        let t0 = self.index as f32 * SEGMENT_S;
        let mut t1 = (self.index + 1) as f32 * SEGMENT_S;
        let last = total - t1 < MAX_SEGMENT_S - SEGMENT_S;
        let (s0, s1) = if last {
            t1 = total;
            (p.position(t0), p.length)
        } else {
            (p.position(t0), p.position(t1))
        };
        let mut seg = Segment::still(SegmentKind::Move, 0);
        let frac = if p.length > 0.0 { s1 / p.length } else { 1.0 };
        for i in 0..AXES {
            let all = b.steps[i].unsigned_abs();
            let target = if last {
                all
            } else {
                (libm::roundf(frac * all as f32) as u32).min(all)
            };
            // At most MAX_STEP_RATE_HZ x MAX_SEGMENT_S + 1 steps (asserted in `config`).
            seg.steps[i] = (target - self.done[i].min(target)) as u16;
            self.done[i] = self.done[i].max(target);
            seg.forward[i] = b.steps[i] >= 0;
        }
        let end_ticks = self.ticks_at(t1);
        seg.ticks = end_ticks.saturating_sub(self.block_ticks).max(1);
        self.block_ticks = end_ticks;
        if b.deposit {
            let dt = t1 - t0;
            let speed = if dt > 0.0 { (s1 - s0) / dt } else { 0.0 };
            let total_flow = b.width * self.layer_height * speed;
            for c in 0..self.channels {
                seg.flow[c] = total_flow * b.material[c];
            }
        } else {
            self.need_dwell = true;
        }
        self.index += 1;
        if last {
            self.block = None;
            if b.pause_after {
                self.pause_after_current = true;
            }
        }
        Some(seg)
    }

    fn pause(&mut self) -> Segment {
        self.paused = true;
        self.need_dwell = true;
        Segment::still(SegmentKind::Pause, 1)
    }
}

/// What the next alarm does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum Phase {
    /// Nothing to step.
    Idle,
    /// Raise the step pins of the next DDA tick.
    Tick,
    /// Lower the raised step pins.
    Lower,
    /// The current segment is over: load the next one.
    SegmentEnd,
    /// Stopped at a pause segment.
    Paused,
}

/// A step or direction pin refused a write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PinFault {
    /// The axis.
    pub axis: u8,
}

/// Figures of a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StepStats {
    /// Steps emitted per axis.
    pub steps: [u64; AXES],
    /// Segments run.
    pub segments: u64,
    /// Segments lengthened so that their steps keep a pulse and a gap apart.
    pub stretched: u64,
    /// Shortest gap between two DDA ticks, ticks.
    pub min_interval: u32,
    /// Timer ticks of every segment run (moves and dwells, as stretched; pauses not).
    pub ticks: u64,
}

/// The step routine's state.
#[derive(Clone, Debug)]
pub struct Stepper {
    /// Prepared segments, the next first.
    pub ring: heapless::Deque<Segment, SEGMENT_RING>,
    /// The segment being stepped.
    pub current: Segment,
    pending: Option<Segment>,
    last_low: Ticks,
    phase: Phase,
    acc: [u32; AXES],
    steps: [u32; AXES],
    major: u32,
    left: u32,
    base: u32,
    rem: u32,
    err: u32,
    seg_end: Ticks,
    /// The loaded segment's duration, ticks (as stretched).
    seg_ticks: u32,
    next_tick: Ticks,
    raised: [bool; AXES],
    dir_level: [Option<bool>; AXES],
    invert: [bool; AXES],
    pulse: u32,
    dir_setup: u32,
    min_interval: u32,
    /// Position in steps from the executed steps.
    pub position: [i32; AXES],
    /// Figures of the run so far.
    pub stats: StepStats,
}

impl Stepper {
    /// For a validated printer.
    pub fn new(cfg: &PrinterConfig) -> Stepper {
        let pulse = cfg.ns_to_ticks(cfg.step_pulse_ns);
        let mut invert = [false; AXES];
        for (i, a) in cfg.axes.iter().enumerate() {
            invert[i] = a.invert_dir;
        }
        Stepper {
            ring: heapless::Deque::new(),
            current: Segment::still(SegmentKind::Dwell, 0),
            pending: None,
            last_low: 0,
            phase: Phase::Idle,
            acc: [0; AXES],
            steps: [0; AXES],
            major: 0,
            left: 0,
            base: 0,
            rem: 0,
            err: 0,
            seg_end: 0,
            seg_ticks: 0,
            next_tick: 0,
            raised: [false; AXES],
            dir_level: [None; AXES],
            invert,
            pulse,
            dir_setup: cfg.ns_to_ticks(cfg.dir_setup_ns),
            // A pulse, a gap as long, and a tick of slack.
            min_interval: 2 * pulse + 1,
            position: [0; AXES],
            stats: StepStats {
                min_interval: u32::MAX,
                ..StepStats::default()
            },
        }
    }

    /// Takes `position` (steps) as where the axes are, and forgets the direction pins'
    /// levels (homing moved them).
    pub fn set_position(&mut self, position: [i32; AXES]) {
        self.position = position;
        self.dir_level = [None; AXES];
    }

    /// The duration of the segment being stepped, ticks (as stretched to keep the pulses
    /// apart).
    pub fn segment_ticks(&self) -> u32 {
        self.seg_ticks
    }

    /// Whether nothing is being stepped.
    pub fn is_idle(&self) -> bool {
        self.phase == Phase::Idle
    }

    /// Whether it stopped at a pause segment.
    pub fn is_paused(&self) -> bool {
        self.phase == Phase::Paused
    }

    /// Continues after a pause (from `now`).
    pub fn resume(&mut self) {
        if self.phase == Phase::Paused {
            self.phase = Phase::Idle;
        }
    }

    /// Tops the ring up from `gen`, by at most `most` segments.
    pub fn fill<const N: usize>(
        &mut self,
        gen: &mut SegmentGen,
        planner: &mut Planner<N>,
        most: usize,
    ) {
        for _ in 0..most {
            if self.ring.is_full() {
                break;
            }
            let Some(s) = self.pending.take().or_else(|| gen.next(planner)) else {
                break;
            };
            if let Err(s) = self.ring.push_back(s) {
                // Not reached (the ring had room); kept for the next fill all the same.
                self.pending = Some(s);
                break;
            }
        }
    }

    /// Drops every segment and lowers the step pins (a fault).
    pub fn stop<B: Board>(&mut self, board: &mut B) {
        self.ring.clear();
        self.pending = None;
        self.phase = Phase::Idle;
        self.left = 0;
        for i in 0..AXES {
            // Shutting down: a pin that refuses now cannot be helped.
            if board.step(i).set_low().is_ok() {
                self.raised[i] = false;
            }
        }
    }

    /// Loads the next prepared segment to start at `start` (idle if there is none);
    /// whether it is a pause.
    fn load(&mut self, start: Ticks) -> bool {
        let Some(seg) = self.ring.pop_front() else {
            self.phase = Phase::Idle;
            return false;
        };
        self.current = seg;
        self.stats.segments += 1;
        if seg.kind == SegmentKind::Pause {
            self.phase = Phase::Paused;
            return true;
        }
        let mut major = 0;
        for i in 0..AXES {
            self.steps[i] = seg.steps[i] as u32;
            major = major.max(self.steps[i]);
        }
        let mut ticks = seg.ticks;
        if major > 0 && ticks / major < self.min_interval {
            ticks = major * self.min_interval;
            self.stats.stretched += 1;
        }
        self.major = major;
        self.left = major;
        self.seg_ticks = ticks;
        self.stats.ticks += ticks as u64;
        self.seg_end = start.wrapping_add(ticks);
        if let Some(base) = ticks.checked_div(major) {
            self.base = base;
            self.rem = ticks % major;
            self.err = 0;
            // Accumulators start half full: the steps are centred in the segment.
            for a in &mut self.acc {
                *a = major / 2;
            }
            self.next_tick = start.wrapping_add(base / 2);
            self.stats.min_interval = self.stats.min_interval.min(base);
            self.phase = Phase::Tick;
        } else {
            self.phase = Phase::SegmentEnd;
        }
        false
    }

    /// Runs the alarm due at `now`: returns the next deadline, or `None` when idle or
    /// paused. `at_pause` is set when a pause segment was reached.
    pub fn on_alarm<B: Board>(
        &mut self,
        now: Ticks,
        board: &mut B,
        at_pause: &mut bool,
    ) -> Result<Option<Ticks>, PinFault> {
        // Each pass either returns or moves to a later phase; a few passes at most.
        for _ in 0..4 {
            match self.phase {
                Phase::Paused => return Ok(None),
                Phase::Idle => {
                    if self.ring.is_empty() {
                        return Ok(None);
                    }
                    // Whatever pulse came last ended at least a pulse ago by the first tick.
                    self.last_low = now;
                    *at_pause |= self.load(now);
                    self.set_dirs(now, board)?;
                }
                Phase::SegmentEnd => {
                    if before(now, self.seg_end) {
                        return Ok(Some(self.seg_end));
                    }
                    *at_pause |= self.load(self.seg_end);
                    self.set_dirs(now, board)?;
                }
                Phase::Tick => {
                    // A late alarm never shortens the gap after a pulse.
                    let earliest = self.last_low.wrapping_add(self.pulse);
                    if before(self.next_tick, earliest) {
                        self.next_tick = earliest;
                    }
                    if before(now, self.next_tick) {
                        return Ok(Some(self.next_tick));
                    }
                    self.tick(board)?;
                    return Ok(Some(now.wrapping_add(self.pulse)));
                }
                Phase::Lower => {
                    for i in 0..AXES {
                        if self.raised[i] {
                            board
                                .step(i)
                                .set_low()
                                .map_err(|_| PinFault { axis: i as u8 })?;
                            self.raised[i] = false;
                        }
                    }
                    self.last_low = now;
                    let (phase, at) = if self.left > 0 {
                        (Phase::Tick, self.next_tick)
                    } else {
                        (Phase::SegmentEnd, self.seg_end)
                    };
                    self.phase = phase;
                    if before(now, at) {
                        return Ok(Some(at));
                    }
                }
            }
        }
        Ok(Some(now))
    }

    /// Sets the direction pins of the loaded segment; a change delays its first step by the
    /// setup time.
    fn set_dirs<B: Board>(&mut self, now: Ticks, board: &mut B) -> Result<(), PinFault> {
        if self.phase != Phase::Tick {
            return Ok(());
        }
        let mut changed = false;
        for i in 0..AXES {
            if self.steps[i] == 0 {
                continue;
            }
            let level = self.current.forward[i] != self.invert[i];
            if self.dir_level[i] != Some(level) {
                let pin = board.dir(i);
                let r = if level { pin.set_high() } else { pin.set_low() };
                r.map_err(|_| PinFault { axis: i as u8 })?;
                self.dir_level[i] = Some(level);
                changed = true;
            }
        }
        let ready = now.wrapping_add(self.dir_setup);
        if changed && before(self.next_tick, ready) {
            self.next_tick = ready;
        }
        Ok(())
    }

    /// One DDA tick: raises the step pins of the axes that step now.
    fn tick<B: Board>(&mut self, board: &mut B) -> Result<(), PinFault> {
        for i in 0..AXES {
            self.acc[i] += self.steps[i];
            if self.acc[i] >= self.major {
                self.acc[i] -= self.major;
                board
                    .step(i)
                    .set_high()
                    .map_err(|_| PinFault { axis: i as u8 })?;
                self.raised[i] = true;
                self.position[i] += if self.current.forward[i] { 1 } else { -1 };
                self.stats.steps[i] += 1;
            }
        }
        self.left -= 1;
        self.err += self.rem;
        let mut interval = self.base;
        if self.err >= self.major {
            self.err -= self.major;
            interval += 1;
        }
        self.next_tick = self.next_tick.wrapping_add(interval);
        self.phase = Phase::Lower;
        Ok(())
    }
}
