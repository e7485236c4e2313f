//! What a [`Trace`] printed, rebuilt from the pins alone (see
//! [`virtual_printer`](crate::virtual_printer)).

use hollowpath::config::CHANNELS;
use hollowpath::geometry::Point;
use hollowpath::motion::config::AXES;
use hollowpath::motion::valve::flow_for;
use hollowpath::motion::PrinterConfig;
use hollowpath::toolpath::moves::Move;

use crate::virtual_printer::{Pin, Trace};

/// Two steps of one axis further apart than this are a stop and a start, not an even move, s.
pub const GAP_S: f64 = 0.05;

/// How finely to rebuild.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rebuild {
    /// Length of one rebuilt move, s.
    pub window_s: f64,
    /// The narrowest bead counted as deposit, mm (below it the nozzle is taken to travel).
    pub min_width_mm: f32,
    /// The shortest rebuilt move, mm: windows are gathered until the nozzle moved this far,
    /// so that where it crawls (into a hairpin) the width is not a volume over a vanishing
    /// length.
    pub min_length_mm: f32,
    /// The stretch of path a depositing move's width is taken over, mm (see [`rebuild`]).
    pub smooth_mm: f32,
}

impl Rebuild {
    /// 1 ms windows (the step engine's segment length), gathered to moves of at least a tenth
    /// of `road_width`; beads narrower than a tenth of `road_width` are not deposit.
    pub fn for_road_width(road_width: f32) -> Rebuild {
        Rebuild {
            window_s: 0.001,
            min_width_mm: 0.1 * road_width,
            min_length_mm: 0.05 * road_width,
            smooth_mm: 0.25 * road_width,
        }
    }
}

/// The figures of a trace.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TraceFigures {
    /// Net signed steps per axis (rising step edges, signed by the direction pin).
    pub net_steps: [i64; AXES],
    /// Step pulses per axis.
    pub pulses: [u64; AXES],
    /// Times each channel's duty went from 0 to more.
    pub valve_openings: [u32; CHANNELS],
    /// Times the valves went from all shut to any open.
    pub any_openings: u32,
    /// Seconds each channel's duty was above 0.
    pub valve_open_s: [f64; CHANNELS],
    /// Volume each channel delivered (through the valve model), mm^3.
    pub volume_mm3: [f64; CHANNELS],
    /// The fastest step rate of any axis: tick rate over the shortest gap between two rising
    /// edges of one axis, Hz.
    pub max_step_rate_hz: f64,
    /// The shortest step pulse, ticks.
    pub min_pulse_ticks: u64,
    /// The shortest time from a direction change to its axis' next step, ticks.
    pub min_dir_setup_ticks: u64,
    /// From the first alarm to the last, s.
    pub print_time_s: f64,
    /// Where the nozzle ended, mm (from home and the steps).
    pub end_mm: [f64; AXES],
}

/// A rebuilt layer: its moves as printed and the trace's figures.
#[derive(Clone, Debug)]
pub struct Rebuilt {
    /// Constant-width moves, one per window (travel where the bead is too narrow), and discs
    /// (zero-length deposit moves) where the nozzle stood while material came out.
    pub moves: Vec<Move>,
    /// The figures.
    pub figures: TraceFigures,
}

/// One channel's valve model: duty timeline -> curve -> dead time -> first-order lag,
/// integrated exactly (the target is constant between duty changes).
struct Flow {
    /// (time the change reaches the flow, s; target flow, mm^3/s).
    events: Vec<(f64, f64)>,
    next: usize,
    t: f64,
    q: f64,
    target: f64,
    tau: f64,
    volume: f64,
}

impl Flow {
    fn new(cfg: &PrinterConfig, trace: &Trace, channel: usize) -> Flow {
        let ch = &cfg.channel[channel];
        let hz = cfg.tick_hz as f64;
        let events = trace
            .duties
            .iter()
            .filter(|d| d.channel as usize == channel)
            .map(|d| {
                (
                    d.t as f64 / hz + ch.dead_time_s as f64,
                    ch.full_flow as f64 * flow_for(&ch.curve, d.duty) as f64,
                )
            })
            .collect();
        Flow {
            events,
            next: 0,
            t: 0.0,
            q: 0.0,
            target: 0.0,
            tau: ch.time_constant_s as f64,
            volume: 0.0,
        }
    }

