//! Every message round-trips through postcard and through a frame; the core's errors convert
//! back losslessly; the hello of another protocol version still decodes.

use hollowpath::config::CHANNELS;
use hollowpath::geometry::Point;
use hollowpath::link::contour::chunks;
use hollowpath::link::endpoint::{Link, LinkConfig};
use hollowpath::link::error::LinkError;
use hollowpath::link::frame::MAX_PAYLOAD;
use hollowpath::link::message::{
    Capacities, CtrlMsg, HostMsg, LayerTelemetry, Phase, RemoteError, Status, StopReport,
    Telemetry, Version, CHUNK_BYTES, PROTOCOL_VERSION, SMALL_PAYLOAD,
};
use hollowpath::link::upload::printer;
use hollowpath::link::wire::{WirePrinterError, PRINTER_KEYS};
use hollowpath::motion::config::{CurvePoint, PrinterConfig, PrinterError, CURVE_POINTS};
use hollowpath::motion::Fault;
use hollowpath::{Error, FeatureId, Limit, SettingId, Settings};

fn full_printer() -> PrinterConfig {
    let mut p = PrinterConfig::default();
    for ch in p.channel.iter_mut() {
        ch.curve.clear();
        for k in 0..CURVE_POINTS {
            let t = k as f32 / (CURVE_POINTS - 1) as f32;
            ch.curve
                .push(CurvePoint {
                    duty: t,
                    flow: t * t,
                })
                .unwrap();
        }
    }
    p
}

fn full_chunk() -> HostMsg {
    // Coordinates far apart: every varint at its longest.
    let pts: Vec<Point> = (0..400)
        .map(|k| {
            if k % 2 == 0 {
                Point::new(-999.0, 999.0)
            } else {
                Point::new(999.0, -999.0)
            }
        })
        .collect();
    HostMsg::Contour(chunks(FeatureId::Hole(7), &pts).next().unwrap().unwrap())
}

fn host_messages() -> Vec<HostMsg> {
    let mut v = vec![HostMsg::Hello {
        protocol: PROTOCOL_VERSION,
    }];
    v.extend(printer(&full_printer()).unwrap());
    v.extend([
        HostMsg::Job {
            settings: Settings::for_road_width(0.33),
            layers: 400,
        },
        HostMsg::Feature {
            feature: FeatureId::Wall,
            material: [0.25; CHANNELS],
            vertices: 4096,
        },
        full_chunk(),
        HostMsg::EndSlice { holes: 64 },
        HostMsg::Start,
        HostMsg::Pause,
        HostMsg::Resume,
        HostMsg::Abort,
    ]);
    v
}

fn errors() -> Vec<RemoteError> {
    let mut v = vec![
        RemoteError::Slice(Error::HoleCrossesWall {
            hole: 3,
            edge: 70,
            wall_edge: 4000,
        }),
        RemoteError::Slice(Error::Capacity {
            limit: Limit::Halves,
            feature: Some(FeatureId::Hole(2)),
        }),
        RemoteError::Slice(Error::InvalidSetting {
            setting: SettingId::MaxWidth,
            value: 9.5,
        }),
        RemoteError::Slice(Error::SliceTooLarge {
            width: 1.0,
            height: 2.0,
            road_width: 0.4,
            holds: 3.0,
            spiral: true,
        }),
        RemoteError::Slice(Error::TooManyVertices {
            feature: FeatureId::Wall,
            vertices: 1 << 20,
            simplified: true,
        }),
        RemoteError::Machine(Fault::Homing { axis: 2 }),
        RemoteError::Link(LinkError::ProtocolMismatch { ours: 1, theirs: 9 }),
        RemoteError::Link(LinkError::AssemblerPoints {
            capacity: 2304,
            needed: 5000,
        }),
        RemoteError::Link(LinkError::ChunkOrder {
            feature: FeatureId::Hole(1),
            expected: 10,
            got: 20,
        }),
    ];
    for e in printer_errors() {
        v.push(RemoteError::Printer(e.into()));
    }
    v
}

