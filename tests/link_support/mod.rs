//! A lossy byte channel between two link ends on a virtual clock, and the frame fuzz case
//! (shared by `tests/link_channel.rs` and `benches/link_fuzz.rs`).
#![allow(dead_code)]

use hollowpath::geometry::Point;
use hollowpath::link::contour::{chunks, ChunkDecoder};
use hollowpath::link::endpoint::{Link, LinkConfig, LinkStats};
use hollowpath::link::frame::{self, Feed, FrameAccumulator, Kind, MAX_FRAME};
use hollowpath::link::message::{CtrlMsg, HostMsg, Phase, Status};
use hollowpath::FeatureId;
use serde::de::DeserializeOwned;
use serde::Serialize;

/// xorshift64*: deterministic, no dependency.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    pub fn next(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    /// True with probability `per_mille` / 1000.
    pub fn chance(&mut self, per_mille: u32) -> bool {
        (self.next() % 1000) < per_mille as u64
    }
}

/// Fault rates per frame, per mille.
#[derive(Clone, Copy, Debug, Default)]
pub struct Faults {
    pub drop: u32,
    pub corrupt: u32,
    pub duplicate: u32,
    pub reorder: u32,
}

/// One direction of the line: frames in flight with their arrival times.
#[derive(Default)]
pub struct Wire {
    flight: Vec<(u64, Vec<u8>)>,
    /// When the line is free again (bytes go out one after another).
    free_at: u64,
    /// Data frames dropped or damaged past reading (each needs a retransmission).
    pub lost_data: u32,
    pub frames: u32,
}

fn is_data(frame: &[u8]) -> bool {
    let mut acc = FrameAccumulator::<MAX_FRAME>::new();
    matches!(acc.feed(frame).0, Feed::Frame(f) if f.kind == Kind::Data)
}

/// The frames `bytes` hold, each as its `Debug` text (owned, to compare).
fn frames_in(bytes: &[u8]) -> Vec<String> {
    let mut acc = FrameAccumulator::<MAX_FRAME>::new();
    let mut out = Vec::new();
    let mut rest = bytes;
    while !rest.is_empty() {
        let (feed, tail) = acc.feed(rest);
        if let Feed::Frame(f) = feed {
            out.push(format!("{f:?}"));
        }
        rest = tail;
    }
    out
}

impl Wire {
    pub fn send(&mut self, now: u64, frame: &[u8], rng: &mut Rng, faults: Faults) {
        self.frames += 1;
        // A FIFO line: 10 us a byte (1 Mbaud) after the frames before, plus 1 ms latency;
        // a reordered frame is held back up to 20 ms.
        self.free_at = self.free_at.max(now) + 10 * frame.len() as u64;
        let at = self.free_at + 1_000;
        if rng.chance(faults.drop) {
            self.lost_data += u32::from(is_data(frame));
            return;
        }
        let mut f = frame.to_vec();
        if rng.chance(faults.corrupt) {
            // Byte faults: a bit flipped, a byte lost, inserted or repeated, two swapped, the
            // frame cut short.
            let k = rng.below(f.len());
            match rng.below(6) {
                0 => f[k] ^= 1 << rng.below(8),
                1 => {
                    f.remove(k);
                }
                2 => f.insert(k, rng.next() as u8),
                3 => f.insert(k, f[k]),
                4 if k + 1 < f.len() && f[k] != f[k + 1] => f.swap(k, k + 1),
                _ => f.truncate(k),
            }
            // Lost unless the damaged bytes still hold the frame: a repeated delimiter, or a
            // zero byte inserted before the frame, only adds an empty frame beside it.
            let intact = frames_in(frame);
            if !frames_in(&f).iter().any(|g| intact.contains(g)) {
                self.lost_data += u32::from(is_data(frame));
            }
        }
        let copies = if rng.chance(faults.duplicate) { 2 } else { 1 };
        for _ in 0..copies {
            let delay = if rng.chance(faults.reorder) {
                rng.below(20_000) as u64
            } else {
                0
            };
            self.flight.push((at + delay, f.clone()));
        }
        self.flight.sort_by_key(|x| x.0);
    }