    fn integrate(&mut self, to: f64) {
        let dt = to - self.t;
        if dt <= 0.0 {
            return;
        }
        if self.tau > 0.0 {
            let e = (-dt / self.tau).exp();
            let d = self.q - self.target;
            self.volume += self.target * dt + d * self.tau * (1.0 - e);
            self.q = self.target + d * e;
        } else {
            self.volume += self.target * dt;
            self.q = self.target;
        }
        self.t = to;
    }

    /// The volume delivered from the start to `t` (non-decreasing `t`), mm^3.
    fn volume_until(&mut self, t: f64) -> f64 {
        while let Some(&(at, target)) = self.events.get(self.next) {
            if at > t {
                break;
            }
            self.integrate(at);
            self.target = target;
            self.next += 1;
        }
        self.integrate(t);
        self.volume
    }
}

/// Rebuilds what `trace` printed on printer `cfg` (layers of `cfg.layer_height`).
pub fn rebuild(cfg: &PrinterConfig, trace: &Trace, how: &Rebuild) -> Rebuilt {
    let hz = cfg.tick_hz as f64;
    let h = cfg.layer_height as f64;
    let channels = cfg.channels().len();
    let mut fig = TraceFigures {
        min_pulse_ticks: u64::MAX,
        min_dir_setup_ticks: u64::MAX,
        print_time_s: trace.now as f64 / hz,
        ..TraceFigures::default()
    };
    let dir_high_positive = [0, 1, 2].map(|a| !cfg.axes[a].invert_dir);

    // The nozzle: position (steps) after every rising step edge.
    let mut dir = [false; AXES];
    let mut pos = [0i64; AXES];
    let mut rise: [Option<u64>; AXES] = [None; AXES];
    let mut last_rise: [Option<u64>; AXES] = [None; AXES];
    let mut dir_changed: [Option<u64>; AXES] = [None; AXES];
    let mut min_gap = u64::MAX;
    let mut samples: Vec<(u64, [i64; AXES])> = Vec::with_capacity(trace.edges.len() / 2 + 1);
    for e in &trace.edges {
        match (e.pin, e.high) {
            (Pin::Dir(a), level) => {
                let a = a as usize;
                dir[a] = level;
                dir_changed[a] = Some(e.t);
            }
            (Pin::Step(a), true) => {
                let a = a as usize;
                pos[a] += if dir[a] == dir_high_positive[a] {
                    1
                } else {
                    -1
                };
                fig.pulses[a] += 1;
                if let Some(t) = last_rise[a] {
                    min_gap = min_gap.min(e.t - t);
                }
                if let Some(t) = dir_changed[a].take() {
                    fig.min_dir_setup_ticks = fig.min_dir_setup_ticks.min(e.t - t);
                }
                last_rise[a] = Some(e.t);
                rise[a] = Some(e.t);
                samples.push((e.t, pos));
            }
            (Pin::Step(a), false) => {
                if let Some(r) = rise[a as usize].take() {
                    fig.min_pulse_ticks = fig.min_pulse_ticks.min(e.t - r);
                }
            }
        }
    }
    fig.net_steps = pos;
    fig.max_step_rate_hz = if min_gap == u64::MAX {
        0.0
    } else {
        hz / min_gap as f64
    };
    let mm = |p: [i64; AXES], a: usize| {
        cfg.home[a] as f64 + p[a] as f64 / cfg.axes[a].steps_per_mm as f64
    };
    for a in 0..AXES {
        fig.end_mm[a] = mm(pos, a);
    }

    // The valves' timeline.
    let mut open = [None::<u64>; CHANNELS];
    let mut any = false;
    for d in &trace.duties {
        let c = d.channel as usize;
        if d.duty > 0.0 && open[c].is_none() {
            open[c] = Some(d.t);
            fig.valve_openings[c] += 1;
        } else if d.duty == 0.0 {
            if let Some(t) = open[c].take() {
                fig.valve_open_s[c] += (d.t - t) as f64 / hz;
            }
        }
        let now_any = open.iter().any(Option::is_some);
        if now_any && !any {
            fig.any_openings += 1;
        }
        any = now_any;
    }
    for (c, o) in open.iter().enumerate() {
        if let Some(t) = o {
            fig.valve_open_s[c] += (trace.now - t) as f64 / hz;
        }
    }

    // The deposition, window by window; after the last alarm the flow still decays (the
    // nozzle stands at its end), so the windows run on for the valves' slowest response.
    let mut flows: Vec<Flow> = (0..channels).map(|c| Flow::new(cfg, trace, c)).collect();
    let tail = cfg
        .channels()
        .iter()
        .map(|c| c.dead_time_s as f64 + 10.0 * c.time_constant_s as f64)
        .fold(0.0, f64::max);
    let end_s = trace.now as f64 / hz + tail;
    let window = how.window_s.max(1e-6);
    let n = (end_s / window).ceil() as usize;
    // Each axis' position at a window's end, interpolated between its steps (a step is a
    // 1/steps_per_mm jump; between two steps less than `GAP_S` apart the axis moves on
    // evenly), so a window's length is not off by the step quantisation.
    let mut axes: Vec<Vec<(u64, i64)>> = vec![Vec::new(); AXES];
    {
        let mut last = [0i64; AXES];
        for &(t, p) in &samples {
            for a in 0..AXES {
                if p[a] != last[a] {
                    axes[a].push((t, p[a]));
                    last[a] = p[a];
                }
            }
        }
    }
    let gap = (GAP_S * hz) as u64;
    let mut cursor = [0usize; AXES];
    let mut position = |t: f64| -> Point {
        let mut out = [0.0f64; AXES];
        for a in 0..2 {
            let s = &axes[a];
            let c = &mut cursor[a];
            while *c < s.len() && (s[*c].0 as f64) <= t {
                *c += 1;
            }
            let steps = match (c.checked_sub(1).map(|i| s[i]), s.get(*c)) {
                (None, _) => 0.0,
                (Some((_, p)), None) => p as f64,
                (Some((t0, p0)), Some(&(t1, p1))) if t1 - t0 <= gap => {
                    p0 as f64 + (t - t0 as f64) / (t1 - t0) as f64 * (p1 - p0) as f64
                }
                (Some((_, p)), Some(_)) => p as f64,
            };
            out[a] = cfg.home[a] as f64 + steps / cfg.axes[a].steps_per_mm as f64;
        }
        Point::new(out[0] as f32, out[1] as f32)
    };
    let mut moves: Vec<Piece> = Vec::with_capacity(n / 4 + 16);
    let mut a = position(0.0);
    let mut v0 = [0.0f64; CHANNELS];
    // Volume delivered while the nozzle stood at `a`.
    let mut standing = [0.0f64; CHANNELS];
    // The piece being gathered: where it starts, its length and volume per channel.
    let mut piece: Option<(Point, f64, [f64; CHANNELS])> = None;
    let min_len = how.min_length_mm as f64;
    for w in 1..=n {
        let t1 = w as f64 * window;
        let b = position(t1 * hz);
        let mut dv = [0.0f64; CHANNELS];
        for (c, f) in flows.iter_mut().enumerate() {
            let v = f.volume_until(t1);
            dv[c] = v - v0[c];
            v0[c] = v;
        }
        let len = (b.x as f64 - a.x as f64).hypot(b.y as f64 - a.y as f64);
        if len <= 0.0 {
            // Standing: a piece too short to carry its volume as a bead joins the disc
            // laid here.
            if let Some((from, l, v)) = piece.take() {
                if l >= min_len {
                    push_piece(&mut moves, from, a, l, &v, h, how.min_width_mm);
                } else {
                    for c in 0..CHANNELS {
                        standing[c] += v[c];
                    }
                }
            }
            for c in 0..CHANNELS {
                standing[c] += dv[c];
            }
            continue;
        }
        flush_disc(&mut moves, a, &mut standing, h, how.min_width_mm);
        let (from, l, mut v) = piece.take().unwrap_or((a, 0.0, [0.0; CHANNELS]));
        for c in 0..CHANNELS {
            v[c] += dv[c];
        }
        let l = l + len;
        if l >= min_len {
            push_piece(&mut moves, from, b, l, &v, h, how.min_width_mm);
        } else {
            piece = Some((from, l, v));
        }
        a = b;
    }
    if let Some((from, l, v)) = piece.take() {
        push_piece(&mut moves, from, a, l, &v, h, how.min_width_mm);
    }
    flush_disc(&mut moves, a, &mut standing, h, how.min_width_mm);
    for (c, f) in flows.iter_mut().enumerate() {
        fig.volume_mm3[c] = f.volume_until(end_s);
    }
    Rebuilt {
        moves: smooth(&moves, h, how.smooth_mm as f64, how.min_width_mm),
        figures: fig,
    }
}

