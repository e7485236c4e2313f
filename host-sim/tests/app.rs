//! The controller application (`hollowpath::app`) on the host: the real host link client
//! against the app over an in-memory byte pipe, on a board of counting pins and a clock whose
//! idle time jumps (as QEMU's `-icount sleep=off`): a job's layer telemetry equals the host's
//! `simulate` of the same job exactly; a bad slice comes back as the core's typed error and the
//! next job prints; pause, resume and abort act on the machine and a job after an abort
//! prints; a host gone silent mid-job has the valves closed and the reason reported on
//! reconnection.

use std::collections::VecDeque;
use std::convert::Infallible;
use std::io::{self, Read, Write};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use embedded_hal::digital::{ErrorType, InputPin, OutputPin};
use embedded_hal::pwm::{self, SetDutyCycle};
use hollowpath::app::{App, Io, Lockstep, Session, Shared, Steps};
use hollowpath::config::{MAX_HOLES, MAX_VERTICES};
use hollowpath::link::controller::Controller;
use hollowpath::link::endpoint::LinkConfig;
use hollowpath::link::message::{
    CtrlMsg, HostMsg, LayerTelemetry, Phase, RemoteError, Telemetry, Version,
};
use hollowpath::link::upload::upload;
use hollowpath::motion::{Board, Fault, PrinterConfig, State};
use hollowpath::FeatureId;
use host_sim::link_client::{as_uploaded, LinkClient};
use host_sim::{printer_file, slice_file, virtual_printer};

type Pipe = Arc<Mutex<VecDeque<u8>>>;

/// One end of an in-memory byte pipe.
#[derive(Clone)]
struct End {
    rx: Pipe,
    tx: Pipe,
}

fn pipe() -> (End, End) {
    let (a, b): (Pipe, Pipe) = (Arc::default(), Arc::default());
    (
        End {
            rx: a.clone(),
            tx: b.clone(),
        },
        End { rx: b, tx: a },
    )
}

impl Read for End {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let mut q = self.rx.lock().unwrap();
        if q.is_empty() {
            return Err(io::ErrorKind::WouldBlock.into());
        }
        let n = buf.len().min(q.len());
        for b in buf[..n].iter_mut() {
            *b = q.pop_front().unwrap();
        }
        Ok(n)
    }
}

impl Write for End {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.tx.lock().unwrap().extend(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// The app's platform: the pipe, and a clock that runs with the wall clock but jumps to a
/// deadline it is asked to sleep to (QEMU's `-icount shift=0,sleep=off` does the same).
/// Clones share the clock (an interrupt reads the same clock as the application).
#[derive(Clone)]
struct Platform {
    wire: End,
    t0: Instant,
    jumped: Arc<AtomicU64>,
}

impl Io for Platform {
    fn now_us(&mut self) -> u64 {
        self.t0.elapsed().as_micros() as u64 + self.jumped.load(Ordering::Relaxed)
    }
    fn read(&mut self, buf: &mut [u8]) -> usize {
        self.wire.read(buf).unwrap_or(0)
    }
    fn write(&mut self, bytes: &[u8]) {
        self.wire.write_all(bytes).unwrap();
    }
    fn sleep(&mut self, until: Option<u64>) {
        let now = self.now_us();
        match until {
            Some(t) if t > now => {
                self.jumped.fetch_add(t - now, Ordering::Relaxed);
            }
            Some(_) => {}
            None => std::thread::sleep(Duration::from_micros(100)),
        }
    }
}

/// A pin that holds a level.
#[derive(Default)]
struct Pin(bool);

impl ErrorType for Pin {
    type Error = Infallible;
}
impl OutputPin for Pin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.0 = false;
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.0 = true;
        Ok(())
    }
}
impl InputPin for Pin {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(self.0)
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(!self.0)
    }
}

/// A valve output holding its duty.
#[derive(Default)]
struct Valve(u16);

impl pwm::ErrorType for Valve {
    type Error = Infallible;
}
impl SetDutyCycle for Valve {
    fn max_duty_cycle(&self) -> u16 {
        10_000
    }
    fn set_duty_cycle(&mut self, d: u16) -> Result<(), Infallible> {
        self.0 = d;
        Ok(())
    }
}

/// The mock board: the endstops read hit (homing ends at once, as the virtual printer's,
/// which starts at its endstops), the emergency stop released.
struct MockBoard {
    step: [Pin; 3],
    dir: [Pin; 3],
    endstop: Pin,
    estop: Pin,
    valve: [Valve; 4],
}

