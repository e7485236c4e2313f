//! The controller application: the link's
//! [`Controller`](crate::link::controller::Controller) and the [`Machine`] in one state
//! machine, generic over the printer's [`Board`] and the platform's [`Io`] (byte stream and
//! clock, both injected).
//!
//! ```text
//!  idle ──slice──► receiving ──EndSlice──► planning ──plan──► idle (planned) ──Start──►
//!  homing ──► printing layer 0, 1, ... ◄──► paused ──► done | aborted | failed ──► idle
//! ```
//!
//! * A slice arrives through the controller's assembler and is built and validated there;
//!   a bad slice comes back to the host as the core's typed error and the application stays
//!   idle. A good one is planned once ([`Planner`]) and its digest reported
//!   ([`Telemetry::Plan`]); then the offset spiral's loops and joins are prepared
//!   ([`OffsetSpiral::prepare`]), so that no spiral layer starts with that work (every odd
//!   layer of the job walks the same loops).
//! * `Start` prints the job on a fresh [`Machine`] for the accepted printer: homing, then
//!   layer after layer on the same machine, z rising, each layer's path streamed straight
//!   into the machine ([`job::print_layer`], the routine the host's `simulate` counts its
//!   telemetry with), the step interrupt run at the deadlines the machine asks for. After
//!   each layer its [`LayerTelemetry`] goes up, with a [`Status`](crate::link::message::Status) (phase, layer, percent)
//!   at each layer's start.
//! * While printing, the link is served between step deadlines: `Pause` stops at the next
//!   block boundary (valves shut), `Resume` continues, `Abort` shuts down. Host silence
//!   past the link's watchdog shuts the machine down at once ([`Fault::HostSilent`]: valves
//!   first, then motion) and the reason is reported when a host greets the controller again.
//!   Every fault goes through [`Machine::shutdown`], valves first. A job that stops early
//!   sends a [`StopReport`] (the fault, the layer, the controller's clock at the stop and
//!   when the host was last heard, the steps driven) after its error, and again after the
//!   hello of every host that greets the controller until the next job starts.
//!
//! [`App::poll`] serves the link and returns the link's next deadline (smoltcp style); a job
//! runs inside the `poll` that received its `Start`, serving the link itself while it
//! prints. The link side, the [`Session`], is not the application's own: it is passed to
//! `poll` behind the platform's lock ([`Shared`]), which the application takes for each
//! call into the session and never across planning or stepping. A controller serves the
//! same session from its receive interrupt ([`Session::serve`]: acks, replies, the host's
//! messages decoded into a queue of events), so the link answers while the application
//! plans a slice or builds a layer, seconds in which its loop reads no byte; the
//! application takes the queued events when it is back in its loop. The step interrupt runs in lockstep with the layer's generator: the generator
//! fills the look-ahead, and the alarm due next runs (at its own deadline, however late the
//! platform woke) whenever the look-ahead is full or the layer ended, so the machine sees
//! the same pushes and alarms as on the host, and counts the same figures. A late wake-up
//! delays steps but never reorders or changes them.

pub mod io;
pub mod job;
pub mod session;
pub mod shared;

use crate::link::controller::Event;
use crate::link::error::LinkError;
use crate::link::message::{CtrlMsg, LayerTelemetry, Phase, RemoteError, StopReport, Telemetry};
use crate::motion::machine::Fault;
use crate::motion::{Board, Machine, State};
use crate::toolpath::offset::OffsetSpiral;
use crate::{Planner, Slice};

pub use io::Io;
use job::{Drive, LayerError};
pub use session::Session;
pub use shared::Shared;

/// Blocks of look-ahead of the application's machine (the host's virtual printer's too).
pub const LOOK_AHEAD: usize = 32;

/// How often the link is served while the machine steps (microseconds).
const SERVE_US: u64 = 500;

