//! The host's link client against an in-process controller end over an in-memory pipe that
//! drops, corrupts, duplicates and injects noise: greet, upload a reference slice and a
//! printer, compare plan digests, start, and receive every status and layer telemetry once
//! and in order.

use std::collections::VecDeque;
use std::io::{self, Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use hollowpath::config::{MAX_HOLES, MAX_VERTICES};
use hollowpath::link::assemble::SliceAssembler;
use hollowpath::link::controller::{Controller, Event};
use hollowpath::link::endpoint::{LinkConfig, LinkStats};
use hollowpath::link::error::LinkError;
use hollowpath::link::message::{
    CtrlMsg, HostMsg, LayerTelemetry, Phase, RemoteError, Status, Telemetry, Version,
};
use hollowpath::link::upload::upload;
use hollowpath::motion::config::PrinterConfig;
use hollowpath::Slice;
use host_sim::link_client::{ClientError, LinkClient};
use host_sim::{slice_file, REFERENCE_SLICES};

/// Faults per write (a frame), per mille.
#[derive(Clone, Copy, Default)]
struct Faults {
    drop: u64,
    corrupt: u64,
    duplicate: u64,
    noise: u64,
}

/// One end of an in-memory byte pipe; faults are applied to what it writes.
struct End {
    rx: Arc<Mutex<VecDeque<u8>>>,
    tx: Arc<Mutex<VecDeque<u8>>>,
    faults: Faults,
    rng: u64,
}

fn pipe(faults: Faults, seed: u64) -> (End, End) {
    let (a, b) = (Arc::default(), Arc::default());
    let end = |rx: &Arc<_>, tx: &Arc<_>, s: u64| End {
        rx: Arc::clone(rx),
        tx: Arc::clone(tx),
        faults,
        rng: s.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1,
    };
    (end(&a, &b, seed), end(&b, &a, seed.wrapping_mul(31) + 7))
}

impl End {
    fn next(&mut self) -> u64 {
        self.rng ^= self.rng << 13;
        self.rng ^= self.rng >> 7;
        self.rng ^= self.rng << 17;
        self.rng
    }
    fn chance(&mut self, per_mille: u64) -> bool {
        self.next() % 1000 < per_mille
    }
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
        let f = self.faults;
        if self.chance(f.drop) {
            return Ok(buf.len());
        }
        let mut bytes = buf.to_vec();
        if self.chance(f.corrupt) && !bytes.is_empty() {
            let k = (self.next() as usize) % bytes.len();
            bytes[k] ^= 1 << (self.next() % 8);
        }
        let copies = if self.chance(f.duplicate) { 2 } else { 1 };
        let noise = self.chance(f.noise);
        let garbage: Vec<u8> = (0..(self.next() % 24)).map(|_| self.next() as u8).collect();
        let mut q = self.tx.lock().unwrap();
        if noise {
            q.extend(&garbage);
        }
        for _ in 0..copies {
            q.extend(&bytes);
        }
        Ok(buf.len())
    }
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

const CONFIG: LinkConfig = LinkConfig {
    retransmit_us: 30_000,
    keepalive_us: 50_000,
    watchdog_us: 2_000_000,
};
type Ctrl = Controller<MAX_HOLES, { (MAX_HOLES + 1) * MAX_VERTICES }, 4>;
const FW: Version = Version {
    major: 0,
    minor: 1,
    patch: 0,
};

/// The controller's application: builds the slice, plans it and reports the digest; on
/// start "prints" its layers, reporting status and telemetry for each.
fn controller(mut wire: End, stop: &AtomicBool) -> (u32, bool) {
    let mut ctrl = Box::new(Ctrl::new(CONFIG, FW));
    let mut store = Box::new(hollowpath::slice::SliceStore::new());
    let t0 = Instant::now();
    let mut outbox: VecDeque<CtrlMsg> = VecDeque::new();
    let mut pending: Vec<u8> = Vec::new();
    let mut lost = false;
    while !stop.load(Ordering::Relaxed) {
        let now = t0.elapsed().as_micros() as u64;
        let mut buf = [0u8; 512];
        if let Ok(n) = wire.read(&mut buf) {
            pending.extend_from_slice(&buf[..n]);
        }
        let mut rest = &pending[..];
        while !rest.is_empty() {
            let (event, r) = ctrl.receive(now, rest);
            let stalled = event.is_none() && r.len() == rest.len();
            rest = r;
            match event {
                Some(Event::SliceReady) => {
                    if let Ok(slice) = ctrl.finish_slice(&mut store) {
                        // Acknowledge (and accept) before planning stops the loop.
                        while let Some(f) = ctrl.transmit(now) {
                            wire.write_all(f).unwrap();
                        }
                        let digest = host_sim::plan(slice).map(|p| p.last_plan().digest());
                        match digest {
                            Ok(digest) => {
                                outbox.push_back(CtrlMsg::Telemetry(Telemetry::Plan { digest }))
                            }
                            Err(e) => outbox.push_back(CtrlMsg::Error(RemoteError::Slice(e))),
                        }
                    }
                }
                Some(Event::Start) => {
                    let layers = ctrl.layers();
                    for layer in 0..layers {
                        let percent = (u32::from(layer) * 100 / u32::from(layers)) as u8;
                        outbox.push_back(CtrlMsg::Status(Status {
                            phase: Phase::Printing,
                            layer,
                            layers,
                            percent,
                        }));
                        outbox.push_back(CtrlMsg::Telemetry(Telemetry::Layer(layer_telemetry(
                            layer,
                        ))));
                    }
                    outbox.push_back(CtrlMsg::Status(Status {
                        phase: Phase::Done,
                        layer: layers,
                        layers,
                        percent: 100,
                    }));
                }
                _ => {}
            }
            if stalled {
                break;
            }
        }
        let used = pending.len() - rest.len();
        pending.drain(..used);
        while let Some(m) = outbox.front() {
            match ctrl.send(m) {
                Ok(()) => {
                    outbox.pop_front();
                }
                Err(LinkError::WindowFull) => break,
                Err(e) => panic!("{e}"),
            }
        }
        ctrl.poll(now);
        while let Some(f) = ctrl.transmit(now) {
            wire.write_all(f).unwrap();
        }
        lost |= ctrl.is_lost(now);
        std::thread::sleep(Duration::from_micros(100));
    }
    (ctrl.stats().retransmissions, lost)
}

fn layer_telemetry(layer: u16) -> LayerTelemetry {
    let l = u32::from(layer);
    LayerTelemetry {
        layer,
        steps: [1000 + l, 2000 + l, 96],
        valve_openings: [l, 1, 0, 2],
        valve_open_ticks: [u64::from(l) * 1000, 5, 0, 7],
        print_ticks: 1_000_000 + u64::from(l),
        starved: 0,
    }
}

/// The slice as the controller rebuilds it (whole micrometres), planned here.
fn host_digest(slice: &Slice) -> u64 {
    let mut asm: Box<SliceAssembler<MAX_HOLES, { (MAX_HOLES + 1) * MAX_VERTICES }>> =
        Box::default();
    for m in upload(slice, 1) {
        match m.unwrap() {
            HostMsg::Job { settings, layers } => asm.begin(settings, layers),
            HostMsg::Feature {
                feature,
                material,
                vertices,
            } => asm.feature(feature, material, vertices).unwrap(),
            HostMsg::Contour(c) => asm.chunk(&c).unwrap(),
            HostMsg::EndSlice { holes } => assert!(asm.end(holes).unwrap()),
            _ => unreachable!(),
        }
    }
    let rebuilt = asm.build().unwrap().unwrap();
    host_sim::plan(&rebuilt).unwrap().last_plan().digest()
}

fn session(faults: Faults, seed: u64) -> (LinkStats, u32) {
    let slice = slice_file::parse(REFERENCE_SLICES[0].1).unwrap().slice;
    let (host_end, ctrl_end) = pipe(faults, seed);
    let stop = AtomicBool::new(false);
    host_sim::run_on_large_stack(|| {
        std::thread::scope(|s| {
            let ctrl = std::thread::Builder::new()
                .stack_size(host_sim::STACK_BYTES)
                .spawn_scoped(s, || controller(ctrl_end, &stop))
                .unwrap();
            let mut client = LinkClient::new(host_end, CONFIG);
            client.timeout = Duration::from_secs(60);
            let (fw, caps) = client.hello().unwrap();
            assert_eq!(fw, FW);
            assert_eq!(caps.max_holes as usize, MAX_HOLES);
            client.send_printer(&PrinterConfig::default()).unwrap();
            let report = client.upload(&slice, 25).unwrap();
            assert_eq!(report.holes as usize, slice.holes().len());
            let digest = match client.next_message(Duration::from_secs(60)).unwrap() {
                Some(CtrlMsg::Telemetry(Telemetry::Plan { digest })) => digest,
                other => panic!("{other:?}"),
            };
            assert_eq!(
                digest,
                host_digest(&slice),
                "the controller planned another slice"
            );
            client.start().unwrap();
            let mut layers = Vec::new();
            let mut statuses = Vec::new();
            loop {
                match client.next_message(Duration::from_secs(60)).unwrap() {
                    Some(CtrlMsg::Status(st)) => {
                        statuses.push(st.layer);
                        if st.phase == Phase::Done {
                            break;
                        }
                    }
                    Some(CtrlMsg::Telemetry(Telemetry::Layer(t))) => layers.push(t),
                    other => panic!("{other:?}"),
                }
            }
            assert_eq!(layers, (0..25).map(layer_telemetry).collect::<Vec<_>>());
            assert_eq!(statuses, (0..=25).collect::<Vec<_>>());
            let host_stats = client.stats();
            stop.store(true, Ordering::Relaxed);
            let (ctrl_retransmissions, lost) = ctrl.join().unwrap();
            assert!(!lost, "the keepalives kept the watchdog fed");
            println!(
                "upload of {} messages: {} bytes; retransmissions: host {}, controller {}; host saw {} CRC errors, {} framing errors",
                report.messages, report.bytes, host_stats.retransmissions, ctrl_retransmissions,
                host_stats.crc_errors, host_stats.framing_errors
            );
            (host_stats, ctrl_retransmissions)
        })
    })
}

#[test]
fn a_clean_session_sees_no_bad_frame() {
    // Retransmissions may still happen here: the controller's loop stops while it plans,
    // and the host's clock runs on.
    let (h, _) = session(Faults::default(), 1);
    assert_eq!((h.crc_errors, h.framing_errors), (0, 0));
}

#[test]
fn a_faulty_pipe_loses_nothing_and_counts_retransmissions() {
    let faults = Faults {
        drop: 100,
        corrupt: 100,
        duplicate: 100,
        noise: 100,
    };
    let (h, c) = session(faults, 42);
    assert!(
        h.retransmissions > 0 && c > 0,
        "host {}, controller {c}",
        h.retransmissions
    );
    assert!(h.crc_errors + h.framing_errors > 0);
}

#[test]
fn the_client_reports_the_controllers_refusal() {
    let (host_end, ctrl_end) = pipe(Faults::default(), 3);
    let stop = AtomicBool::new(false);
    host_sim::run_on_large_stack(|| {
        std::thread::scope(|s| {
            let ctrl = std::thread::Builder::new()
                .stack_size(host_sim::STACK_BYTES)
                .spawn_scoped(s, || controller(ctrl_end, &stop))
                .unwrap();
            let mut client = LinkClient::new(host_end, CONFIG);
            client.hello().unwrap();
            let p = PrinterConfig {
                channels: 0,
                ..PrinterConfig::default()
            };
            let e = client.send_printer(&p).unwrap_err();
            assert!(
                matches!(e, ClientError::Remote(RemoteError::Printer(_))),
                "{e}"
            );
            assert_eq!(
                e.to_string(),
                "the controller refused: channels: 0 is out of range (1 to 4)"
            );
            // A start without an accepted slice.
            client.start().unwrap();
            let m = client.next_message(Duration::from_secs(10)).unwrap();
            assert_eq!(
                m,
                Some(CtrlMsg::Error(RemoteError::Link(
                    LinkError::UnexpectedMessage
                )))
            );
            stop.store(true, Ordering::Relaxed);
            ctrl.join().unwrap();
        })
    });
}