    /// The bytes arriving by `now`, in arrival order.
    pub fn arrive(&mut self, now: u64) -> Vec<u8> {
        let n = self.flight.iter().take_while(|x| x.0 <= now).count();
        self.flight.drain(..n).flat_map(|x| x.1).collect()
    }
}

/// Feeds `bytes` to `link` in random pieces, collecting what it delivers.
pub fn feed<O: Serialize, I: DeserializeOwned, const W: usize>(
    link: &mut Link<O, I, W>,
    now: u64,
    bytes: &[u8],
    rng: &mut Rng,
    out: &mut Vec<I>,
) {
    let mut rest = bytes;
    while !rest.is_empty() {
        let piece = (1 + rng.below(64)).min(rest.len());
        let (mut b, tail) = rest.split_at(piece);
        rest = tail;
        while !b.is_empty() {
            let (m, r) = link.receive(now, b);
            b = r;
            if let Ok(Some(m)) = m {
                out.push(m);
            }
        }
    }
}

pub const WINDOW: usize = 4;
pub type HostEnd = Link<HostMsg, CtrlMsg, WINDOW>;
pub type CtrlEnd = Link<CtrlMsg, HostMsg, WINDOW>;

pub const SIM_CONFIG: LinkConfig = LinkConfig {
    retransmit_us: 25_000,
    keepalive_us: 100_000,
    watchdog_us: 0,
};

/// What a simulation ended with.
pub struct Outcome {
    pub host_got: Vec<CtrlMsg>,
    pub ctrl_got: Vec<HostMsg>,
    pub host: LinkStats,
    pub ctrl: LinkStats,
    pub lost_data: u32,
    pub elapsed_us: u64,
}

/// Both ends send their messages over a faulty line until everything is delivered and
/// acknowledged, or `limit_us` of virtual time passed.
pub fn simulate(
    seed: u64,
    faults: Faults,
    to_ctrl: &[HostMsg],
    to_host: &[CtrlMsg],
    limit_us: u64,
) -> Outcome {
    let mut rng = Rng::new(seed);
    let mut host = HostEnd::new(SIM_CONFIG);
    host.open(seed as u8);
    let mut ctrl = CtrlEnd::new(SIM_CONFIG);
    let (mut up, mut down) = (Wire::default(), Wire::default());
    let (mut host_got, mut ctrl_got) = (Vec::new(), Vec::new());
    let (mut hi, mut ci) = (0, 0);
    let mut now = 0;
    while now < limit_us {
        while hi < to_ctrl.len() && host.can_send() {
            host.send(&to_ctrl[hi]).unwrap();
            hi += 1;
        }
        // The controller speaks once the host opened the session (its first message).
        let open = to_ctrl.is_empty() || !ctrl_got.is_empty();
        while open && ci < to_host.len() && ctrl.can_send() {
            ctrl.send(&to_host[ci]).unwrap();
            ci += 1;
        }
        host.poll(now);
        while let Some(f) = host.transmit(now) {
            up.send(now, f, &mut rng, faults);
        }
        ctrl.poll(now);
        while let Some(f) = ctrl.transmit(now) {
            down.send(now, f, &mut rng, faults);
        }
        let b = up.arrive(now);
        feed(&mut ctrl, now, &b, &mut rng, &mut ctrl_got);
        let b = down.arrive(now);
        feed(&mut host, now, &b, &mut rng, &mut host_got);
        if hi == to_ctrl.len()
            && ci == to_host.len()
            && host.in_flight() == 0
            && ctrl.in_flight() == 0
            && host_got.len() >= to_host.len()
            && ctrl_got.len() >= to_ctrl.len()
        {
            break;
        }
        now += 500;
    }
    Outcome {
        host_got,
        ctrl_got,
        host: host.stats(),
        ctrl: ctrl.stats(),
        lost_data: up.lost_data + down.lost_data,
        elapsed_us: now,
    }
}

