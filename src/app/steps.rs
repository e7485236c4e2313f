//! The step side of a job: what the step timer's interrupt owns.
//!
//! ```text
//!  layer generator ──Move──► queue (MOVE_QUEUE) ──top-up──► look-ahead ──► segments ──► pins
//!  (the application's loop)   └──────────── Stepping, behind the platform's lock ───────────┘
//!                                               ▲ on_alarm(deadline): the step interrupt
//! ```
//!
//! A [`Stepping`] holds the job's [`Machine`], the board it drives and a short queue of the
//! layer's moves. The application's loop generates the layer and offers its moves to the
//! queue ([`Stepping::offer`]); the step interrupt ([`Stepping::on_alarm`]) first tops the
//! machine's look-ahead up from the queue, then runs the machine's alarm, and keeps the
//! deadline it returns for the platform's timer. So the steps keep their times while the
//! application computes (a layer's generator may take longer for one vertex than a step
//! period), and the application only waits when the queue is full.
//!
//! The machine sees the same blocks at the same alarms as the host's virtual printer,
//! whatever the platform: every alarm of a layer runs with the look-ahead full (topped up
//! from the queue), except once the layer's last move is queued ([`Stepping::end_layer`]);
//! and a layer starts from rest only once the look-ahead can be filled or the layer ended
//! ([`Stepping::start`]). An alarm that finds the queue empty while the layer is still being
//! generated runs with a short look-ahead (the ring's tail always able to stop, so the motion
//! stays within its limits): it is counted ([`Stepping::starved`]), and a layer with any
//! such alarm may differ from the host's figures. A platform implements [`Steps`]: its lock
//! (a critical section on a controller), the kick that makes its timer interrupt run, and
//! its wait (`wfi`; or, on a host, running the alarm due next on a virtual clock).

use heapless::Deque;

use super::io::{self, Io};
use super::LOOK_AHEAD;
use crate::motion::machine::Fault;
use crate::motion::stepper::{before, Ticks};
use crate::motion::{Board, Machine, Refused, State};
use crate::toolpath::moves::Move;

/// Moves queued between the layer's generator and the machine's look-ahead (twice the
/// look-ahead: a full queue always fills it).
pub const MOVE_QUEUE: usize = 2 * LOOK_AHEAD;

/// The step side of a job (the module's essay).
pub struct Stepping<B> {
    machine: Option<Machine<LOOK_AHEAD>>,
    board: B,
    queue: Deque<Move, MOVE_QUEUE>,
    z: f32,
    /// The layer's last move is queued (or no layer runs).
    ended: bool,
    deadline: Option<Ticks>,
    refused: Option<Refused>,
    starved: u32,
}

impl<B: Board> Stepping<B> {
    /// No job yet, on `board`.
    pub const fn new(board: B) -> Self {
        Stepping {
            machine: None,
            board,
            queue: Deque::new(),
            z: 0.0,
            ended: true,
            deadline: None,
            refused: None,
            starved: 0,
        }
    }

    /// The board.
    pub fn board(&mut self) -> &mut B {
        &mut self.board
    }

    /// The job's machine, if a job ran.
    pub fn machine(&self) -> Option<&Machine<LOOK_AHEAD>> {
        self.machine.as_ref()
    }

    /// Installs a new job's machine (the last one is dropped: it is at rest or stopped).
    pub fn install(&mut self, machine: Machine<LOOK_AHEAD>) {
        self.queue.clear();
        self.ended = true;
        self.deadline = None;
        self.refused = None;
        self.starved = 0;
        self.machine = Some(machine);
    }

    /// The deadline the step interrupt runs at next (`None`: at rest, paused or stopped).
    pub fn deadline(&self) -> Option<Ticks> {
        self.deadline
    }

    /// The machine's timer frequency (Hz; none without a job).
    pub fn tick_hz(&self) -> Option<u32> {
        self.machine.as_ref().map(|m| m.config().tick_hz)
    }