/// A rebuilt piece: its move (width from its own volume), its length along the nozzle's way
/// (0 for a disc) and the volume per channel it received.
type Piece = (Move, f64, [f64; CHANNELS]);

/// The pieces' moves, each depositing piece's width taken over the `span` mm of path centred
/// on it (within its run of depositing pieces between stops): the volume over that stretch
/// / (its length x `h`). A piece alone carries the step quantisation of its length and the
/// segment timing of its volume; over a fraction of a road width they average out.
fn smooth(pieces: &[Piece], h: f64, span: f64, min_width: f32) -> Vec<Move> {
    let mut out: Vec<Move> = pieces.iter().map(|p| p.0).collect();
    let mut i = 0;
    while i < pieces.len() {
        if !(pieces[i].0.deposit && pieces[i].1 > 0.0) {
            i += 1;
            continue;
        }
        let mut j = i;
        while j < pieces.len() && pieces[j].0.deposit && pieces[j].1 > 0.0 {
            j += 1;
        }
        // Run i..j: arc length at each piece's start, and the volume before it.
        let run = &pieces[i..j];
        let mut s = Vec::with_capacity(run.len() + 1);
        let mut v = Vec::with_capacity(run.len() + 1);
        s.push(0.0);
        v.push(0.0);
        for p in run {
            s.push(s.last().copied().unwrap_or(0.0) + p.1);
            v.push(v.last().copied().unwrap_or(0.0) + p.2.iter().sum::<f64>());
        }
        let (mut lo, mut hi) = (0, 0);
        for k in 0..run.len() {
            let mid = 0.5 * (s[k] + s[k + 1]);
            while s[lo + 1] < mid - 0.5 * span {
                lo += 1;
            }
            while hi < run.len() && s[hi] < mid + 0.5 * span {
                hi += 1;
            }
            let hi = hi.max(k + 1);
            let len = s[hi] - s[lo];
            let width = ((v[hi] - v[lo]) / (len * h)) as f32;
            let m = &mut out[i + k];
            m.deposit = width >= min_width;
            m.width = if m.deposit { width } else { 0.0 };
        }
        i = j;
    }
    out
}