/// The controller application (the module's essay). Large (planner, offset spiral,
/// machine): keep it in a `static` (`const fn new`). Its link side, the [`Session`], lives
/// apart behind a [`Shared`] lock, so that a controller's interrupt can serve the link
/// while the application plans.
pub struct App<const HOLES: usize, const POINTS: usize, const W: usize> {
    planner: Planner,
    offset: OffsetSpiral,
    slice: Option<Slice>,
    planned: bool,
    machine: Option<Machine<LOOK_AHEAD>>,
}

impl<const HOLES: usize, const POINTS: usize, const W: usize> App<HOLES, POINTS, W> {
    /// An idle application (its link side is a [`Session`] of its own).
    pub const fn new() -> Self {
        App {
            planner: Planner::new(),
            offset: OffsetSpiral::new(),
            slice: None,
            planned: false,
            machine: None,
        }
    }

    /// The machine of the last job, if any.
    pub fn machine(&self) -> Option<&Machine<LOOK_AHEAD>> {
        self.machine.as_ref()
    }

    /// Serves the link: handles what arrived (planning a slice, running a job to its end),
    /// writes what is due; returns the link's next deadline (microseconds). `link` is the
    /// application's [`Session`], behind the platform's lock (taken for each call into it,
    /// never across planning or stepping).
    pub fn poll<L, I, B>(&mut self, link: &L, io: &mut I, board: &mut B) -> Option<u64>
    where
        L: Shared<Session<HOLES, POINTS, W>>,
        I: Io,
        B: Board,
    {
        while let Some(event) = link.lock(|s| s.next_event(io)) {
            self.on_event(event, link, io, board);
            link.lock(|s| s.flush(io));
        }
        link.lock(|s| s.flush(io))
    }

    fn on_event<L, I, B>(&mut self, event: Event, link: &L, io: &mut I, board: &mut B)
    where
        L: Shared<Session<HOLES, POINTS, W>>,
        I: Io,
        B: Board,
    {
        match event {
            Event::SliceReady => {
                self.planned = false;
                self.slice = None;
                // A refusal was already reported to the host by the controller.
                let slice = link.lock(|s| {
                    s.report(Phase::Receiving, 0, 0, 0);
                    let slice = s.ctrl.finish_slice();
                    if slice.is_ok() {
                        s.report(Phase::Planning, 0, 0, 0);
                    }
                    s.flush(io);
                    slice
                });
                if let Ok(slice) = slice {
                    // Seconds of work: the platform may serve the link meanwhile.
                    let outcome = self.planner.plan(&slice).map(|plan| plan.digest());
                    self.planned = outcome.is_ok();
                    link.lock(|s| {
                        match outcome {
                            Ok(digest) => s.send(CtrlMsg::Telemetry(Telemetry::Plan { digest })),
                            Err(e) => s.send(CtrlMsg::Error(RemoteError::Slice(e))),
                        }
                        s.flush(io);
                    });
                    if self.planned {
                        // The spiral layers' loops and joins now, not between layers 0 and
                        // 1 (where the nozzle would wait). A slice whose spiral cannot be
                        // prepared fails at its first spiral layer with that error (a
                        // one-layer job never needs it).
                        let _spiral_ready = self.offset.prepare(&slice).is_ok();
                    }
                    self.slice = Some(slice);
                }
                link.lock(|s| s.report(Phase::Idle, 0, 0, 0));
            }
            Event::Start => self.run_job(link, io, board),
            // Outside a job there is nothing to pause, resume or abort; a stopped machine
            // stays stopped (a new job builds a new one).
            Event::Pause | Event::Resume | Event::Abort => link.lock(|s| {
                let st = s.status;
                s.report(st.phase, st.layer, st.layers, st.percent);
            }),
            Event::Hello | Event::Printer | Event::Refused(_) => {}
        }
    }

