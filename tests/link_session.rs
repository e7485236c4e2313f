//! The controller's end of a session against a host end, in process: the handshake, a slice
//! upload through the assembler and the core's validation, refusals, the watchdog.

mod common;

use common::{circle, two_circles, A, B, WALL};
use hollowpath::link::assemble::SliceAssembler;
use hollowpath::link::contour::{chunks, quantize};
use hollowpath::link::controller::{Controller, Event};
use hollowpath::link::endpoint::{Link, LinkConfig};
use hollowpath::link::error::LinkError;
use hollowpath::link::message::{CtrlMsg, HostMsg, RemoteError, Version, PROTOCOL_VERSION};
use hollowpath::link::upload::upload;
use hollowpath::motion::config::{PrinterConfig, PrinterError};
use hollowpath::{Error, FeatureId, Settings};

const CFG: LinkConfig = LinkConfig {
    retransmit_us: 5_000,
    keepalive_us: 0,
    watchdog_us: 50_000,
};
const FW: Version = Version {
    major: 1,
    minor: 2,
    patch: 3,
};
type Ctrl = Controller<8, 2304, 4>;
type Host = Link<HostMsg, CtrlMsg, 4>;

/// Moves every frame both ways at `now`; returns the controller's events and the host's
/// messages.
fn exchange(host: &mut Host, ctrl: &mut Ctrl, now: u64) -> (Vec<Event>, Vec<CtrlMsg>) {
    let mut events = Vec::new();
    let mut got = Vec::new();
    let mut wire = Vec::new();
    while let Some(f) = host.transmit(now) {
        wire.extend_from_slice(f);
    }
    let mut rest = &wire[..];
    while !rest.is_empty() {
        let (e, r) = ctrl.receive(now, rest);
        rest = r;
        if e == Some(Event::SliceReady) {
            // The outcome reaches the host as a reply (accepted, or the error), which the
            // tests read from the host's side.
            let mut store = Box::new(hollowpath::slice::SliceStore::new());
            let _reported = ctrl.finish_slice(&mut store);
        }
        events.extend(e);
    }
    let mut wire = Vec::new();
    while let Some(f) = ctrl.transmit(now) {
        wire.extend_from_slice(f);
    }
    let mut rest = &wire[..];
    while !rest.is_empty() {
        let (m, r) = host.receive(now, rest);
        rest = r;
        got.extend(m.unwrap());
    }
    (events, got)
}

/// Sends `msgs` (as the window allows) and exchanges until everything is acknowledged.
fn run(
    host: &mut Host,
    ctrl: &mut Ctrl,
    msgs: &[HostMsg],
    now: &mut u64,
) -> (Vec<Event>, Vec<CtrlMsg>) {
    let (mut events, mut got) = (Vec::new(), Vec::new());
    let mut i = 0;
    for _ in 0..10_000 {
        while i < msgs.len() && host.send(&msgs[i]).is_ok() {
            i += 1;
        }
        let (e, g) = exchange(host, ctrl, *now);
        events.extend(e);
        got.extend(g);
        *now += 100;
        if i == msgs.len() && host.in_flight() == 0 {
            let (e, g) = exchange(host, ctrl, *now);
            events.extend(e);
            got.extend(g);
            break;
        }
    }
    (events, got)
}

/// The printer configuration's chunks.
fn printer_msgs(p: &PrinterConfig) -> Vec<HostMsg> {
    hollowpath::link::upload::printer(p).unwrap().collect()
}

fn hello() -> HostMsg {
    HostMsg::Hello {
        protocol: PROTOCOL_VERSION,
    }
}

#[test]
fn a_slice_uploads_validates_and_starts() {
    let slice = two_circles(Settings::default());
    let mut msgs = vec![hello()];
    msgs.extend(printer_msgs(&PrinterConfig::default()));
    msgs.extend(upload(&slice, 12).map(Result::unwrap));
    let (mut host, mut ctrl, mut now) = (Host::new(CFG), Ctrl::new(CFG, FW), 0);
    let (events, got) = run(&mut host, &mut ctrl, &msgs, &mut now);
    assert_eq!(events, [Event::Hello, Event::Printer, Event::SliceReady]);
    assert!(matches!(
        got[0],
        CtrlMsg::Hello {
            protocol: PROTOCOL_VERSION,
            firmware: FW,
            ..
        }
    ));
    assert_eq!(got[1], CtrlMsg::PrinterAccepted);
    assert_eq!(
        got[2],
        CtrlMsg::SliceAccepted {
            holes: 2,
            vertices: 128 + 48 + 48
        }
    );
    assert_eq!(ctrl.layers(), 12);
    let (events, _) = run(&mut host, &mut ctrl, &[HostMsg::Start], &mut now);
    assert_eq!(events, [Event::Start]);
}

