//! A job's layers streamed into one [`Machine`](crate::motion::Machine): the routine the
//! controller application prints with and the host's `simulate` counts its telemetry with,
//! so that the two agree exactly.
//!
//! Layer `k` is the zigzag along the MCLs on even `k` and the offset spiral on odd `k`
//! ([`layer_path`], as host-sim's `layers::layer(.., Fill::Offset, k)`), at height
//! `(k + 1) x layer_height` ([`layer_z`]). The layer is never stored: [`Feed`] is its
//! [`PathSink`], cuts each vertex pair into moves ([`split`]), the first vertex reached by a
//! travel from wherever the nozzle is, and queues them for the step side
//! ([`Stepping`]), whose interrupt tops the machine's look-ahead up
//! from that queue at every alarm. When the queue is full the feed starts the step
//! interrupt if the machine is at rest and asks its [`Drive`] to wait; at the end of the
//! layer it waits until the machine is at rest. Every alarm of a layer therefore runs with
//! the look-ahead full (or after the layer's last move), whatever drives it (a virtual
//! clock on the host, the step timer on the controller), and the machine counts the same
//! steps, valve openings and ticks; an alarm that ran short is counted
//! ([`Printed::starved`]).

use super::steps::Stepping;
use crate::field::GridMemory;
use crate::motion::machine::{Counters, Fault};
use crate::motion::stepper::Ticks;
use crate::motion::{Board, PrinterConfig, Refused, State};
use crate::toolpath::moves::{split, Move};
use crate::toolpath::offset::OffsetSpiral;
use crate::toolpath::zigzag::zigzag;
use crate::toolpath::{PathSink, Vertex};
use crate::{Error, Plan, Slice};

/// Builds layer `index`'s path into `sink`: the zigzag on even layers, the offset spiral on
/// odd ones and on every layer of a slice without a hollow feature (its distance grid in
/// `grid`, the planner's lent field memory on a controller).
pub fn layer_path(
    slice: &Slice,
    plan: &Plan,
    offset: &mut OffsetSpiral,
    grid: &mut GridMemory,
    index: usize,
    sink: &mut impl PathSink,
) -> Result<(), Error> {
    // A slice without a hollow feature has no MCLs to zigzag along: every layer is the
    // offset spiral (as the host lays it).
    if index % 2 == 0 && !slice.holes().is_empty() {
        zigzag(slice, plan, sink).map(|_| ())
    } else {
        offset.build(slice, plan, grid, sink).map(|_| ())
    }
}

/// The nozzle's height over layer `index` (the first layer one layer height up).
pub fn layer_z(cfg: &PrinterConfig, index: usize) -> f32 {
    (index + 1) as f32 * cfg.layer_height
}

/// What runs the step side for a [`Feed`]: the platform's lock, clock, kick and wait
/// ([`Steps`](super::steps::Steps) with the link served while waiting, or a host's virtual
/// clock).
pub trait Drive {
    /// The printer's pins.
    type Board: Board;
    /// Why a drive ends the layer early (host gone, abort, ...).
    type Stop;
    /// Runs `f` on the step side (never held across generating or waiting).
    fn lock<R>(&mut self, f: impl FnOnce(&mut Stepping<Self::Board>) -> R) -> R;
    /// The step timer's time now (ticks): where a start from rest puts the first alarm.
    fn now(&mut self) -> Ticks;
    /// The step side got a deadline while its interrupt was idle: make it run.
    fn kick(&mut self);
    /// Nothing to do until the step interrupt ran: wait for it (serving the link, acting on
    /// pause and abort), or end the layer.
    fn wait(&mut self) -> Result<(), Self::Stop>;

    /// Starts the step interrupt if the step side is at rest and has work
    /// ([`Stepping::start`]).
    fn start(&mut self) {
        let now = self.now();
        if self.lock(|s| s.start(now)) {
            self.kick();
        }
    }
}

/// Why a layer did not print to its end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LayerError<S> {
    /// The layer's path could not be built.
    Path(Error),
    /// The machine refused a move.
    Refused(Refused),
    /// The drive stopped the layer.
    Stopped(S),
    /// The machine was not at rest and ready after the layer (its state).
    Unfinished(State),
}

impl<S> LayerError<S> {
    /// The machine fault behind the error, if the machine stopped.
    pub fn fault(&self) -> Option<Fault> {
        match self {
            LayerError::Refused(Refused::Stopped(f)) => Some(*f),
            LayerError::Unfinished(State::Stopped(f)) => Some(*f),
            _ => None,
        }
    }
}

/// A layer's [`PathSink`] that queues its moves for the step side (the module's essay).
pub struct Feed<'a, D: Drive> {
    drive: &'a mut D,
    last: Option<Vertex>,
    stop: Option<LayerError<D::Stop>>,
    /// Moves queued.
    pub moves: u32,
}

impl<'a, D: Drive> Feed<'a, D> {
    /// A feed of a layer at height `z` (the step side at rest).
    pub fn new(drive: &'a mut D, z: f32) -> Self {
        drive.lock(|s| s.begin_layer(z));
        Feed {
            drive,
            last: None,
            stop: None,
            moves: 0,
        }
    }

