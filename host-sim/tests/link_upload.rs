//! What the reference slices cost on the wire: bytes per vertex of the contour encoding and
//! of the whole upload (frames, COBS, CRC, headers, the job and feature messages), and the
//! upload time at 115 200 and 1 000 000 baud (8N1: 10 bits a byte).

use std::path::Path;

use hollowpath::link::endpoint::{Link, LinkConfig};
use hollowpath::link::message::{CtrlMsg, HostMsg};
use hollowpath::link::upload::upload;
use host_sim::{slice_file, REFERENCE_SLICES};

/// The four reference slices, from `shared/slices` when it is there, else host-sim's copies.
fn reference_slices() -> Vec<(String, hollowpath::Slice)> {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/slices");
    REFERENCE_SLICES
        .iter()
        .map(|(name, text)| {
            let path = shared.join(format!("{name}.json"));
            let file = if path.is_file() {
                slice_file::load(&path).expect(name)
            } else {
                slice_file::parse(text).expect(name)
            };
            (name.to_string(), file.slice)
        })
        .collect()
}

#[test]
fn reference_slices_upload_compactly() {
    let cfg = LinkConfig {
        retransmit_us: 1 << 40,
        keepalive_us: 0,
        watchdog_us: 0,
    };
    println!(
        "{:<12} {:>8} {:>13} {:>12} {:>12} {:>14} {:>14}",
        "slice", "vertices", "contour B/v", "wire bytes", "wire B/v", "115200 baud", "1000000 baud"
    );
    host_sim::run_on_large_stack(|| {
        for (name, slice) in reference_slices() {
            let vertices: usize = std::iter::once(slice.wall())
                .chain(slice.holes())
                .map(|f| f.points().len())
                .sum();
            let mut link: Link<HostMsg, CtrlMsg, 4> = Link::new(cfg);
            let (mut contour, mut wire, mut sent) = (0usize, 0usize, 0u8);
            for msg in upload(&slice, 100) {
                let msg = msg.unwrap();
                if let HostMsg::Contour(c) = &msg {
                    contour += c.data.len();
                }
                link.send(&msg).unwrap();
                sent = sent.wrapping_add(1);
                while let Some(f) = link.transmit(0) {
                    wire += f.len();
                }
                // The controller's ack of everything so far (on the other wire, not counted)
                // frees the window.
                let mut ack = [0u8; 16];
                let n = hollowpath::link::frame::encode(
                    hollowpath::link::frame::Kind::Ack,
                    0,
                    sent,
                    &[],
                    &mut ack,
                )
                .unwrap();
                let _ = link.receive(0, &ack[..n]);
            }
            let per = |b: usize| b as f64 / vertices as f64;
            let secs = |baud: f64| wire as f64 * 10.0 / baud;
            println!(
                "{name:<12} {vertices:>8} {:>13.2} {wire:>12} {:>12.2} {:>12.1} ms {:>12.1} ms",
                per(contour),
                per(wire),
                secs(115_200.0) * 1e3,
                secs(1_000_000.0) * 1e3
            );
            // Roads of 0.4 mm have vertices under 8 mm apart: 2 bytes a coordinate.
            assert!(per(contour) <= 4.1, "{name}: {} B/vertex", per(contour));
            assert!(
                per(wire) <= 6.0,
                "{name}: {} B/vertex on the wire",
                per(wire)
            );
        }
    });
}
