//! The controller application: the link's
//! [`Controller`](crate::link::controller::Controller) and the [`Machine`] in one state
//! machine, generic over the printer's [`Board`](crate::motion::Board) and the platform's [`Io`] (byte stream and
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
//!   layer after layer on the same machine, z rising, each layer's path generated into the
//!   step side's queue ([`job::print_layer`], the routine the host's `simulate` counts its
//!   telemetry with) while the platform's step interrupt runs the machine. After
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
//! application takes the queued events when it is back in its loop.
//!
//! The machine is not the application's either: it lives on the step side
//! ([`steps::Stepping`]: the machine, the board, a queue of the layer's moves), passed to
//! `poll` as the platform's [`Steps`]. A controller's step timer interrupt runs it
//! ([`Stepping::run_due`]) at the deadlines the machine asks for, while the application's
//! loop generates the layer and queues its moves, so steps keep their times however long
//! one vertex of a layer takes to compute. Each alarm first tops the look-ahead up from the
//! queue, and a layer starts from rest only once the look-ahead can be filled, so every alarm
//! of a layer sees the look-ahead full as on the host (whose [`Lockstep`] runs the alarm due
//! next whenever the application waits) and the machine counts the same figures; an alarm
//! that ran short because the generator fell behind is counted and reported
//! ([`LayerTelemetry::starved`]). A late interrupt delays steps but never reorders or
//! changes them.

pub mod io;
pub mod job;
pub mod session;
pub mod shared;
pub mod steps;

use crate::link::controller::Event;
use crate::link::error::LinkError;
use crate::link::message::{CtrlMsg, LayerTelemetry, Phase, RemoteError, StopReport, Telemetry};
use crate::motion::machine::Fault;
use crate::motion::stepper::Ticks;
use crate::motion::{Machine, State};
use crate::plan::Planner;
use crate::slice::SliceStore;
use crate::toolpath::offset::OffsetSpiral;

pub use io::Io;
use job::{Drive, LayerError};
pub use session::Session;
pub use shared::Shared;
pub use steps::{Lockstep, Stepping, Steps};

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
    /// The accepted slice, if any, built in place by the link's assembler (a `Slice` moved
    /// by value took a 21 KiB copy in every frame on its way). Empty storage is all zeros
    /// (no `Option` niche), so the application is zeroed `.bss`, not a `.data` image.
    slice: SliceStore,
    planned: bool,
}

impl<const HOLES: usize, const POINTS: usize, const W: usize> App<HOLES, POINTS, W> {
    /// An idle application (its link side is a [`Session`] of its own).
    pub const fn new() -> Self {
        App {
            planner: Planner::new(),
            offset: OffsetSpiral::new(),
            slice: SliceStore::new(),
            planned: false,
        }
    }

    /// Serves the link: handles what arrived (planning a slice, running a job to its end),
    /// writes what is due; returns the link's next deadline (microseconds). `link` is the
    /// application's [`Session`], behind the platform's lock (taken for each call into it,
    /// never across planning or stepping). `steps` is the step side ([`Steps`]: the
    /// machine, the board and the moves queued for them), which the platform's step
    /// interrupt runs.
    pub fn poll<L, I, S>(&mut self, link: &L, io: &mut I, steps: &S) -> Option<u64>
    where
        L: Shared<Session<HOLES, POINTS, W>>,
        I: Io,
        S: Steps,
    {
        while let Some(event) = link.lock(|s| s.next_event(io)) {
            self.on_event(event, link, io, steps);
            link.lock(|s| s.flush(io));
        }
        link.lock(|s| s.flush(io))
    }