    /// Prints the accepted slice on a fresh machine; ends idle, with the outcome reported.
    fn run_job<L, I, B>(&mut self, link: &L, io: &mut I, board: &mut B)
    where
        L: Shared<Session<HOLES, POINTS, W>>,
        I: Io,
        B: Board,
    {
        let cfg = link.lock(|s| s.ctrl.printer().cloned());
        let (Some(slice), true, Some(cfg)) = (&self.slice, self.planned, cfg) else {
            link.lock(|s| {
                s.send(CtrlMsg::Error(RemoteError::Link(
                    LinkError::UnexpectedMessage,
                )))
            });
            return;
        };
        let layers = link.lock(|s| s.ctrl.layers());
        let machine = match Machine::new(cfg) {
            Ok(m) => self.machine.insert(m),
            Err(e) => {
                link.lock(|s| s.send(CtrlMsg::Error(RemoteError::Printer(e.into()))));
                return;
            }
        };
        let tick_hz = machine.config().tick_hz;
        link.lock(|s| {
            s.report_on_hello = None;
            s.report(Phase::Homing, 0, layers, 0);
        });
        let mut run = Run {
            link,
            io,
            board,
            tick_hz,
            deadline: None,
            served: 0,
            pause_reported: false,
            stopped: None,
            _session: core::marker::PhantomData,
        };
        let mut result = job::home(machine, &mut run);
        let plan = self.planner.last_plan();
        let mut layer = 0u16;
        while result.is_ok() && layer < layers {
            let percent = (layer as u32 * 100 / layers.max(1) as u32) as u8;
            link.lock(|s| {
                s.report(Phase::Printing, layer, layers, percent);
                s.flush(run.io);
            });
            match job::print_layer(
                slice,
                plan,
                &mut self.offset,
                layer as usize,
                machine,
                &mut run,
            ) {
                Ok(c) => {
                    let t = LayerTelemetry::from_counters(layer, &c);
                    link.lock(|s| s.send(CtrlMsg::Telemetry(Telemetry::Layer(t))));
                    layer += 1;
                }
                Err(e) => result = Err(e),
            }
        }
        match result {
            Ok(()) => link.lock(|s| s.report(Phase::Done, layers, layers, 100)),
            Err(e) => {
                // Valves first: a stopped machine already closed them; anything else
                // (a path the core could not build, a refused move) stops it here.
                let fault = e.fault().unwrap_or(match e {
                    LayerError::Stopped(f) => f,
                    _ => Fault::Aborted,
                });
                machine.shutdown(run.board, fault);
                let percent = (layer as u32 * 100 / layers.max(1) as u32) as u8;
                let phase = if fault == Fault::Aborted {
                    Phase::Aborted
                } else {
                    Phase::Failed
                };
                let why = match e {
                    LayerError::Path(err) => RemoteError::Slice(err),
                    _ => RemoteError::Machine(fault),
                };
                let now = run.io.now_us();
                let steps = machine.counters().steps;
                link.lock(|s| {
                    let (at_us, heard_us) = run.stopped.unwrap_or((now, s.ctrl.last_heard()));
                    let stop = StopReport {
                        fault,
                        layer,
                        at_us,
                        heard_us,
                        watchdog_us: s.ctrl.link_config().watchdog_us,
                        steps,
                    };
                    s.report_on_hello = Some(stop);
                    s.send(CtrlMsg::Error(why));
                    s.send(CtrlMsg::Stopped(stop));
                    s.report(phase, layer, layers, percent);
                });
            }
        }
        link.lock(|s| s.flush(run.io));
    }
}

impl<const HOLES: usize, const POINTS: usize, const W: usize> Default for App<HOLES, POINTS, W> {
    fn default() -> Self {
        Self::new()
    }
}

/// The step interrupt of a job, with the link served between deadlines.
struct Run<'a, L, I, B, S> {
    link: &'a L,
    io: &'a mut I,
    board: &'a mut B,
    tick_hz: u32,
    /// The deadline the machine asked for last (`None`: at rest, run at once).
    deadline: Option<u32>,
    /// When the link was served last (microseconds).
    served: u64,
    pause_reported: bool,
    /// When the machine was stopped from the link (abort, host silence), and when the
    /// host was last heard then.
    stopped: Option<(u64, Option<u64>)>,
    _session: core::marker::PhantomData<S>,
}