#[test]
fn the_controller_rebuilds_the_slice_to_the_micrometre() {
    let slice = two_circles(Settings::default());
    let mut asm: SliceAssembler<8, 2304> = SliceAssembler::new();
    for m in upload(&slice, 1) {
        match m.unwrap() {
            HostMsg::Job { settings, layers } => asm.begin(settings, layers),
            HostMsg::Feature {
                feature,
                material,
                vertices,
            } => asm.feature(feature, material, vertices).unwrap(),
            HostMsg::Contour(c) => asm.chunk(&c).unwrap(),
            HostMsg::EndSlice { holes } => assert!(asm.end(holes).unwrap()),
            m => panic!("{m:?}"),
        }
    }
    let got = asm.build().unwrap().unwrap();
    for (a, b) in std::iter::once(slice.wall())
        .chain(slice.holes())
        .zip(std::iter::once(got.wall()).chain(got.holes()))
    {
        let q: Vec<_> = a.points().iter().map(|&p| quantize(p)).collect();
        assert_eq!(b.points(), &q[..]);
        assert_eq!(a.material(), b.material());
    }
    assert_eq!(got.settings(), slice.settings());
}

#[test]
fn a_protocol_mismatch_is_refused_on_both_sides() {
    let (mut host, mut ctrl, mut now) = (Host::new(CFG), Ctrl::new(CFG, FW), 0);
    let msgs = [
        HostMsg::Hello {
            protocol: PROTOCOL_VERSION + 1,
        },
        HostMsg::Start,
    ];
    let (events, got) = run(&mut host, &mut ctrl, &msgs, &mut now);
    let mismatch = LinkError::ProtocolMismatch {
        ours: PROTOCOL_VERSION,
        theirs: PROTOCOL_VERSION + 1,
    };
    assert_eq!(events[0], Event::Refused(RemoteError::Link(mismatch)));
    assert_eq!(
        events[1],
        Event::Refused(RemoteError::Link(LinkError::NotGreeted))
    );
    // The host learns the controller's version from its hello, and checks it itself.
    let CtrlMsg::Hello { protocol, .. } = got[0] else {
        panic!("{got:?}")
    };
    assert_eq!(
        hollowpath::link::message::check_protocol(protocol + 1),
        Err(LinkError::ProtocolMismatch {
            ours: PROTOCOL_VERSION,
            theirs: protocol + 1
        })
    );
    assert_eq!(got[1], CtrlMsg::Error(RemoteError::Link(mismatch)));
}

fn refusal_of(msgs: Vec<HostMsg>) -> Vec<RemoteError> {
    let (mut host, mut ctrl, mut now) = (Host::new(CFG), Ctrl::new(CFG, FW), 0);
    let mut all = vec![hello()];
    all.extend(msgs);
    let (_, got) = run(&mut host, &mut ctrl, &all, &mut now);
    got.into_iter()
        .filter_map(|m| {
            if let CtrlMsg::Error(e) = m {
                Some(e)
            } else {
                None
            }
        })
        .collect()
}

#[test]
fn a_bad_slice_is_refused_with_the_cores_error_and_never_started() {
    // Hole 1 sticks out of the wall.
    let wall = circle(0.0, 0.0, 12.0, 64, 0.0);
    let h0 = circle(-5.0, 0.0, 2.0, 32, 0.0);
    let h1 = circle(11.0, 0.0, 2.0, 32, 0.0);
    let mut msgs = printer_msgs(&PrinterConfig::default());
    msgs.push(HostMsg::Job {
        settings: Settings::default(),
        layers: 3,
    });
    for (id, pts, m) in [
        (FeatureId::Wall, &wall, WALL),
        (FeatureId::Hole(0), &h0, A),
        (FeatureId::Hole(1), &h1, B),
    ] {
        msgs.push(HostMsg::Feature {
            feature: id,
            material: m,
            vertices: pts.len() as u32,
        });
        msgs.extend(chunks(id, pts).map(|c| HostMsg::Contour(c.unwrap())));
    }
    msgs.push(HostMsg::EndSlice { holes: 2 });
    msgs.push(HostMsg::Start);
    let errs = refusal_of(msgs);
    assert!(
        matches!(
            errs[0],
            RemoteError::Slice(Error::HoleOutsideWall { hole: 1, .. })
        ),
        "{errs:?}"
    );
    assert_eq!(errs[1], RemoteError::Link(LinkError::UnexpectedMessage));
    assert_eq!(errs.len(), 2);
}

