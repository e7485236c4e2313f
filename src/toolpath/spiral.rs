//! The spiral layer (paper, section 2.4): in every Voronoi cell a spiral across the MCLs,
//! `S(t) = MCL_v(u)` with `u = f(v)`.
//!
//! `v` runs over the MCL halves around the feature, turn after turn; `u` is the position along
//! the half, from the feature (0) to the cell boundary (1), given by the control function `f`
//! the user chooses ([`ControlFunction`]). Each cell's spiral runs outwards. Beyond the paper,
//! the cells' spirals are chained into one road wherever they touch: a spiral ends on the joint
//! `p*` of a matched MCL, the road follows that MCL's other half inwards to the next feature,
//! and that cell's spiral starts there. Cells are visited along a path through the cells'
//! adjacency (matched MCLs); only where no such path exists does the road jump.
//!
//! Where a half ends on a bisector the spiral stops half a road width short of it, so the
//! spirals of the two cells do not deposit on the same line.

use heapless::Vec;

use crate::config::{MAX_HALVES, MAX_HOLES};
use crate::error::Limit;
use crate::geometry::polyline;
use crate::geometry::primitives::{fmax, MinMax};
use crate::mcl::HalfEnd;
use crate::toolpath::composition::{along, mcl_end_materials};
use crate::toolpath::lining::Lining;
use crate::toolpath::{emit_move, PathSink, Vertex};
use crate::{Error, Plan, Slice};

/// The spiral control function `u = f(v)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ControlFunction {
    /// `u` grows linearly with `v` (the paper's `f(v) = v`): every MCL is divided into the same
    /// number of turns, so turns are closer on short MCLs than on long ones.
    Linear,
    /// Turns a road width apart along every MCL: the position along an MCL grows by one road
    /// width per turn and stops at the MCL's end, so short MCLs are finished in fewer turns.
    RoadWidth,
    /// `u = v - sin(2 pi v) / (4 pi)`: turns half as far apart as [`Linear`](Self::Linear)'s
    /// at the feature and at the cell boundary and half again as far in between, for a denser
    /// deposit where the material meets the features and the neighbouring cells.
    Ease,
}

impl ControlFunction {
    /// The name on the command line.
    pub const fn name(self) -> &'static str {
        match self {
            ControlFunction::Linear => "linear",
            ControlFunction::RoadWidth => "road-width",
            ControlFunction::Ease => "ease",
        }
    }
}

/// Counters of a spiral layer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SpiralStats {
    /// Cells whose spiral was started by a jump (travel) rather than a connecting road.
    pub jumps: u16,
    /// Turns of the spiral in the first cell.
    pub turns: u16,
}

/// One half in a cell's cycle: its index, the MCL it belongs to, whether it is that MCL's
/// first half, and the length the spiral may use.
#[derive(Clone, Copy)]
struct Spoke {
    half: u16,
    mcl: u16,
    first: bool,
    usable: f32,
}

fn spokes(
    plan: &Plan,
    owner: &[u16; MAX_HALVES],
    hole: usize,
    half_width: f32,
) -> Result<Vec<Spoke, MAX_HALVES>, Error> {
    let order = crate::mcl::insert::sorted_halves(&plan.halves, hole)?;
    let mut out: Vec<Spoke, MAX_HALVES> = Vec::new();
    for &h in order.iter() {
        let k = owner[h as usize] as usize;
        let Some(m) = plan.mcls.get(k) else {
            continue;
        };
        let half = &plan.halves[h as usize];
        let len = polyline::length(plan.halves.points(h as usize));
        let usable = if half.end == HalfEnd::Wall {
            len
        } else {
            (len - half_width).fmax(0.0)
        };
        // Never full: one spoke per half in `order`, of the same capacity.
        out.push(Spoke {
            half: h,
            mcl: k as u16,
            first: m.first == h,
            usable,
        })
        .map_err(|_| Limit::Halves.error())?;
    }
    Ok(out)
}

