//! A mock printer board for the motion tests: pins that record every edge and duty with the
//! virtual time, inputs driven by the trace (endstops by the position the steps reached, the
//! emergency stop at a set time), and the loop that jumps a virtual clock from alarm to alarm.
#![allow(dead_code)]

use std::cell::RefCell;
use std::convert::Infallible;
use std::rc::Rc;

use embedded_hal::digital::{ErrorType, InputPin, OutputPin};
use embedded_hal::pwm::{self, SetDutyCycle};
use hollowpath::motion::config::AXES;
use hollowpath::motion::{Board, Machine, PrinterConfig, Refused, State};
use hollowpath::toolpath::moves::Move;

/// Which output an edge is on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pin {
    Step(usize),
    Dir(usize),
}

/// One output edge (a write that changed the level).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Edge {
    pub t: u64,
    pub pin: Pin,
    pub high: bool,
    /// Order among all writes (edges and duties).
    pub seq: u64,
}

/// Everything the pins saw.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trace {
    /// Virtual time, ticks (unwrapped).
    pub now: u64,
    pub edges: Vec<Edge>,
    /// (time, channel, duty as a fraction of the maximum).
    pub duties: Vec<(u64, usize, f32)>,
    /// Order of each duty write among all writes.
    pub duty_seq: Vec<u64>,
    /// Writes so far.
    pub writes: u64,
    /// Step and direction levels per axis.
    pub levels: [[bool; 2]; AXES],
    /// Steps from the start per axis, counted from the edges as a motor would.
    pub position: [i64; AXES],
    /// Whether a direction pin high is the positive direction, per axis.
    pub dir_high_positive: [bool; AXES],
    /// The endstop of each axis is hit at or below this position (steps from the start).
    pub endstop_at: [i64; AXES],
    /// The emergency stop is pressed from this time on.
    pub estop_at: Option<u64>,
    /// This valve channel refuses every duty written to it.
    pub broken_valve: Option<usize>,
}

pub type Shared = Rc<RefCell<Trace>>;

pub struct Out {
    pin: Pin,
    trace: Shared,
}

impl ErrorType for Out {
    type Error = Infallible;
}

impl Out {
    fn set(&mut self, high: bool) {
        let mut t = self.trace.borrow_mut();
        let (axis, k) = match self.pin {
            Pin::Step(a) => (a, 0),
            Pin::Dir(a) => (a, 1),
        };
        if t.levels[axis][k] == high {
            return;
        }
        t.levels[axis][k] = high;
        if k == 0 && high {
            let forward = t.levels[axis][1] == t.dir_high_positive[axis];
            t.position[axis] += if forward { 1 } else { -1 };
        }
        let now = t.now;
        t.writes += 1;
        let seq = t.writes;
        t.edges.push(Edge {
            t: now,
            pin: self.pin,
            high,
            seq,
        });
    }
}

impl OutputPin for Out {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.set(false);
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.set(true);
        Ok(())
    }
}

pub enum InKind {
    Endstop(usize),
    EStop,
}

pub struct In {
    kind: InKind,
    trace: Shared,
}

impl ErrorType for In {
    type Error = Infallible;
}

impl InputPin for In {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        let t = self.trace.borrow();
        Ok(match self.kind {
            InKind::Endstop(a) => t.position[a] <= t.endstop_at[a],
            InKind::EStop => t.estop_at.is_some_and(|at| t.now >= at),
        })
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        self.is_high().map(|h| !h)
    }
}

pub struct Pwm {
    channel: usize,
    trace: Shared,
}

/// What a broken output answers.
#[derive(Debug)]
pub struct Broken;

impl pwm::Error for Broken {
    fn kind(&self) -> pwm::ErrorKind {
        pwm::ErrorKind::Other
    }
}

impl pwm::ErrorType for Pwm {
    type Error = Broken;
}

pub const MAX_DUTY: u16 = 10_000;