/// A refusal of every kind `PrinterConfig::validate` and `check_slice` give.
fn printer_errors() -> Vec<PrinterError> {
    let mut out = Vec::new();
    let mut push = |f: &dyn Fn(&mut PrinterConfig)| {
        let mut p = PrinterConfig::default();
        f(&mut p);
        out.push(p.validate().unwrap_err());
    };
    push(&|p| p.axes[1].steps_per_mm = -1.0);
    push(&|p| p.axes[0].max_speed = 0.0);
    push(&|p| p.axes[2].max_accel = f32::INFINITY);
    push(&|p| p.print_speed = 0.0);
    push(&|p| p.travel_speed = -3.0);
    push(&|p| p.homing_speed = 0.0);
    push(&|p| p.junction_deviation = 0.0);
    push(&|p| p.homing_travel = 0.0);
    push(&|p| p.layer_height = 0.0);
    push(&|p| p.step_pulse_ns = 0);
    push(&|p| p.dir_setup_ns = 0);
    push(&|p| p.tick_hz = 1);
    push(&|p| p.channels = 0);
    push(&|p| p.channel[1].full_flow = 0.0);
    push(&|p| p.channel[2].dead_time_s = -1.0);
    push(&|p| p.channel[2].time_constant_s = -1.0);
    push(&|p| p.channel[0].lead_s = -1.0);
    push(&|p| p.channel[0].lag_s = -1.0);
    push(&|p| p.channel[3].pwm_hz = 0.0);
    push(&|p| p.channel[3].curve[1].duty = 2.0);
    push(&|p| p.channel[0].dead_time_s = 10.0);
    push(&|p| p.home[1] = f32::NAN);
    out
}

fn ctrl_messages() -> Vec<CtrlMsg> {
    let mut v = vec![
        CtrlMsg::Hello {
            protocol: PROTOCOL_VERSION,
            firmware: Version {
                major: 0,
                minor: 3,
                patch: 1,
            },
            capacities: Capacities {
                max_holes: 8,
                max_vertices: 256,
                max_points: 2304,
                channels: 4,
            },
        },
        CtrlMsg::PrinterAccepted,
        CtrlMsg::SliceAccepted {
            holes: 4,
            vertices: 360,
        },
        CtrlMsg::Status(Status {
            phase: Phase::Paused,
            layer: 12,
            layers: 40,
            percent: 31,
        }),
        CtrlMsg::Telemetry(Telemetry::Plan {
            digest: u64::MAX - 5,
        }),
        CtrlMsg::Telemetry(Telemetry::Layer(LayerTelemetry {
            layer: 39,
            steps: [u32::MAX, 12, 0],
            valve_openings: [1, 2, 3, 4],
            valve_open_ticks: [u64::MAX, 0, 7, 1 << 40],
            print_ticks: 1 << 50,
            starved: 3,
        })),
    ];
    v.extend(errors().into_iter().map(CtrlMsg::Error));
    v.push(CtrlMsg::Stopped(StopReport {
        fault: Fault::HostSilent,
        layer: 3,
        at_us: u64::MAX,
        heard_us: Some(1 << 40),
        watchdog_us: 30_000_000,
        steps: [u64::MAX, 1, 0],
    }));
    v
}

#[test]
fn every_message_round_trips_and_fits_a_frame() {
    for m in host_messages() {
        let mut buf = [0u8; MAX_PAYLOAD];
        let bytes = postcard::to_slice(&m, &mut buf).unwrap_or_else(|e| panic!("{m:?}: {e}"));
        assert_eq!(postcard::from_bytes::<HostMsg>(bytes).unwrap(), m);
        // Small frames: on a line that spoils 1 % of the bytes most arrive whole.
        assert!(bytes.len() <= SMALL_PAYLOAD, "{} bytes: {m:?}", bytes.len());
    }
    // The fullest printer takes several chunks, each but the last full.
    let chunks: Vec<HostMsg> = printer(&full_printer()).unwrap().collect();
    assert!(chunks.len() >= 3, "{}", chunks.len());
    for c in &chunks[..chunks.len() - 1] {
        let HostMsg::Printer(c) = c else {
            panic!("{c:?}")
        };
        assert_eq!(c.data.len(), CHUNK_BYTES);
    }
    for m in ctrl_messages() {
        let mut buf = [0u8; MAX_PAYLOAD];
        let bytes = postcard::to_slice(&m, &mut buf).unwrap_or_else(|e| panic!("{m:?}: {e}"));
        assert_eq!(postcard::from_bytes::<CtrlMsg>(bytes).unwrap(), m);
    }
}