/// `n` host messages of every size: small commands and full contour chunks.
pub fn host_messages(n: usize, rng: &mut Rng) -> Vec<HostMsg> {
    (0..n)
        .map(|k| match rng.below(4) {
            0 => HostMsg::Pause,
            1 => HostMsg::EndSlice { holes: k as u8 },
            _ => {
                let pts: Vec<Point> = (0..1 + rng.below(200))
                    .map(|j| Point::new(j as f32 * 0.37, (rng.below(2000) as f32) * 0.01))
                    .collect();
                HostMsg::Contour(chunks(FeatureId::Hole(3), &pts).next().unwrap().unwrap())
            }
        })
        .collect()
}

/// `n` controller messages.
pub fn ctrl_messages(n: usize) -> Vec<CtrlMsg> {
    (0..n)
        .map(|k| {
            CtrlMsg::Status(Status {
                phase: Phase::Printing,
                layer: k as u16,
                layers: n as u16,
                percent: (k * 100 / n.max(1)) as u8,
            })
        })
        .collect()
}

/// One fuzz case: a real frame (or none) mutated, or random bytes, fed to the frame
/// accumulator, a link end and the message and contour decoders. `Err` if a frame other than
/// the one sent was accepted. Panics are failures of the caller's `catch_unwind`.
pub fn fuzz_case(rng: &mut Rng, host: &mut CtrlEnd) -> Result<(), String> {
    let mut payload = vec![0u8; rng.below(frame::MAX_PAYLOAD + 1)];
    for b in payload.iter_mut() {
        *b = rng.next() as u8;
    }
    let (kind, seq, ack) = match rng.below(4) {
        0 => (Kind::Data, rng.next() as u8, rng.next() as u8),
        1 => (Kind::Open, 0, rng.next() as u8),
        2 => (Kind::Ack, 0, rng.next() as u8),
        _ => (Kind::Nak, 0, rng.next() as u8),
    };
    if matches!(kind, Kind::Ack | Kind::Nak) {
        payload.clear();
    }
    let mut buf = [0u8; MAX_FRAME];
    let n = frame::encode(kind, seq, ack, &payload, &mut buf).unwrap();
    let mut bytes = buf[..n].to_vec();
    match rng.below(6) {
        0 => {
            // Pure noise.
            bytes = (0..rng.below(2 * MAX_FRAME))
                .map(|_| rng.next() as u8)
                .collect();
        }
        1 => {
            for _ in 0..1 + rng.below(4) {
                let k = rng.below(bytes.len());
                bytes[k] ^= 1 << rng.below(8);
            }
        }
        2 => {
            let k = rng.below(bytes.len());
            bytes[k] = rng.next() as u8;
        }
        3 => {
            let k = rng.below(bytes.len());
            bytes.insert(k, rng.next() as u8);
        }
        4 => {
            let k = rng.below(bytes.len());
            bytes.remove(k);
        }
        _ => {} // unmodified: must be accepted
    }
    let unmodified = bytes == buf[..n];
    let mut acc = FrameAccumulator::<MAX_FRAME>::new();
    let mut rest = &bytes[..];
    let mut accepted = 0;
    while !rest.is_empty() {
        let (r, tail) = acc.feed(rest);
        rest = tail;
        if let Feed::Frame(f) = r {
            accepted += 1;
            if (f.kind, f.seq, f.ack, f.payload) != (kind, seq, ack, &payload[..]) {
                return Err(format!("accepted a frame never sent: {bytes:02x?}"));
            }
        }
    }
    if unmodified && accepted != 1 {
        return Err(format!("refused a good frame: {bytes:02x?}"));
    }
    // The same bytes through a link end, and the payload through every decoder.
    let mut rest = &bytes[..];
    while !rest.is_empty() {
        rest = host.receive(0, rest).1;
    }
    let _ = postcard::from_bytes::<HostMsg>(&payload);
    let _ = postcard::from_bytes::<CtrlMsg>(&payload);
    for q in ChunkDecoder::new(&payload) {
        if q.is_err() {
            break;
        }
    }
    Ok(())
}