impl MockBoard {
    fn new() -> MockBoard {
        MockBoard {
            step: Default::default(),
            dir: Default::default(),
            endstop: Pin(true),
            estop: Pin(false),
            valve: Default::default(),
        }
    }
}

impl Board for MockBoard {
    type Out = Pin;
    type In = Pin;
    type Pwm = Valve;
    fn step(&mut self, a: usize) -> &mut Pin {
        &mut self.step[a]
    }
    fn dir(&mut self, a: usize) -> &mut Pin {
        &mut self.dir[a]
    }
    fn endstop(&mut self, _: usize) -> &mut Pin {
        &mut self.endstop
    }
    fn estop(&mut self) -> &mut Pin {
        &mut self.estop
    }
    fn valve(&mut self, c: usize) -> &mut Valve {
        &mut self.valve[c]
    }
}

const POINTS: usize = (MAX_HOLES + 1) * MAX_VERTICES;
type TestApp = App<MAX_HOLES, POINTS, 4>;
type TestSession = Session<MAX_HOLES, POINTS, 4>;

/// The session behind a mutex, as a controller keeps it behind a critical section.
struct Locked(Mutex<TestSession>);

impl Shared<TestSession> for Locked {
    fn lock<R>(&self, f: impl FnOnce(&mut TestSession) -> R) -> R {
        f(&mut self.0.lock().unwrap())
    }
}

/// Who serves the link besides the application's own loop.
#[derive(Clone, Copy, PartialEq)]
enum Served {
    /// Nobody: the link waits while the application plans.
    ByTheAppOnly,
    /// A thread every 200 us, as the controller's receive interrupt does.
    AlsoByAnInterrupt,
}

/// The controller's link timers, in the app clock's microseconds, which jump while it steps
/// (a layer of 100 s prints in about half a second): the watchdog allows for the host
/// thread being descheduled on a busy machine.
const CTRL: LinkConfig = LinkConfig {
    retransmit_us: 200_000,
    keepalive_us: 100_000,
    watchdog_us: 30_000_000,
};
const HOST: LinkConfig = LinkConfig {
    retransmit_us: 30_000,
    keepalive_us: 2_000,
    watchdog_us: 0,
};

/// What the app thread left: the machine's state, the valves' duties.
struct Outcome {
    state: Option<State>,
    duties: [u16; 4],
}

/// Runs the app on its own thread until `stop`.
fn spawn_app(wire: End, stop: Arc<AtomicBool>) -> std::thread::JoinHandle<Outcome> {
    spawn_app_served(wire, stop, Served::AlsoByAnInterrupt)
}

fn spawn_app_served(
    wire: End,
    stop: Arc<AtomicBool>,
    served: Served,
) -> std::thread::JoinHandle<Outcome> {
    std::thread::Builder::new()
        .stack_size(host_sim::STACK_BYTES)
        .spawn(move || {
            let fw = Version {
                major: 0,
                minor: 1,
                patch: 0,
            };
            let mut app: Box<TestApp> = Box::default();
            let link = Arc::new(Locked(Mutex::new(Session::new(Controller::new(CTRL, fw)))));
            let mut io = Platform {
                wire,
                t0: Instant::now(),
                jumped: Arc::default(),
            };
            let interrupt = (served == Served::AlsoByAnInterrupt).then(|| {
                let (link, mut io, stop) = (link.clone(), io.clone(), stop.clone());
                std::thread::spawn(move || {
                    while !stop.load(Ordering::Relaxed) {
                        link.lock(|s| s.serve(&mut io));
                        std::thread::sleep(Duration::from_micros(200));
                    }
                })
            });
            // The step side, its interrupt run at each deadline when the app waits.
            let steps = Box::new(Lockstep::new(MockBoard::new()));
            while !stop.load(Ordering::Relaxed) {
                app.poll(&*link, &mut io, &*steps);
                if !link.lock(|s| s.has_events()) {
                    io.sleep(None);
                }
            }
            if let Some(t) = interrupt {
                t.join().unwrap();
            }
            Outcome {
                state: steps.lock(|s| s.state()),
                duties: steps.lock(|s| [0, 1, 2, 3].map(|c| s.board().valve[c].0)),
            }
        })
        .unwrap()
}

fn ci_printer() -> PrinterConfig {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/data/ci_printer.json");
    printer_file::load(std::path::Path::new(path)).unwrap()
}