impl SetDutyCycle for Pwm {
    fn max_duty_cycle(&self) -> u16 {
        MAX_DUTY
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Broken> {
        let mut t = self.trace.borrow_mut();
        if t.broken_valve == Some(self.channel) {
            return Err(Broken);
        }
        let now = t.now;
        t.writes += 1;
        let seq = t.writes;
        t.duty_seq.push(seq);
        t.duties
            .push((now, self.channel, duty as f32 / MAX_DUTY as f32));
        Ok(())
    }
}

pub struct MockBoard {
    pub trace: Shared,
    step: Vec<Out>,
    dir: Vec<Out>,
    endstop: Vec<In>,
    estop: In,
    valves: Vec<Pwm>,
}

impl MockBoard {
    pub fn new(cfg: &PrinterConfig) -> MockBoard {
        let trace: Shared = Rc::new(RefCell::new(Trace {
            dir_high_positive: [0, 1, 2].map(|a| !cfg.axes[a].invert_dir),
            endstop_at: [i64::MIN; AXES],
            ..Trace::default()
        }));
        let out = |pin| Out {
            pin,
            trace: trace.clone(),
        };
        MockBoard {
            step: (0..AXES).map(|a| out(Pin::Step(a))).collect(),
            dir: (0..AXES).map(|a| out(Pin::Dir(a))).collect(),
            endstop: (0..AXES)
                .map(|a| In {
                    kind: InKind::Endstop(a),
                    trace: trace.clone(),
                })
                .collect(),
            estop: In {
                kind: InKind::EStop,
                trace: trace.clone(),
            },
            valves: (0..4)
                .map(|channel| Pwm {
                    channel,
                    trace: trace.clone(),
                })
                .collect(),
            trace,
        }
    }
}

impl Board for MockBoard {
    type Out = Out;
    type In = In;
    type Pwm = Pwm;
    fn step(&mut self, axis: usize) -> &mut Out {
        &mut self.step[axis]
    }
    fn dir(&mut self, axis: usize) -> &mut Out {
        &mut self.dir[axis]
    }
    fn endstop(&mut self, axis: usize) -> &mut In {
        &mut self.endstop[axis]
    }
    fn estop(&mut self) -> &mut In {
        &mut self.estop
    }
    fn valve(&mut self, channel: usize) -> &mut Pwm {
        &mut self.valves[channel]
    }
}

/// Drives a machine on a virtual clock: alarms at the deadlines it asks for, the layer's
/// moves pushed whenever the look-ahead has room.
pub struct Driver<const N: usize> {
    pub machine: Box<Machine<N>>,
    pub board: MockBoard,
    /// The wrapping timer value (starts near the wrap, so wrapping is exercised).
    pub ticks: u32,
    pub alarms: u64,
}

impl<const N: usize> Driver<N> {
    pub fn new(cfg: PrinterConfig) -> Driver<N> {
        let board = MockBoard::new(&cfg);
        Driver {
            machine: Box::new(Machine::new(cfg).unwrap()),
            board,
            ticks: u32::MAX - 500_000,
            alarms: 0,
        }
    }

    pub fn now(&self) -> u64 {
        self.board.trace.borrow().now
    }

    /// One alarm at the current time; the deadline it set, if any, is jumped to.
    pub fn alarm(&mut self) -> bool {
        self.alarms += 1;
        match self.machine.on_alarm(self.ticks, &mut self.board) {
            Some(at) => {
                let dt = at.wrapping_sub(self.ticks);
                assert!(dt < 1 << 30, "a deadline in the past or too far: {dt}");
                self.ticks = at;
                self.board.trace.borrow_mut().now += dt as u64;
                true
            }
            None => false,
        }
    }

    /// Lets `ticks` of virtual time pass with no alarm.
    pub fn wait(&mut self, ticks: u32) {
        self.ticks = self.ticks.wrapping_add(ticks);
        self.board.trace.borrow_mut().now += ticks as u64;
    }

    /// Homes (the machine starts `start` steps above each endstop).
    pub fn home(&mut self, start: [i64; AXES]) {
        self.board.trace.borrow_mut().endstop_at = start.map(|s| -s);
        self.machine.start_homing();
        while self.alarm() {}
        assert_eq!(self.machine.state(), State::Ready);
        // The motion code now counts from home: so does the trace.
        self.board.trace.borrow_mut().position = [0; AXES];
    }