impl<L, I, B, const HOLES: usize, const POINTS: usize, const W: usize>
    Run<'_, L, I, B, Session<HOLES, POINTS, W>>
where
    L: Shared<Session<HOLES, POINTS, W>>,
    I: Io,
    B: Board,
{
    /// Serves the link: pause, resume and abort act on the machine; silence past the
    /// watchdog stops it.
    fn serve(&mut self, machine: &mut Machine<LOOK_AHEAD>, now: u64) -> Option<u64> {
        self.served = now;
        while let Some(event) = self.link.lock(|s| s.next_event(self.io)) {
            match event {
                Event::Pause => machine.pause(),
                Event::Resume => {
                    if machine.state() == State::Paused {
                        machine.resume();
                        self.deadline = None;
                        self.pause_reported = false;
                        self.link.lock(|s| {
                            let st = s.status;
                            s.report(Phase::Printing, st.layer, st.layers, st.percent);
                        });
                    }
                }
                Event::Abort => {
                    machine.abort(self.board);
                    self.stop_at(now);
                }
                Event::Start => self.link.lock(|s| {
                    s.send(CtrlMsg::Error(RemoteError::Link(
                        LinkError::UnexpectedMessage,
                    )))
                }),
                // A slice uploaded mid-job waits for the job's end (the controller takes
                // nothing more until then).
                Event::SliceReady | Event::Hello | Event::Printer | Event::Refused(_) => {}
            }
        }
        let now = self.io.now_us();
        if self.link.lock(|s| s.ctrl.is_lost(now)) {
            machine.shutdown(self.board, Fault::HostSilent);
            self.stop_at(now);
        }
        self.link.lock(|s| s.flush(self.io))
    }

    /// Notes the first stop's time and the host's last frame before it.
    fn stop_at(&mut self, now: u64) {
        if self.stopped.is_none() {
            let heard = self.link.lock(|s| s.ctrl.last_heard());
            self.stopped = Some((now, heard));
        }
    }
}

impl<L, I, B, const HOLES: usize, const POINTS: usize, const W: usize> Drive<LOOK_AHEAD>
    for Run<'_, L, I, B, Session<HOLES, POINTS, W>>
where
    L: Shared<Session<HOLES, POINTS, W>>,
    I: Io,
    B: Board,
{
    type Stop = Fault;

    fn alarm(&mut self, machine: &mut Machine<LOOK_AHEAD>) -> Result<bool, Fault> {
        loop {
            let now = self.io.now_us();
            if now.wrapping_sub(self.served) >= SERVE_US || self.deadline.is_none() {
                self.serve(machine, now);
            }
            match machine.state() {
                State::Stopped(f) => return Err(f),
                State::Paused => {
                    if !self.pause_reported {
                        self.pause_reported = true;
                        self.link.lock(|s| {
                            let st = s.status;
                            s.report(Phase::Paused, st.layer, st.layers, st.percent);
                            s.flush(self.io);
                        });
                    }
                    self.serve(machine, now);
                    if machine.state() == State::Paused {
                        // Nothing to step: wait for the host (its keep-alives wake us).
                        self.io.sleep(None);
                    }
                    continue;
                }
                _ => {}
            }
            let at = match self.deadline {
                None => io::ticks_at(now, self.tick_hz),
                Some(d) => {
                    let wait = io::us_until(io::ticks_at(now, self.tick_hz), d, self.tick_hz);
                    if wait > 0 {
                        // Only the step deadline wakes us (and bytes): the link is served
                        // every `SERVE_US` of stepping, and a platform whose idle time
                        // jumps (QEMU's `-icount sleep=off`) must not race through the
                        // link's timers.
                        self.io.sleep(Some(now + wait));
                        continue;
                    }
                    d
                }
            };
            self.deadline = machine.on_alarm(at, self.board);
            return Ok(self.deadline.is_some() || machine.state() == State::Paused);
        }
    }
}