/// Collects messages until the job's end (or `timeout`); (statuses, layer telemetry, errors).
fn until_done(
    client: &mut LinkClient<End>,
    timeout: Duration,
) -> (Vec<Phase>, Vec<LayerTelemetry>, Vec<RemoteError>) {
    let t = Instant::now();
    let (mut phases, mut layers, mut errors) = (vec![], vec![], vec![]);
    while t.elapsed() < timeout {
        match client.next_message(Duration::from_millis(100)).unwrap() {
            Some(CtrlMsg::Status(s)) => {
                phases.push(s.phase);
                if matches!(s.phase, Phase::Done | Phase::Aborted | Phase::Failed) {
                    break;
                }
            }
            Some(CtrlMsg::Telemetry(Telemetry::Layer(l))) => layers.push(l),
            Some(CtrlMsg::Error(e)) => errors.push(e),
            _ => {}
        }
    }
    (phases, layers, errors)
}

#[test]
fn a_job_prints_with_the_telemetry_of_simulate_and_a_bad_slice_is_refused() {
    host_sim::run_on_large_stack(|| {
        let (host, ctrl) = pipe();
        let stop = Arc::new(AtomicBool::new(false));
        let app = spawn_app(ctrl, stop.clone());
        let mut client = LinkClient::new(host, HOST);
        client.hello().unwrap();
        let cfg = ci_printer();
        client.send_printer(&cfg).unwrap();

        // A bad slice: the wall of one slice with the hole of another, outside it. The
        // core's own error comes back, and the app is idle again.
        let square = |at: f32, size: f32| {
            format!(
                "[[{at},{at}],[{b},{at}],[{b},{b}],[{at},{b}]]",
                b = at + size
            )
        };
        let slice_json = |wall: &str, hole: &str| {
            format!(
                r#"{{"outer": {{"points": {wall}, "material": [1,0,0,0]}},
                   "holes": [{{"points": {hole}, "material": [0,1,0,0]}}]}}"#
            )
        };
        let a = slice_file::parse(&slice_json(&square(0.0, 10.0), &square(4.0, 2.0)))
            .unwrap()
            .slice;
        let b = slice_file::parse(&slice_json(&square(0.0, 100.0), &square(80.0, 5.0)))
            .unwrap()
            .slice;
        let msgs =
            |s: &hollowpath::Slice| -> Vec<HostMsg> { upload(s, 2).map(|m| m.unwrap()).collect() };
        let is_hole = |m: &HostMsg| match m {
            HostMsg::Feature { feature, .. } => *feature != FeatureId::Wall,
            HostMsg::Contour(c) => c.feature != FeatureId::Wall,
            _ => false,
        };
        let (ma, mb) = (msgs(&a), msgs(&b));
        let mut bad: Vec<HostMsg> = ma.iter().filter(|m| !is_hole(m)).cloned().collect();
        let end = bad.pop().unwrap();
        bad.extend(mb.iter().filter(|m| is_hole(m)).cloned());
        bad.push(end);
        for m in &bad {
            client.send(m).unwrap();
        }
        let refused = loop {
            match client.next_message(Duration::from_secs(10)).unwrap() {
                Some(CtrlMsg::Error(e)) => break e,
                Some(CtrlMsg::SliceAccepted { .. }) => panic!("the bad slice was accepted"),
                Some(_) => {}
                None => panic!("no answer to the bad slice"),
            }
        };
        assert!(matches!(refused, RemoteError::Slice(_)), "{refused:?}");
        // Starting it is refused too.
        client.send(&HostMsg::Start).unwrap();
        loop {
            match client.next_message(Duration::from_secs(10)).unwrap() {
                Some(CtrlMsg::Error(RemoteError::Link(_))) => break,
                Some(CtrlMsg::Status(s)) => assert_ne!(s.phase, Phase::Homing),
                Some(m) => panic!("unexpected {m:?}"),
                None => panic!("no answer to the start"),
            }
        }

        // The next job prints: two layers of four_holes on the CI printer.
        let f = slice_file::parse(host_sim::REFERENCE_SLICES[0].1).unwrap();
        client.upload(&f.slice, 2).unwrap();
        // The controller plans and prints the slice as it arrived (whole micrometres).
        let uploaded = as_uploaded(&f.slice, 2).unwrap();
        let planner = host_sim::plan(&uploaded).unwrap();
        let digest = loop {
            match client.next_message(Duration::from_secs(30)).unwrap() {
                Some(CtrlMsg::Telemetry(Telemetry::Plan { digest })) => break digest,
                Some(CtrlMsg::Error(e)) => panic!("{e}"),
                Some(_) => {}
                None => panic!("no plan digest"),
            }
        };
        assert_eq!(digest, planner.last_plan().digest());
        client.start().unwrap();
        let (phases, layers, errors) = until_done(&mut client, Duration::from_secs(120));
        assert!(errors.is_empty(), "{errors:?}");
        // (The idle status after planning may still be on its way.)
        let phases: Vec<Phase> = phases
            .into_iter()
            .skip_while(|p| *p == Phase::Idle)
            .collect();
        assert_eq!(
            phases,
            [Phase::Homing, Phase::Printing, Phase::Printing, Phase::Done]
        );
        assert_eq!(phases.first(), Some(&Phase::Homing), "{phases:?}");
        assert_eq!(phases.last(), Some(&Phase::Done), "{phases:?}");
        let expected =
            virtual_printer::run_job_counted(&cfg, &uploaded, planner.last_plan(), 2).unwrap();
        assert_eq!(layers.len(), 2);
        for (k, (got, c)) in layers.iter().zip(&expected).enumerate() {
            assert_eq!(
                *got,
                LayerTelemetry::from_counters(k as u16, &c.counters, c.starved),
                "layer {k}"
            );
            assert!(got.steps[0] > 1000 && got.valve_openings.iter().sum::<u32>() > 0);
        }
        stop.store(true, Ordering::Relaxed);
        let out = app.join().unwrap();
        assert_eq!(out.state, Some(State::Ready));
        assert_eq!(out.duties, [0; 4]);
    })
}