#[test]
fn a_printer_the_motion_code_cannot_drive_is_refused_by_key() {
    let mut p = PrinterConfig::default();
    p.channel[2].pwm_hz = 0.0;
    let errs = refusal_of(printer_msgs(&p));
    let RemoteError::Printer(w) = errs[0] else {
        panic!("{errs:?}")
    };
    assert_eq!(PrinterError::from(w), p.validate().unwrap_err());
    assert!(PrinterError::from(w)
        .to_string()
        .starts_with("channel[2].pwm_hz"));
}

#[test]
fn assembler_refusals_name_what_to_change() {
    let s = Settings::default();
    let m = [1.0, 0.0, 0.0, 0.0];
    let job = HostMsg::Job {
        settings: s,
        layers: 1,
    };
    let wall = circle(0.0, 0.0, 12.0, 64, 0.0);
    // Too many vertices for the assembler's pool.
    let errs = refusal_of(vec![
        job.clone(),
        HostMsg::Feature {
            feature: FeatureId::Wall,
            material: m,
            vertices: 5000,
        },
    ]);
    assert_eq!(
        errs,
        [RemoteError::Link(LinkError::AssemblerPoints {
            capacity: 2304,
            needed: 5000
        })]
    );
    assert!(errs[0].to_string().contains("raise its POINTS"));
    // A hole before the wall.
    let errs = refusal_of(vec![
        job.clone(),
        HostMsg::Feature {
            feature: FeatureId::Hole(0),
            material: m,
            vertices: 3,
        },
    ]);
    assert_eq!(
        errs,
        [RemoteError::Link(LinkError::FeatureOrder {
            expected: FeatureId::Wall,
            got: FeatureId::Hole(0)
        })]
    );
    // A contour short of what it declared; only the first refusal is reported.
    let mut msgs = vec![
        job.clone(),
        HostMsg::Feature {
            feature: FeatureId::Wall,
            material: m,
            vertices: 65,
        },
    ];
    msgs.extend(chunks(FeatureId::Wall, &wall).map(|c| HostMsg::Contour(c.unwrap())));
    msgs.push(HostMsg::EndSlice { holes: 0 });
    let errs = refusal_of(msgs);
    assert_eq!(
        errs,
        [RemoteError::Link(LinkError::VertexCount {
            feature: FeatureId::Wall,
            declared: 65,
            received: 64
        })]
    );
    // A contour before any job.
    let errs = refusal_of(vec![HostMsg::Feature {
        feature: FeatureId::Wall,
        material: m,
        vertices: 3,
    }]);
    assert_eq!(errs, [RemoteError::Link(LinkError::UnexpectedMessage)]);
    // Holes beyond the assembler's HOLES.
    let mut asm: SliceAssembler<1, 100> = SliceAssembler::new();
    asm.begin(s, 1);
    asm.feature(FeatureId::Wall, m, 0).unwrap();
    asm.feature(FeatureId::Hole(0), m, 0).unwrap();
    assert_eq!(
        asm.feature(FeatureId::Hole(1), m, 0),
        Err(LinkError::AssemblerHoles { capacity: 1 })
    );
}

#[test]
fn a_restarted_host_opens_a_new_session() {
    let (mut host, mut ctrl, mut now) = (Host::new(CFG), Ctrl::new(CFG, FW), 0);
    host.open(1);
    let mut msgs = vec![hello()];
    msgs.extend(printer_msgs(&PrinterConfig::default()));
    msgs.push(HostMsg::Pause);
    let (events, _) = run(&mut host, &mut ctrl, &msgs, &mut now);
    assert_eq!(events, [Event::Hello, Event::Printer, Event::Pause]);
    // The controller has frames in flight to a host that is gone ...
    ctrl.send(&CtrlMsg::PrinterAccepted).unwrap();
    let _ = ctrl.transmit(now);
    // ... and a new host, from sequence number 0, is heard all the same.
    let mut host = Host::new(CFG);
    host.open(2);
    let (events, got) = run(&mut host, &mut ctrl, &[hello(), HostMsg::Resume], &mut now);
    assert_eq!(events, [Event::Hello, Event::Resume]);
    assert!(matches!(got[..], [CtrlMsg::Hello { .. }]), "{got:?}");
    assert_eq!(ctrl.stats().sessions, 2);
    // A new session must greet first.
    let mut host = Host::new(CFG);
    host.open(3);
    let (events, _) = run(&mut host, &mut ctrl, &[HostMsg::Resume], &mut now);
    assert_eq!(
        events,
        [Event::Refused(RemoteError::Link(LinkError::NotGreeted))]
    );
}