#[test]
fn every_message_crosses_a_link() {
    let cfg = LinkConfig {
        retransmit_us: 1_000,
        keepalive_us: 0,
        watchdog_us: 0,
    };
    let mut host: Link<HostMsg, CtrlMsg, 4> = Link::new(cfg);
    let mut ctrl: Link<CtrlMsg, HostMsg, 4> = Link::new(cfg);
    let (up, down) = (host_messages(), ctrl_messages());
    let (mut got_up, mut got_down) = (Vec::new(), Vec::new());
    let (mut i, mut j) = (0, 0);
    for now in 0..1000u64 {
        while i < up.len() && host.send(&up[i]).is_ok() {
            i += 1;
        }
        while j < down.len() && ctrl.send(&down[j]).is_ok() {
            j += 1;
        }
        let mut wire = Vec::new();
        while let Some(f) = host.transmit(now) {
            wire.extend_from_slice(f);
        }
        let mut rest = &wire[..];
        while !rest.is_empty() {
            let (m, r) = ctrl.receive(now, rest);
            rest = r;
            if let Some(m) = m.unwrap() {
                got_up.push(m);
            }
        }
        let mut wire = Vec::new();
        while let Some(f) = ctrl.transmit(now) {
            wire.extend_from_slice(f);
        }
        let mut rest = &wire[..];
        while !rest.is_empty() {
            let (m, r) = host.receive(now, rest);
            rest = r;
            if let Some(m) = m.unwrap() {
                got_down.push(m);
            }
        }
    }
    assert_eq!(got_up, up);
    assert_eq!(got_down, down);
    assert_eq!(
        host.stats().retransmissions + ctrl.stats().retransmissions,
        0
    );
}

#[test]
fn printer_errors_convert_back_losslessly_and_print_the_same() {
    let all = printer_errors();
    assert!(all.len() >= 20);
    for e in all {
        let w = WirePrinterError::from(e);
        let mut buf = [0u8; 64];
        let bytes = postcard::to_slice(&w, &mut buf).unwrap();
        let back = PrinterError::from(postcard::from_bytes::<WirePrinterError>(bytes).unwrap());
        assert_eq!(back, e);
        assert_eq!(back.to_string(), e.to_string());
        if let PrinterError::Speed { key, .. }
        | PrinterError::Pulse { key, .. }
        | PrinterError::ChannelValue { key, .. } = e
        {
            assert!(
                PRINTER_KEYS.contains(&key),
                "{key} missing from PRINTER_KEYS"
            );
        }
    }
}

#[test]
fn remote_errors_print_as_the_core_prints_them() {
    let e = Error::HolesNested { outer: 1, inner: 2 };
    assert_eq!(RemoteError::Slice(e).to_string(), e.to_string());
    let l = LinkError::ProtocolMismatch { ours: 1, theirs: 2 };
    assert!(RemoteError::Link(l)
        .to_string()
        .contains("protocol version 2"));
}

#[test]
fn hello_of_another_version_still_decodes() {
    // A later version's hello: variant 0, the protocol first, then fields this one lacks.
    let mut buf = [0u8; 32];
    let newer = postcard::to_slice(&(0u8, 7u16, "future fields", 99u32), &mut buf).unwrap();
    assert_eq!(
        postcard::from_bytes::<HostMsg>(newer).unwrap(),
        HostMsg::Hello { protocol: 7 }
    );
    let newer =
        postcard::to_slice(&(0u8, 7u16, [1u8, 2, 3], [8u8, 0, 0, 1, 0, 4]), &mut buf).unwrap();
    assert!(matches!(
        postcard::from_bytes::<CtrlMsg>(newer).unwrap(),
        CtrlMsg::Hello { protocol: 7, .. }
    ));
}