#[test]
fn a_silent_host_has_the_valves_closed_and_hears_why_on_reconnection() {
    host_sim::run_on_large_stack(|| {
        let (host, ctrl) = pipe();
        let (rx, tx) = (host.rx.clone(), host.tx.clone());
        let stop = Arc::new(AtomicBool::new(false));
        let app = spawn_app(ctrl, stop.clone());
        let mut client = LinkClient::new(host, HOST);
        client.hello().unwrap();
        client.send_printer(&ci_printer()).unwrap();
        let f = slice_file::parse(host_sim::REFERENCE_SLICES[0].1).unwrap();
        client.upload(&f.slice, 40).unwrap();
        client.start().unwrap();
        // Wait for the first layer to be printing, then fall silent.
        loop {
            if let Some(CtrlMsg::Status(s)) = client.next_message(Duration::from_secs(30)).unwrap()
            {
                if s.phase == Phase::Printing {
                    break;
                }
            }
        }
        drop(client);
        std::thread::sleep(Duration::from_secs(3));
        // A new host on the same line: greeted, it hears the fault.
        rx.lock().unwrap().clear();
        let mut client = LinkClient::new(End { rx, tx }, HOST);
        client.hello().unwrap();
        let mut heard = None;
        while let Some(m) = client.next_message(Duration::from_secs(2)).unwrap() {
            if let CtrlMsg::Stopped(r) = m {
                heard = Some(r);
                break;
            }
        }
        let heard = heard.expect("no stop report after the hello");
        assert_eq!(heard.fault, Fault::HostSilent);
        // Stopped within the watchdog's time of the last frame (the link is served every
        // half millisecond while the machine steps).
        let silent = heard.silent_us().unwrap();
        assert_eq!(heard.watchdog_us, CTRL.watchdog_us);
        assert!(
            silent > CTRL.watchdog_us && silent < CTRL.watchdog_us + 500_000,
            "{heard:?}"
        );
        assert!(heard.steps[0] > 0, "{heard:?}");
        stop.store(true, Ordering::Relaxed);
        let out = app.join().unwrap();
        assert_eq!(out.state, Some(State::Stopped(Fault::HostSilent)));
        assert_eq!(out.duties, [0; 4]);
    })
}