    /// Takes the machine as homed where it stands (no endstops configured).
    pub fn home_in_place(&mut self) {
        self.home([0; AXES]);
    }

    /// Runs `moves` at height `z` to the end (or until `stop` says so after an alarm).
    pub fn run(&mut self, moves: &[Move], z: f32, mut stop: impl FnMut(&mut Self) -> bool) {
        let mut next = 0;
        let mut idle = 0;
        loop {
            while next < moves.len() {
                match self.machine.push_move(&moves[next], z) {
                    Ok(()) => next += 1,
                    Err(Refused::Full) => break,
                    Err(e) => panic!("move {next} refused: {e:?}"),
                }
            }
            let stepped = self.alarm();
            if stop(self) {
                return;
            }
            if !stepped {
                idle += 1;
                if next == moves.len() && self.machine.is_done() || idle > 3 {
                    return;
                }
            } else {
                idle = 0;
            }
        }
    }
}

/// A config without endstops (homing takes the start as home) and with axes that home
/// nowhere.
pub fn no_endstops(mut cfg: PrinterConfig) -> PrinterConfig {
    for a in &mut cfg.axes {
        a.endstop = None;
    }
    cfg
}

/// The signed steps per axis the trace moved from its start.
pub fn net_steps(trace: &Trace) -> [i64; AXES] {
    trace.position
}

/// Position per axis after each rising step edge: (time, position).
pub fn positions(trace: &Trace) -> Vec<(u64, [i64; AXES])> {
    let mut dir = [false; AXES];
    let mut pos = [0i64; AXES];
    let mut out = Vec::new();
    for e in &trace.edges {
        match e.pin {
            Pin::Dir(a) => dir[a] = e.high,
            Pin::Step(a) if e.high => {
                pos[a] += if dir[a] == trace.dir_high_positive[a] {
                    1
                } else {
                    -1
                };
                out.push((e.t, pos));
            }
            Pin::Step(_) => {}
        }
    }
    out
}

/// The duty of `channel` at time `t` from the trace (0 before any write).
pub fn duty_at(trace: &Trace, channel: usize, t: u64) -> f32 {
    let mut d = 0.0;
    for &(at, c, duty) in &trace.duties {
        if at > t {
            break;
        }
        if c == channel {
            d = duty;
        }
    }
    d
}

/// Where a path ends, in steps (rounded as a printer must, from the absolute position).
pub fn expected_steps(cfg: &PrinterConfig, end: [f32; AXES]) -> [i64; AXES] {
    let mut s = [0; AXES];
    for a in 0..AXES {
        let spm = cfg.axes[a].steps_per_mm;
        s[a] = (end[a] * spm).round() as i64 - (cfg.home[a] * spm).round() as i64;
    }
    s
}

/// Per step pin: every pulse at least `pulse` ticks; every step at least `setup` ticks after
/// its axis' last direction change, and no direction change while a step is high.
pub fn check_pulses(trace: &Trace, pulse: u64, setup: u64) -> Result<(), String> {
    let mut rise: [Option<u64>; AXES] = [None; AXES];
    let mut dir_change = [0u64; AXES];
    let mut pulses = 0;
    for e in &trace.edges {
        match (e.pin, e.high) {
            (Pin::Step(a), true) => {
                if dir_change[a] > 0 && e.t < dir_change[a] + setup {
                    return Err(format!(
                        "axis {a}: step at {} only {} ticks after its direction changed",
                        e.t,
                        e.t - dir_change[a]
                    ));
                }
                rise[a] = Some(e.t);
            }
            (Pin::Step(a), false) => {
                let r = rise[a].take().ok_or("a step pin fell without rising")?;
                if e.t - r < pulse {
                    return Err(format!("axis {a}: pulse of {} ticks at {r}", e.t - r));
                }
                pulses += 1;
            }
            (Pin::Dir(a), _) => {
                if rise[a].is_some() {
                    return Err(format!(
                        "axis {a}: direction changed during a step at {}",
                        e.t
                    ));
                }
                dir_change[a] = e.t;
            }
        }
    }
    if pulses == 0 {
        return Err("no pulses".into());
    }
    Ok(())
}