    /// The machine's state (none without a job).
    pub fn state(&self) -> Option<State> {
        self.machine.as_ref().map(|m| m.state())
    }

    /// Starts a layer at height `z` (the machine at rest).
    pub fn begin_layer(&mut self, z: f32) {
        self.queue.clear();
        self.z = z;
        self.ended = false;
        self.refused = None;
        self.starved = 0;
    }

    /// Queues one of the layer's moves; the move back if the queue is full.
    pub fn offer(&mut self, m: Move) -> Result<(), Move> {
        self.queue.push_back(m)
    }

    /// Whether the queue is full (the generator must wait).
    pub fn queue_full(&self) -> bool {
        self.queue.is_full()
    }

    /// The layer's last move is queued.
    pub fn end_layer(&mut self) {
        self.ended = true;
    }

    /// Whether the layer is stepped out: nothing queued, the machine at rest.
    pub fn layer_done(&self) -> bool {
        self.queue.is_empty()
            && self.deadline.is_none()
            && self.machine.as_ref().is_none_or(|m| m.is_done())
    }

    /// The move the machine refused since the layer began, if any.
    pub fn refused(&self) -> Option<Refused> {
        self.refused
    }

    /// Alarms of this layer that ran with the look-ahead short of moves while the layer was
    /// still being generated (the module's essay): 0 when the generator kept ahead.
    pub fn starved(&self) -> u32 {
        self.starved
    }

    /// Starts the step interrupt at `now` if the machine is at rest and has work: homing, or
    /// a layer whose look-ahead the queue fills (or whose last move is queued). Whether the
    /// platform must kick its timer.
    pub fn start(&mut self, now: Ticks) -> bool {
        let Some(m) = self.machine.as_ref() else {
            return false;
        };
        if self.deadline.is_some() {
            return false;
        }
        let ready = match m.state() {
            State::Homing => true,
            State::Ready => {
                self.top_up();
                let m = self.machine.as_ref();
                !m.is_none_or(|m| m.is_done())
                    && (self.ended || m.is_some_and(|m| m.planner().is_full()))
            }
            _ => false,
        };
        if ready {
            self.deadline = Some(now);
        }
        ready
    }

    /// Tops the look-ahead up from the queue. A refused move stops the machine (valves
    /// first) and is kept for the application.
    fn top_up(&mut self) {
        let Some(m) = self.machine.as_mut() else {
            return;
        };
        while !m.planner().is_full() {
            let Some(mv) = self.queue.pop_front() else {
                break;
            };
            match m.push_move(&mv, self.z) {
                Ok(()) => {}
                Err(Refused::Full) => {
                    // Not reached (the ring had room); kept for the next top-up all the same.
                    if self.queue.push_front(mv).is_err() {
                        self.refused = Some(Refused::Full);
                    }
                    break;
                }
                Err(why) => {
                    self.refused = Some(why);
                    let fault = match why {
                        Refused::Stopped(f) => f,
                        _ => Fault::Aborted,
                    };
                    m.shutdown(&mut self.board, fault);
                    self.queue.clear();
                    break;
                }
            }
        }
    }

    /// The step interrupt, at the deadline it asked for (however late the platform runs it:
    /// the machine's times are its own): tops the look-ahead up, runs the machine's alarm;
    /// the next deadline (kept, see [`deadline`](Self::deadline)).
    pub fn on_alarm(&mut self, now: Ticks) -> Option<Ticks> {
        self.top_up();
        let Some(m) = self.machine.as_mut() else {
            self.deadline = None;
            return None;
        };
        if m.state() == State::Ready && !self.ended && !m.planner().is_full() {
            self.starved = self.starved.saturating_add(1);
        }
        self.deadline = m.on_alarm(now, &mut self.board);
        if self.deadline.is_none() && m.state() == State::Ready && !m.is_done() {
            // The last segment ended as the top-up brought blocks (a starved look-ahead
            // refilled): the machine is at rest with work, so start it again at once, as
            // an alarm from rest does (with what the queue holds now).
            self.top_up();
            if let Some(m) = self.machine.as_mut() {
                self.deadline = m.on_alarm(now, &mut self.board);
            }
        }
        self.deadline
    }