/// Writes the spiral layer of `plan` into `sink`, each feature's lining in its own material
/// ([`Lining`], as the zigzag's): a chord between two turn points
/// just off a hole's keep-out curve, in a blend a thousandth off the hole's material, sags
/// onto the curve (four_holes' linear spiral once its plan had eight more MCLs: 0.0012).
pub fn spiral(
    slice: &Slice,
    plan: &Plan,
    f: ControlFunction,
    sink: &mut impl PathSink,
) -> Result<SpiralStats, Error> {
    let mut lined = Lining::new(sink, slice);
    spiral_into(slice, plan, f, &mut lined)
}

/// [`spiral`] into a sink that lines the features.
fn spiral_into(
    slice: &Slice,
    plan: &Plan,
    f: ControlFunction,
    sink: &mut impl PathSink,
) -> Result<SpiralStats, Error> {
    if slice.holes().is_empty() {
        return Err(Error::NoHoles);
    }
    let w = slice.settings().road_width;
    let holes = slice.holes().len();
    let mut stats = SpiralStats::default();
    // Adjacency: the shortest matched MCL between each pair of cells.
    let mut link = [[None::<(u16, f32)>; MAX_HOLES]; MAX_HOLES];
    for (k, m) in plan.mcls.iter().enumerate() {
        if let (crate::Target::Hole(j), Some(_)) = (m.to, m.second) {
            let len = polyline::length(&plan.points(m));
            let (a, b) = (m.from as usize, j as usize);
            if link[a][b].is_none_or(|l| len < l.1) {
                link[a][b] = Some((k as u16, len));
                link[b][a] = Some((k as u16, len));
            }
        }
    }
    let order = cell_order(holes, &link)?;
    // The MCL each half belongs to.
    let mut owner = [u16::MAX; MAX_HALVES];
    for (k, m) in plan.mcls.iter().enumerate() {
        owner[m.first as usize] = k as u16;
        if let Some(s) = m.second {
            owner[s as usize] = k as u16;
        }
    }
    let mut entry: Option<u16> = None; // the half the road arrives on, from the previous cell
    for (pos, &cell) in order.iter().enumerate() {
        let cell = cell as usize;
        let sp = spokes(plan, &owner, cell, 0.5 * w)?;
        if sp.is_empty() {
            continue;
        }
        let n = sp.len();
        // Where to start: the half we arrived on (its start is on this feature).
        let start = entry.and_then(|h| sp.iter().position(|s| s.half == h));
        if pos > 0 && start.is_none() {
            stats.jumps += 1;
        }
        let start = start.unwrap_or(0);
        // Where to end: on the half that leads to the next cell.
        let next = order.get(pos + 1).map(|&c| c as usize);
        let exit = next.and_then(|nc| link[cell][nc]).and_then(|(k, _)| {
            let m = &plan.mcls[k as usize];
            sp.iter()
                .position(|s| s.mcl == k && (m.from as usize == cell) == s.first)
        });
        let end = exit.unwrap_or((start + n - 1) % n);
        let extra = (end + n - start) % n;
        let longest = sp.iter().map(|s| s.usable).fold(0.0f32, fmax);
        let mean = sp.iter().map(|s| s.usable).sum::<f32>() / n as f32;
        let turns = match f {
            ControlFunction::RoadWidth => libm::ceilf(longest / w).fmax(1.0),
            _ => libm::roundf(mean / w).fmax(1.0),
        } as usize;
        if pos == 0 {
            stats.turns = turns.min(u16::MAX as usize) as u16;
        }
        let total = turns * n + extra;
        for v in 0..=total {
            let s = sp[(start + v) % n];
            let frac = v as f32 / total as f32;
            let t = match f {
                ControlFunction::Linear => frac * s.usable,
                ControlFunction::Ease => {
                    let tau = 2.0 * core::f32::consts::PI;
                    (frac - libm::sinf(tau * frac) / (2.0 * tau)).clamp(0.0, 1.0) * s.usable
                }
                ControlFunction::RoadWidth => {
                    // A road width per turn, ending exactly at the boundary on the last step.
                    let reach = (v as f32 / n as f32) * w;
                    if v == total {
                        s.usable
                    } else {
                        reach.fmin(s.usable)
                    }
                }
            };
            let p = polyline::point_at(plan.halves.points(s.half as usize), t);
            let (ma, mb) = mcl_end_materials(slice, plan, s.mcl as usize);
            let full = polyline::length(&plan.points(&plan.mcls[s.mcl as usize]));
            let at_full = if s.first { t } else { full - t };
            // Reached by travel only at the very start or after a jump (no connecting road).
            let deposit = v != 0 || entry.is_some();
            emit_move(
                slice,
                sink,
                Vertex {
                    at: p,
                    material: along(&ma, &mb, at_full, full),
                    width: slice.settings().road_width,
                    deposit,
                },
            )?;
        }
        // Into the next cell along the other half of the exit MCL.
        entry = None;
        if let (Some(_), Some(e)) = (next, exit) {
            let s = sp[e];
            let m = &plan.mcls[s.mcl as usize];
            let other = if s.first { m.second } else { Some(m.first) };
            if let Some(o) = other {
                let pts = plan.halves.points(o as usize);
                let (ma, mb) = mcl_end_materials(slice, plan, s.mcl as usize);
                let full = polyline::length(&plan.points(m));
                let mut cum = [0.0f32; crate::config::HALF_POINTS];
                polyline::cumulative(pts, &mut cum);
                let len = cum[pts.len() - 1];
                // From just short of p* (where the spiral ended) to the next feature.
                for i in (0..pts.len()).rev() {
                    if len - cum[i] < 0.5 * w {
                        continue;
                    }
                    let at_full = if s.first { full - cum[i] } else { cum[i] };
                    emit_move(
                        slice,
                        sink,
                        Vertex {
                            at: pts[i],
                            material: along(&ma, &mb, at_full, full),
                            width: slice.settings().road_width,
                            deposit: true,
                        },
                    )?;
                }
                entry = Some(o);
            }
        }
    }
    Ok(stats)
}