/// Lays a piece of path `from` -> `to` (`len` mm along the nozzle's way) that received `v`
/// mm^3: one move of width `v / (len x h)`, travel if narrower than `min_width`.
fn push_piece(
    moves: &mut Vec<Piece>,
    from: Point,
    to: Point,
    len: f64,
    v: &[f64; CHANNELS],
    h: f64,
    min_width: f32,
) {
    let volume: f64 = v.iter().sum();
    let width = (volume / (len * h)) as f32;
    let deposit = width >= min_width;
    let m = Move {
        from,
        to,
        width: if deposit { width } else { 0.0 },
        material: mix(v),
        deposit,
    };
    moves.push((m, len, *v));
}

/// The channels' shares of `dv` (all 0 if nothing was delivered).
fn mix(dv: &[f64; CHANNELS]) -> [f32; CHANNELS] {
    let total: f64 = dv.iter().sum();
    let mut m = [0.0f32; CHANNELS];
    if total > 0.0 {
        for c in 0..CHANNELS {
            m[c] = (dv[c] / total) as f32;
        }
    }
    m
}

/// Lays the volume delivered while the nozzle stood at `at` as a disc of that volume (a
/// zero-length move), if it is as wide as a bead.
fn flush_disc(
    moves: &mut Vec<Piece>,
    at: Point,
    standing: &mut [f64; CHANNELS],
    h: f64,
    min_width: f32,
) {
    let volume: f64 = standing.iter().sum();
    if volume > 0.0 {
        let width = (4.0 * volume / (std::f64::consts::PI * h)).sqrt() as f32;
        if width >= min_width {
            let m = Move {
                from: at,
                to: at,
                width,
                material: mix(standing),
                deposit: true,
            };
            moves.push((m, 0.0, *standing));
        }
    }
    *standing = [0.0; CHANNELS];
}