#[test]
fn pause_resume_and_abort_act_on_the_machine_and_the_next_job_prints() {
    host_sim::run_on_large_stack(|| {
        let (host, ctrl) = pipe();
        let stop = Arc::new(AtomicBool::new(false));
        let app = spawn_app(ctrl, stop.clone());
        let mut client = LinkClient::new(host, HOST);
        client.hello().unwrap();
        client.send_printer(&ci_printer()).unwrap();
        let f = slice_file::parse(host_sim::REFERENCE_SLICES[0].1).unwrap();
        client.upload(&f.slice, 6).unwrap();
        client.start().unwrap();
        let wait_for = |client: &mut LinkClient<End>, phase: Phase| -> Vec<CtrlMsg> {
            let t = Instant::now();
            let mut seen = vec![];
            loop {
                assert!(
                    t.elapsed() < Duration::from_secs(60),
                    "no {phase:?}: {seen:?}"
                );
                if let Some(m) = client.next_message(Duration::from_millis(100)).unwrap() {
                    let hit = matches!(&m, CtrlMsg::Status(s) if s.phase == phase);
                    seen.push(m);
                    if hit {
                        return seen;
                    }
                }
            }
        };
        wait_for(&mut client, Phase::Printing);
        client.pause().unwrap();
        wait_for(&mut client, Phase::Paused);
        // Paused: nothing more is printed while the host waits.
        let quiet = client.next_message(Duration::from_millis(300)).unwrap();
        assert!(
            !matches!(quiet, Some(CtrlMsg::Telemetry(_))),
            "{quiet:?} while paused"
        );
        client.resume().unwrap();
        wait_for(&mut client, Phase::Printing);
        client.abort().unwrap();
        let seen = wait_for(&mut client, Phase::Aborted);
        assert!(
            seen.contains(&CtrlMsg::Error(RemoteError::Machine(Fault::Aborted))),
            "{seen:?}"
        );
        // The next job on the same slice prints to its end.
        client.start().unwrap();
        let seen = wait_for(&mut client, Phase::Done);
        let layers = seen
            .iter()
            .filter(|m| matches!(m, CtrlMsg::Telemetry(Telemetry::Layer(_))))
            .count();
        assert_eq!(layers, 6, "{seen:?}");
        stop.store(true, Ordering::Relaxed);
        let out = app.join().unwrap();
        assert_eq!(out.state, Some(State::Ready));
        assert_eq!(out.duties, [0; 4]);
    })
}

/// Sends a message while the controller plans a slice (42 holes, about a second on the
/// host) and waits for its acknowledgement; whether the plan's digest came before it.
fn plan_came_before_the_ack(served: Served) -> bool {
    use host_sim::random_slice::{draw, Draw};
    host_sim::run_on_large_stack(move || {
        let (host, ctrl) = pipe();
        let stop = Arc::new(AtomicBool::new(false));
        let app = spawn_app_served(ctrl, stop.clone(), served);
        let mut client = LinkClient::new(host, HOST);
        client.timeout = Duration::from_secs(60);
        client.hello().unwrap();
        client.send_printer(&ci_printer()).unwrap();
        let r = draw(7, &Draw::default()).unwrap();
        assert!(r.slice.holes().len() >= 32, "{}", r.description);
        // Accepted: the controller plans it now.
        client.upload(&r.slice, 2).unwrap();
        // A pause outside a job changes nothing (the controller answers with its status).
        client.send(&HostMsg::Pause).unwrap();
        client.flush().unwrap();
        let mut early = false;
        while let Some(m) = client.next_message(Duration::ZERO).unwrap() {
            early |= matches!(m, CtrlMsg::Telemetry(Telemetry::Plan { .. }));
        }
        let retransmitted_while_planning = client.stats().retransmissions;
        let mut planned = early;
        while !planned {
            match client.next_message(Duration::from_secs(60)).unwrap() {
                Some(CtrlMsg::Telemetry(Telemetry::Plan { .. })) => planned = true,
                Some(CtrlMsg::Error(e)) => panic!("{e}"),
                Some(_) => {}
                None => panic!("no plan digest"),
            }
        }
        println!(
            "{}: plan digest before the ack {early}, host retransmissions until the ack {retransmitted_while_planning}",
            match served {
                Served::ByTheAppOnly => "served by the app only",
                Served::AlsoByAnInterrupt => "served by an interrupt too",
            }
        );
        stop.store(true, Ordering::Relaxed);
        app.join().unwrap();
        early
    })
}

/// The controller keeps answering while it plans: a message sent during the planning is
/// acknowledged before the plan is done when an interrupt serves the session (as the
/// firmware's receive interrupt does), and only after it when nothing but the
/// application's loop does (the check can fail).
#[test]
fn while_the_controller_plans_its_interrupt_keeps_the_link_answering() {
    assert!(!plan_came_before_the_ack(Served::AlsoByAnInterrupt));
    assert!(plan_came_before_the_ack(Served::ByTheAppOnly));
}
