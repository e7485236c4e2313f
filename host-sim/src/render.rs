//! SVG pictures of a plan: wall, features, bisectors, branch points and MCLs coloured by the
//! materials they join.

use std::fmt::Write;

use hollowpath::geometry::Point;
use hollowpath::{Material, Plan, Slice, Target};

/// Display colour of each material channel (sRGB).
pub const CHANNEL_COLOURS: [[f32; 3]; 4] = [
    [0.84, 0.15, 0.16],
    [0.12, 0.47, 0.71],
    [0.17, 0.63, 0.17],
    [1.00, 0.50, 0.05],
];

/// The display colour of a composition: the channels' colours mixed by fraction.
pub fn colour(m: &Material) -> String {
    let mut c = [0.0f32; 3];
    for (k, frac) in m.iter().enumerate() {
        for (ci, cc) in c.iter_mut().enumerate() {
            *cc += frac * CHANNEL_COLOURS[k][ci];
        }
    }
    format!(
        "#{:02x}{:02x}{:02x}",
        (c[0].clamp(0.0, 1.0) * 255.0) as u8,
        (c[1].clamp(0.0, 1.0) * 255.0) as u8,
        (c[2].clamp(0.0, 1.0) * 255.0) as u8
    )
}

/// An SVG path `d` attribute for `pts` (y flipped: SVG's y points down).
pub fn svg_path(pts: &[Point], close: bool) -> String {
    let mut s = String::new();
    for (k, p) in pts.iter().enumerate() {
        let _ = write!(
            s,
            "{}{:.4},{:.4} ",
            if k == 0 { "M" } else { "L" },
            p.x,
            -p.y
        );
    }
    if close {
        s.push('Z');
    }
    s.trim_end().to_string()
}

/// The MCL picture (`mcls.svg`).
pub fn mcls_svg(slice: &Slice, plan: &Plan) -> String {
    let (lo, hi) = slice.wall().bbox();
    let m = 1.0;
    let w = slice.settings().road_width;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="{} {} {} {}" width="{}" height="{}">"#,
        lo.x - m,
        -hi.y - m,
        hi.x - lo.x + 2.0 * m,
        hi.y - lo.y + 2.0 * m,
        ((hi.x - lo.x + 2.0 * m) * 25.0) as u32,
        ((hi.y - lo.y + 2.0 * m) * 25.0) as u32
    );
    let _ = writeln!(
        s,
        r#"<rect x="{}" y="{}" width="100%" height="100%" fill="white"/>"#,
        lo.x - m,
        -hi.y - m
    );
    let _ = writeln!(s, "<defs>");
    for (k, mcl) in plan.mcls.iter().enumerate() {
        let pts = plan.points(mcl);
        let (a, b) = (pts[0], pts[pts.len() - 1]);
        let ca = colour(&slice.holes()[mcl.from as usize].material());
        let cb = match mcl.to {
            Target::Wall => colour(&slice.wall().material()),
            Target::Hole(j) => colour(&slice.holes()[j as usize].material()),
        };
        let _ = writeln!(
            s,
            r#"<linearGradient id="g{k}" gradientUnits="userSpaceOnUse" x1="{:.4}" y1="{:.4}" x2="{:.4}" y2="{:.4}"><stop offset="0" stop-color="{ca}"/><stop offset="1" stop-color="{cb}"/></linearGradient>"#,
            a.x, -a.y, b.x, -b.y
        );
    }
    let _ = writeln!(s, "</defs>");
    let _ = writeln!(
        s,
        r#"<path d="{}" fill="none" stroke="{}" stroke-width="0.12"/>"#,
        svg_path(slice.wall().points(), true),
        colour(&slice.wall().material())
    );
    for h in slice.holes() {
        let _ = writeln!(
            s,
            r##"<path d="{}" fill="#eeeeee" stroke="{}" stroke-width="0.12"/>"##,
            svg_path(h.points(), true),
            colour(&h.material())
        );
    }
    for b in plan.bisectors() {
        let _ = writeln!(
            s,
            r##"<path d="{}" fill="none" stroke="#555555" stroke-width="0.06" stroke-dasharray="0.3,0.2"/>"##,
            svg_path(&b.points, false)
        );
    }
    for (k, mcl) in plan.mcls.iter().enumerate() {
        let _ = writeln!(
            s,
            r#"<path d="{}" fill="none" stroke="url(#g{k})" stroke-width="{:.3}" stroke-linecap="round"/>"#,
            svg_path(&plan.points(mcl), false),
            0.25 * w
        );
    }
    for p in plan.cells.branch_points.iter() {
        let _ = writeln!(
            s,
            r#"<circle cx="{:.4}" cy="{:.4}" r="0.25" fill="black"/>"#,
            p.x, -p.y
        );
    }
    s.push_str("</svg>\n");
    s
}