    /// Why the step side cannot take moves, if it cannot.
    fn refusal(s: &Stepping<D::Board>) -> Option<LayerError<D::Stop>> {
        if let Some(why) = s.refused() {
            return Some(LayerError::Refused(why));
        }
        match s.state() {
            Some(State::Ready | State::Paused) => None,
            Some(State::Stopped(f)) => Some(LayerError::Refused(Refused::Stopped(f))),
            Some(State::Unhomed | State::Homing) => Some(LayerError::Refused(Refused::NotHomed)),
            None => Some(LayerError::Unfinished(State::Unhomed)),
        }
    }

    fn push(&mut self, m: &Move) {
        if self.stop.is_some() {
            return;
        }
        let mut m = *m;
        loop {
            let offered = self.drive.lock(|s| match Self::refusal(s) {
                Some(e) => Err(e),
                None => Ok(s.offer(m)),
            });
            match offered {
                Err(e) => {
                    self.stop = Some(e);
                    return;
                }
                Ok(Ok(())) => {
                    self.moves += 1;
                    return;
                }
                // The queue is full: its moves fill the look-ahead, so a machine at rest
                // starts now; then wait for the step interrupt to take some.
                // (Moves of no whole step take no slot in the look-ahead: a queue of them may
                // not fill it, but then the top-up of the start emptied it: offer again.)
                Ok(Err(back)) => {
                    m = back;
                    self.drive.start();
                    if self.drive.lock(|s| !s.queue_full()) {
                        continue;
                    }
                    if let Err(s) = self.drive.wait() {
                        self.stop = Some(LayerError::Stopped(s));
                        return;
                    }
                }
            }
        }
    }

    /// Steps out what is queued, then checks the machine is at rest and ready.
    pub fn finish(mut self) -> Result<u32, LayerError<D::Stop>> {
        if let Some(e) = self.stop.take() {
            return Err(e);
        }
        self.drive.lock(|s| s.end_layer());
        loop {
            let (refusal, done) = self.drive.lock(|s| (Self::refusal(s), s.layer_done()));
            if let Some(e) = refusal {
                return Err(e);
            }
            if done {
                break;
            }
            self.drive.start();
            // (The start's lock may have let the last alarms run.)
            if !self.drive.lock(|s| s.layer_done()) {
                self.drive.wait().map_err(LayerError::Stopped)?;
            }
        }
        let state = self.drive.lock(|s| s.state());
        if state != Some(State::Ready) {
            return Err(LayerError::Unfinished(state.unwrap_or(State::Unhomed)));
        }
        Ok(self.moves)
    }
}

impl<D: Drive> PathSink for Feed<'_, D> {
    fn push_vertex(&mut self, v: Vertex) -> Result<(), Vertex> {
        if self.stop.is_some() {
            // Ends the generator at once (it reports a full sink; `finish` the reason).
            return Err(v);
        }
        match self.last {
            // The layer's first vertex: travel there from where the nozzle is (a block's
            // target is all the machine takes from a move).
            None => self.push(&Move {
                from: v.at,
                to: v.at,
                width: v.width,
                material: v.material,
                deposit: false,
            }),
            Some(a) => split(&a, &v, |m| self.push(&m)),
        }
        self.last = Some(v);
        if self.stop.is_some() {
            return Err(v);
        }
        Ok(())
    }

    fn last_vertex(&self) -> Option<Vertex> {
        self.last
    }
}

/// What a layer drove: the machine's figures over it, and the alarms that ran short of moves
/// ([`Stepping::starved`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Printed {
    /// What the machine drove over the layer.
    pub counters: Counters,
    /// Alarms that ran with the look-ahead short while the layer was being generated.
    pub starved: u32,
}

/// Prints layer `index` of the job on the drive's machine (homed, at rest): its path
/// generated into the step side's queue while the step interrupt runs, then stepped to the
/// end. What the machine drove over it (the layer's telemetry).
pub fn print_layer<D: Drive>(
    slice: &Slice,
    plan: &Plan,
    offset: &mut OffsetSpiral,
    grid: &mut GridMemory,
    index: usize,
    drive: &mut D,
) -> Result<Printed, LayerError<D::Stop>> {
    let Some((before, z)) = drive.lock(|s| {
        s.machine()
            .map(|m| (m.counters(), layer_z(m.config(), index)))
    }) else {
        return Err(LayerError::Unfinished(State::Unhomed));
    };
    let mut feed = Feed::new(drive, z);
    let built = layer_path(slice, plan, offset, grid, index, &mut feed);
    if feed.stop.is_none() {
        built.map_err(LayerError::Path)?;
    }
    feed.finish()?;
    Ok(drive.lock(|s| Printed {
        counters: s
            .machine()
            .map(|m| m.counters().since(&before))
            .unwrap_or_default(),
        starved: s.starved(),
    }))
}

/// Homes the drive's machine (from any state it can home from).
pub fn home<D: Drive>(drive: &mut D) -> Result<(), LayerError<D::Stop>> {
    let now = drive.now();
    if drive.lock(|s| s.start_homing(now)) {
        drive.kick();
    }
    loop {
        let (state, running) = drive.lock(|s| (s.state(), s.deadline().is_some()));
        match state {
            Some(State::Homing) if running => drive.wait().map_err(LayerError::Stopped)?,
            Some(State::Ready) => return Ok(()),
            s => return Err(LayerError::Unfinished(s.unwrap_or(State::Unhomed))),
        }
    }
}