#[test]
fn the_watchdog_reports_a_silent_host() {
    let (mut host, mut ctrl, mut now) = (Host::new(CFG), Ctrl::new(CFG, FW), 0);
    assert!(!ctrl.is_lost(1_000_000)); // no host yet
    run(&mut host, &mut ctrl, &[hello()], &mut now);
    assert!(!ctrl.is_lost(now + 40_000));
    assert!(ctrl.is_lost(now + 60_000));
    // The deadline poll returns covers the watchdog.
    assert!(ctrl.poll(now).is_some_and(|d| d <= now + 50_001));
    // A host with keepalives keeps it fed through a long idle time.
    let cfg = LinkConfig {
        keepalive_us: 10_000,
        ..CFG
    };
    let (mut host, mut ctrl, mut now) = (Host::new(cfg), Ctrl::new(CFG, FW), 0);
    run(&mut host, &mut ctrl, &[hello()], &mut now);
    for _ in 0..1000 {
        host.poll(now);
        exchange(&mut host, &mut ctrl, now);
        assert!(!ctrl.is_lost(now));
        now += 1_000;
    }
}

#[test]
fn the_controller_fits_a_static_on_the_mcu() {
    // The MCU's capacities (this test crate builds the core without `large`).
    type Mcu = Controller<
        { hollowpath::config::MAX_HOLES },
        { (hollowpath::config::MAX_HOLES + 1) * hollowpath::config::MAX_VERTICES },
        4,
    >;
    let bytes = std::mem::size_of::<Mcu>();
    println!("controller (link, assembler, printer): {bytes} bytes");
    if !hollowpath::config::LARGE {
        assert!(bytes < 28 * 1024, "{bytes} bytes");
    }
}

mod random_messages {
    use super::*;
    use heapless::Vec as HVec;
    use hollowpath::link::message::ContourChunk;
    use proptest::prelude::*;

    fn op() -> impl Strategy<Value = HostMsg> {
        let id = prop_oneof![Just(FeatureId::Wall), (0u8..10).prop_map(FeatureId::Hole)];
        prop_oneof![
            Just(HostMsg::Job {
                settings: Settings::default(),
                layers: 2
            }),
            (id.clone(), 0u32..400).prop_map(|(feature, vertices)| HostMsg::Feature {
                feature,
                material: [1.0, 0.0, 0.0, 0.0],
                vertices
            }),
            (id, 0u32..400, proptest::collection::vec(any::<u8>(), 0..64)).prop_map(
                |(feature, start, d)| {
                    let mut data = HVec::new();
                    data.extend_from_slice(&d).unwrap();
                    HostMsg::Contour(ContourChunk {
                        feature,
                        start,
                        data,
                    })
                }
            ),
            (0u8..10).prop_map(|holes| HostMsg::EndSlice { holes }),
            Just(HostMsg::Start),
            Just(HostMsg::Abort),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

        /// Any sequence of messages: no panic, every refusal reported, and a start only after a
        /// slice was accepted.
        #[test]
        fn random_message_sequences_never_start_an_unaccepted_slice(ops in proptest::collection::vec(op(), 0..60)) {
            let (mut host, mut ctrl, mut now) = (Host::new(CFG), Ctrl::new(CFG, FW), 0);
            let mut all = vec![hello()];
            all.extend(ops);
            let (events, got) = run(&mut host, &mut ctrl, &all, &mut now);
            let accepted = got.iter().any(|m| matches!(m, CtrlMsg::SliceAccepted { .. }));
            if events.contains(&Event::Start) {
                prop_assert!(accepted);
            }
            let refusals = events.iter().filter(|e| matches!(e, Event::Refused(_))).count();
            let errors = got.iter().filter(|m| matches!(m, CtrlMsg::Error(_))).count();
            // Slice refusals from finish_slice are reported too, with no Refused event.
            prop_assert!(errors >= refusals);
        }
    }
}