    fn on_event<L, I, S>(&mut self, event: Event, link: &L, io: &mut I, steps: &S)
    where
        L: Shared<Session<HOLES, POINTS, W>>,
        I: Io,
        S: Steps,
    {
        match event {
            Event::SliceReady => {
                self.planned = false;
                // Built in place in the application's static; a refusal was already
                // reported to the host by the controller (and leaves the store empty).
                let store = &mut self.slice;
                link.lock(|s| {
                    s.report(Phase::Receiving, 0, 0, 0);
                    if s.ctrl.finish_slice(store).is_ok() {
                        s.report(Phase::Planning, 0, 0, 0);
                    }
                    s.flush(io);
                });
                if let Some(slice) = self.slice.get() {
                    // Seconds of work: the platform may serve the link meanwhile.
                    let outcome = self.planner.plan(slice).map(|plan| plan.digest());
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
                        let (_, grid) = self.planner.plan_and_grid();
                        let _spiral_ready = self.offset.prepare(slice, grid).is_ok();
                    }
                }
                link.lock(|s| s.report(Phase::Idle, 0, 0, 0));
            }
            Event::Start => self.run_job(link, io, steps),
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
    fn run_job<L, I, S>(&mut self, link: &L, io: &mut I, steps: &S)
    where
        L: Shared<Session<HOLES, POINTS, W>>,
        I: Io,
        S: Steps,
    {
        let cfg = link.lock(|s| s.ctrl.printer().cloned());
        let (Some(slice), true, Some(cfg)) = (self.slice.get(), self.planned, cfg) else {
            link.lock(|s| {
                s.send(CtrlMsg::Error(RemoteError::Link(
                    LinkError::UnexpectedMessage,
                )))
            });
            return;
        };
        let layers = link.lock(|s| s.ctrl.layers());
        let tick_hz = cfg.tick_hz;
        match Machine::new(cfg) {
            Ok(m) => steps.lock(|s| s.install(m)),
            Err(e) => {
                link.lock(|s| s.send(CtrlMsg::Error(RemoteError::Printer(e.into()))));
                return;
            }
        }
        link.lock(|s| {
            s.report_on_hello = None;
            s.report(Phase::Homing, 0, layers, 0);
        });
        let mut run = Run {
            link,
            io,
            steps,
            tick_hz,
            served: 0,
            pause_reported: false,
            stopped: None,
            _session: core::marker::PhantomData,
        };
        let mut result = job::home(&mut run);
        let (plan, grid) = self.planner.plan_and_grid();
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
                grid,
                layer as usize,
                &mut run,
            ) {
                Ok(p) => {
                    let t = LayerTelemetry::from_counters(layer, &p.counters, p.starved);
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
                run.steps.lock(|s| s.shutdown(fault));
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
                let steps = run
                    .steps
                    .lock(|s| s.machine().map(|m| m.counters().steps))
                    .unwrap_or_default();
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

/// A job's [`Drive`]: the platform's step side, with the link served while the application
/// waits for it.
struct Run<'a, L, I, S, Sn> {
    link: &'a L,
    io: &'a mut I,
    steps: &'a S,
    tick_hz: u32,
    /// When the link was served last (microseconds).
    served: u64,
    pause_reported: bool,
    /// When the machine was stopped from the link (abort, host silence), and when the
    /// host was last heard then.
    stopped: Option<(u64, Option<u64>)>,
    _session: core::marker::PhantomData<Sn>,
}

impl<L, I, S, const HOLES: usize, const POINTS: usize, const W: usize>
    Run<'_, L, I, S, Session<HOLES, POINTS, W>>
where
    L: Shared<Session<HOLES, POINTS, W>>,
    I: Io,
    S: Steps,
{
    /// Serves the link: pause, resume and abort act on the machine; silence past the
    /// watchdog stops it.
    fn serve(&mut self, now: u64) -> Option<u64> {
        self.served = now;
        while let Some(event) = self.link.lock(|s| s.next_event(self.io)) {
            match event {
                Event::Pause => self.steps.lock(|s| s.pause()),
                Event::Resume => {
                    let at = io::ticks_at(self.io.now_us(), self.tick_hz);
                    if self.steps.lock(|s| s.resume(at)) {
                        self.steps.kick();
                        self.pause_reported = false;
                        self.link.lock(|s| {
                            let st = s.status;
                            s.report(Phase::Printing, st.layer, st.layers, st.percent);
                        });
                    }
                }
                Event::Abort => {
                    self.steps.lock(|s| s.shutdown(Fault::Aborted));
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
            self.steps.lock(|s| s.shutdown(Fault::HostSilent));
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

impl<L, I, S, const HOLES: usize, const POINTS: usize, const W: usize> Drive
    for Run<'_, L, I, S, Session<HOLES, POINTS, W>>
where
    L: Shared<Session<HOLES, POINTS, W>>,
    I: Io,
    S: Steps,
{
    type Board = S::Board;
    type Stop = Fault;

    fn lock<R>(&mut self, f: impl FnOnce(&mut Stepping<S::Board>) -> R) -> R {
        self.steps.lock(f)
    }

    fn now(&mut self) -> Ticks {
        io::ticks_at(self.io.now_us(), self.tick_hz)
    }

    fn kick(&mut self) {
        self.steps.kick();
    }

    fn wait(&mut self) -> Result<(), Fault> {
        let now = self.io.now_us();
        let (state, running) = self.steps.lock(|s| (s.state(), s.deadline().is_some()));
        if now.wrapping_sub(self.served) >= SERVE_US || !running {
            self.serve(now);
        }
        match self.steps.lock(|s| s.state()).or(state) {
            Some(State::Stopped(f)) => Err(f),
            Some(State::Paused) => {
                if !self.pause_reported {
                    self.pause_reported = true;
                    self.link.lock(|s| {
                        let st = s.status;
                        s.report(Phase::Paused, st.layer, st.layers, st.percent);
                        s.flush(self.io);
                    });
                }
                self.serve(now);
                if self.steps.lock(|s| s.state()) == Some(State::Paused) {
                    // Nothing to step: wait for the host (its keep-alives wake us).
                    self.io.sleep(None);
                }
                Ok(())
            }
            _ => {
                // The step interrupt runs at its deadlines (a host's runs here); the link
                // is served every `SERVE_US` of it.
                self.steps.wait(self.io);
                Ok(())
            }
        }
    }
}