/// Cells up to which the search for a linked order is exhaustive; beyond, it gives up after
/// [`SEARCH_STEPS`] steps (the search is exponential in the cells).
const EXHAUSTIVE_CELLS: usize = 8;
/// Steps of the search for a linked order of more than [`EXHAUSTIVE_CELLS`] cells.
const SEARCH_STEPS: u32 = 200_000;

/// An order of the cells along which consecutive cells are linked, if one exists (depth-first
/// search for a Hamiltonian path: exhaustive up to eight cells, at most [`SEARCH_STEPS`] steps
/// beyond); else the cells in index order.
fn cell_order(
    holes: usize,
    link: &[[Option<(u16, f32)>; MAX_HOLES]; MAX_HOLES],
) -> Result<Vec<u8, MAX_HOLES>, Error> {
    fn extend(
        path: &mut Vec<u8, MAX_HOLES>,
        used: &mut [bool; MAX_HOLES],
        holes: usize,
        link: &[[Option<(u16, f32)>; MAX_HOLES]; MAX_HOLES],
        budget: &mut u32,
    ) -> Result<bool, Error> {
        if path.len() == holes {
            return Ok(true);
        }
        if *budget == 0 {
            return Ok(false);
        }
        *budget -= 1;
        let last = *path.last().unwrap_or(&0) as usize;
        for c in 0..holes {
            if !used[c] && link[last][c].is_some() {
                used[c] = true;
                // Never full: each of the `holes <= MAX_HOLES` cells is used once.
                path.push(c as u8).map_err(|_| Limit::Holes.error())?;
                if extend(path, used, holes, link, budget)? {
                    return Ok(true);
                }
                path.pop();
                used[c] = false;
            }
        }
        Ok(false)
    }
    let mut budget = if holes <= EXHAUSTIVE_CELLS {
        u32::MAX
    } else {
        SEARCH_STEPS
    };
    for first in 0..holes {
        if budget == 0 {
            break;
        }
        let mut path: Vec<u8, MAX_HOLES> = Vec::new();
        let mut used = [false; MAX_HOLES];
        used[first] = true;
        // Never full: the path was just created.
        path.push(first as u8).map_err(|_| Limit::Holes.error())?;
        if extend(&mut path, &mut used, holes, link, &mut budget)? {
            return Ok(path);
        }
    }
    let mut order = Vec::new();
    for c in 0..holes {
        // `holes <= MAX_HOLES` (the slice holds no more).
        order.push(c as u8).map_err(|_| Limit::Holes.error())?;
    }
    Ok(order)
}