    /// Runs the interrupt's alarms that are due at `now`, at most `most`; the deadline left
    /// (`None`: at rest). A board's timer interrupt calls this and arms its compare for the
    /// deadline returned.
    pub fn run_due(&mut self, now: Ticks, most: u32) -> Option<Ticks> {
        for _ in 0..most {
            match self.deadline {
                Some(d) if !before(now, d) => {
                    self.on_alarm(d);
                }
                other => return other,
            }
        }
        self.deadline
    }

    /// Asks the machine to pause at its next block boundary.
    pub fn pause(&mut self) {
        if let Some(m) = self.machine.as_mut() {
            m.pause();
        }
    }

    /// Continues a paused machine from `now`; whether the platform must kick its timer.
    pub fn resume(&mut self, now: Ticks) -> bool {
        match self.machine.as_mut() {
            Some(m) if m.state() == State::Paused => {
                m.resume();
                self.deadline = Some(now);
                true
            }
            _ => false,
        }
    }

    /// Starts homing from `now`; whether the platform must kick its timer.
    pub fn start_homing(&mut self, now: Ticks) -> bool {
        let Some(m) = self.machine.as_mut() else {
            return false;
        };
        m.start_homing();
        self.start(now)
    }

    /// The one way down ([`Machine::shutdown`]: valves first, then the motors); the queue
    /// dropped.
    pub fn shutdown(&mut self, fault: Fault) {
        self.queue.clear();
        self.deadline = None;
        if let Some(m) = self.machine.as_mut() {
            m.shutdown(&mut self.board, fault);
        }
    }
}

/// The step side as a platform shares it between its step interrupt and the application.
pub trait Steps {
    /// The printer's pins.
    type Board: Board;
    /// Runs `f` on the step side with the step interrupt held off (a critical section on a
    /// controller). Never held across planning or stepping by the application.
    fn lock<R>(&self, f: impl FnOnce(&mut Stepping<Self::Board>) -> R) -> R;
    /// The step side got a deadline while its interrupt was idle: make the interrupt run
    /// (pend it, or arm the timer for [`Stepping::deadline`]).
    fn kick(&self);
    /// The application has nothing to do until the step interrupt ran (or a byte arrived):
    /// sleep until an interrupt (a controller), or run the alarm due next on a virtual
    /// clock (a host).
    fn wait<I: Io>(&self, io: &mut I);
}

/// [`Steps`] on a host: the step side in a [`RefCell`](core::cell::RefCell), its interrupt
/// run by [`wait`](Steps::wait) at the deadline due next, the platform's clock jumped
/// there ([`Io::sleep`]) as QEMU's `-icount sleep=off` jumps idle time. The application
/// then waits only when the queue is full or the layer ends, and every alarm finds the
/// queue full: a host's run starves never.
pub struct Lockstep<B>(pub core::cell::RefCell<Stepping<B>>);

impl<B: Board> Lockstep<B> {
    /// No job yet, on `board`.
    pub const fn new(board: B) -> Self {
        Lockstep(core::cell::RefCell::new(Stepping::new(board)))
    }
}

impl<B: Board> Steps for Lockstep<B> {
    type Board = B;
    fn lock<R>(&self, f: impl FnOnce(&mut Stepping<B>) -> R) -> R {
        f(&mut self.0.borrow_mut())
    }
    fn kick(&self) {}
    fn wait<I: Io>(&self, io: &mut I) {
        let mut s = self.0.borrow_mut();
        let (Some(d), Some(hz)) = (s.deadline(), s.tick_hz()) else {
            drop(s);
            io.sleep(None);
            return;
        };
        let now = io.now_us();
        let wait = io::us_until(io::ticks_at(now, hz), d, hz);
        if wait > 0 {
            io.sleep(Some(now + wait));
        }
        s.on_alarm(d);
    }
}
