//! A job's layers streamed into one [`Machine`]: the routine the controller application
//! prints with and the host's `simulate` counts its telemetry with, so that the two agree
//! exactly.
//!
//! Layer `k` is the zigzag along the MCLs on even `k` and the offset spiral on odd `k`
//! ([`layer_path`], as host-sim's `layers::layer(.., Fill::Offset, k)`), at height
//! `(k + 1) x layer_height` ([`layer_z`]). The layer is never stored: [`Feed`] is its
//! [`PathSink`], cuts each vertex pair into moves ([`split`]), the first vertex reached by a
//! travel from wherever the nozzle is, and pushes them into the machine. Whenever the
//! look-ahead is full it asks its [`Drive`] for one step interrupt, and at the end of the
//! layer it runs them until the machine is at rest. The machine therefore sees the same
//! sequence of pushes and alarms whatever drives it (a virtual clock on the host, the
//! step timer on the controller), and counts the same steps, valve openings and ticks.

use crate::motion::machine::{Counters, Fault};
use crate::motion::{Machine, PrinterConfig, Refused, State};
use crate::toolpath::moves::{split, Move};
use crate::toolpath::offset::OffsetSpiral;
use crate::toolpath::zigzag::zigzag;
use crate::toolpath::{PathSink, Vertex};
use crate::{Error, Plan, Slice};

/// Builds layer `index`'s path into `sink`: the zigzag on even layers, the offset spiral on
/// odd ones.
pub fn layer_path(
    slice: &Slice,
    plan: &Plan,
    offset: &mut OffsetSpiral,
    index: usize,
    sink: &mut impl PathSink,
) -> Result<(), Error> {
    if index % 2 == 0 {
        zigzag(slice, plan, sink).map(|_| ())
    } else {
        offset.build(slice, plan, sink).map(|_| ())
    }
}

/// The nozzle's height over layer `index` (the first layer one layer height up).
pub fn layer_z(cfg: &PrinterConfig, index: usize) -> f32 {
    (index + 1) as f32 * cfg.layer_height
}

/// What runs the machine's step interrupt for a [`Feed`].
pub trait Drive<const N: usize> {
    /// Why a drive ends the layer early (host gone, abort, ...).
    type Stop;
    /// Runs one [`Machine::on_alarm`] (at the deadline it asked for last, or at once when it
    /// was idle); whether it asked for another (`false`: the machine is at rest).
    fn alarm(&mut self, machine: &mut Machine<N>) -> Result<bool, Self::Stop>;
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

/// A layer's [`PathSink`] that pushes its moves into the machine (the module's essay).
pub struct Feed<'a, const N: usize, D: Drive<N>> {
    machine: &'a mut Machine<N>,
    drive: &'a mut D,
    z: f32,
    last: Option<Vertex>,
    stop: Option<LayerError<D::Stop>>,
    /// Moves pushed.
    pub moves: u32,
}

impl<'a, const N: usize, D: Drive<N>> Feed<'a, N, D> {
    /// A feed of a layer at height `z`.
    pub fn new(machine: &'a mut Machine<N>, drive: &'a mut D, z: f32) -> Self {
        Feed {
            machine,
            drive,
            z,
            last: None,
            stop: None,
            moves: 0,
        }
    }

    fn push(&mut self, m: &Move) {
        if self.stop.is_some() {
            return;
        }
        loop {
            match self.machine.push_move(m, self.z) {
                Ok(()) => {
                    self.moves += 1;
                    return;
                }
                Err(Refused::Full) => match self.drive.alarm(self.machine) {
                    Ok(true) => {}
                    // At rest with a full look-ahead: it cannot make room.
                    Ok(false) if self.machine.planner().is_full() => {
                        self.stop = Some(LayerError::Unfinished(self.machine.state()));
                        return;
                    }
                    Ok(false) => {}
                    Err(s) => {
                        self.stop = Some(LayerError::Stopped(s));
                        return;
                    }
                },
                Err(why) => {
                    self.stop = Some(LayerError::Refused(why));
                    return;
                }
            }
        }
    }

    /// Steps out what is queued, then checks the machine is at rest and ready.
    pub fn finish(mut self) -> Result<u32, LayerError<D::Stop>> {
        if let Some(e) = self.stop.take() {
            return Err(e);
        }
        loop {
            match self.drive.alarm(self.machine) {
                Ok(true) => {}
                Ok(false) => break,
                Err(s) => return Err(LayerError::Stopped(s)),
            }
        }
        if !self.machine.is_done() || self.machine.state() != State::Ready {
            return Err(LayerError::Unfinished(self.machine.state()));
        }
        Ok(self.moves)
    }
}

impl<const N: usize, D: Drive<N>> PathSink for Feed<'_, N, D> {
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

/// Prints layer `index` of the job on `machine` (homed, at rest): its path streamed in, then
/// stepped to the end. What the machine drove over it (the layer's telemetry).
pub fn print_layer<const N: usize, D: Drive<N>>(
    slice: &Slice,
    plan: &Plan,
    offset: &mut OffsetSpiral,
    index: usize,
    machine: &mut Machine<N>,
    drive: &mut D,
) -> Result<Counters, LayerError<D::Stop>> {
    let before = machine.counters();
    let z = layer_z(machine.config(), index);
    let mut feed = Feed::new(machine, drive, z);
    let built = layer_path(slice, plan, offset, index, &mut feed);
    if feed.stop.is_none() {
        built.map_err(LayerError::Path)?;
    }
    feed.finish()?;
    Ok(machine.counters().since(&before))
}

/// Homes `machine` (from any state it can home from) through `drive`.
pub fn home<const N: usize, D: Drive<N>>(
    machine: &mut Machine<N>,
    drive: &mut D,
) -> Result<(), LayerError<D::Stop>> {
    machine.start_homing();
    while machine.state() == State::Homing {
        if !drive.alarm(machine).map_err(LayerError::Stopped)? {
            break;
        }
    }
    match machine.state() {
        State::Ready => Ok(()),
        s => Err(LayerError::Unfinished(s)),
    }
}
