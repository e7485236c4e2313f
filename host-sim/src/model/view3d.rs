//! The part in 3D: every layer's roads stacked at their heights, coloured by composition, as a
//! PNG seen from an angle (tiny-skia) and as a self-contained HTML page (a canvas the user
//! turns with the mouse; no script from anywhere else).

use std::fmt::Write;

use tiny_skia::{Color, LineCap, Paint, PathBuilder, Pixmap, Stroke, Transform};

use super::part::PlannedLayer;
use crate::render::CHANNEL_COLOURS;

/// One deposited piece of road: ends (mm), colour, width (mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Piece {
    /// Start, mm.
    pub a: [f64; 3],
    /// End, mm.
    pub b: [f64; 3],
    /// sRGB colour.
    pub rgb: [u8; 3],
    /// Road width, mm.
    pub width: f64,
}

fn rgb(m: &hollowpath::Material) -> [u8; 3] {
    let mut c = [0.0f32; 3];
    for (k, f) in m.iter().enumerate() {
        for (ci, cc) in c.iter_mut().enumerate() {
            *cc += f * CHANNEL_COLOURS[k.min(3)][ci];
        }
    }
    c.map(|x| (x.clamp(0.0, 1.0) * 255.0).round() as u8)
}

/// The deposited pieces of `layers` (layer `k` at height `(k + 1/2) h`), consecutive moves of
/// one colour merged into pieces of at least `min_mm` (0 keeps every move).
pub fn pieces(layers: &[PlannedLayer], layer_height: f64, min_mm: f64) -> Vec<Piece> {
    let mut out = Vec::new();
    for l in layers {
        let z = (l.index as f64 + 0.5) * layer_height;
        for isl in &l.islands {
            let mut open: Option<Piece> = None;
            for w in isl.path.windows(2) {
                let (p, q) = (w[0], w[1]);
                if !q.deposit {
                    out.extend(open.take());
                    continue;
                }
                let a = [p.at.x as f64, p.at.y as f64, z];
                let b = [q.at.x as f64, q.at.y as f64, z];
                let c = rgb(&q.material);
                match &mut open {
                    Some(o) if o.rgb == c && dist(o.a, o.b) < min_mm => o.b = b,
                    _ => {
                        out.extend(open.take());
                        open = Some(Piece {
                            a,
                            b,
                            rgb: c,
                            width: q.width as f64,
                        });
                    }
                }
            }
            out.extend(open);
        }
    }
    out
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The view: turned `azimuth` about Z, seen from `elevation` above the horizon (radians).
/// Returns screen (u right, v up) and depth (larger farther).
fn project(p: [f64; 3], azimuth: f64, elevation: f64) -> (f64, f64, f64) {
    let (sa, ca) = azimuth.sin_cos();
    let (se, ce) = elevation.sin_cos();
    let x = p[0] * ca - p[1] * sa;
    let y = p[0] * sa + p[1] * ca;
    (x, p[2] * ce + y * se, y * ce - p[2] * se)
}

/// A piece on the screen: depth, ends (u, v), the piece.
type Projected<'a> = (f64, (f64, f64), (f64, f64), &'a Piece);

/// The part as a PNG about `size` pixels wide, seen from the front right, 35 degrees above.
pub fn png(pieces: &[Piece], size: u32) -> Vec<u8> {
    let (az, el) = (-35f64.to_radians(), 35f64.to_radians());
    let mut proj: Vec<Projected<'_>> = pieces
        .iter()
        .map(|p| {
            let (ua, va, da) = project(p.a, az, el);
            let (ub, vb, db) = project(p.b, az, el);
            (0.5 * (da + db), (ua, va), (ub, vb), p)
        })
        .collect();
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for (_, a, b, _) in &proj {
        for q in [a, b] {
            lo = [lo[0].min(q.0), lo[1].min(q.1)];
            hi = [hi[0].max(q.0), hi[1].max(q.1)];
        }
    }
    let margin = 1.0;
    let span = (hi[0] - lo[0] + 2.0 * margin)
        .max(hi[1] - lo[1] + 2.0 * margin)
        .max(1e-6);
    let scale = size as f64 / span;
    let (w, h) = (
        ((hi[0] - lo[0] + 2.0 * margin) * scale).ceil().max(1.0) as u32,
        ((hi[1] - lo[1] + 2.0 * margin) * scale).ceil().max(1.0) as u32,
    );
    let Some(mut pixmap) = Pixmap::new(w, h) else {
        return Vec::new();
    };
    pixmap.fill(Color::WHITE);
    // Far pieces first.
    proj.sort_by(|a, b| b.0.total_cmp(&a.0));
    let zmax = pieces.iter().map(|p| p.a[2]).fold(1e-9, f64::max);
    for (_, a, b, p) in &proj {
        let mut pb = PathBuilder::new();
        let px = |q: (f64, f64)| {
            (
                ((q.0 - lo[0] + margin) * scale) as f32,
                ((hi[1] - q.1 + margin) * scale) as f32,
            )
        };
        let (a, b) = (px(*a), px(*b));
        pb.move_to(a.0, a.1);
        pb.line_to(b.0, b.1);
        let Some(path) = pb.finish() else { continue };
        // Lower layers a little darker, so the layers read apart.
        let shade = 0.7 + 0.3 * (p.a[2] / zmax);
        let mut paint = Paint::default();
        paint.set_color_rgba8(
            (p.rgb[0] as f64 * shade) as u8,
            (p.rgb[1] as f64 * shade) as u8,
            (p.rgb[2] as f64 * shade) as u8,
            255,
        );
        paint.anti_alias = true;
        let stroke = Stroke {
            width: (p.width * scale * 0.9).max(1.0) as f32,
            line_cap: LineCap::Round,
            ..Stroke::default()
        };
        pixmap.stroke_path(&path, &paint, &stroke, Transform::identity(), None);
    }
    pixmap.encode_png().unwrap_or_default()
}

/// A self-contained HTML page showing `pieces` in 3D: drag to turn, wheel to zoom, a slider
/// to show the layers up to one.
pub fn html(title: &str, pieces: &[Piece], layer_height: f64) -> String {
    let mut palette: Vec<[u8; 3]> = Vec::new();
    let mut data = String::new();
    for p in pieces {
        let c = match palette.iter().position(|c| *c == p.rgb) {
            Some(c) => c,
            None => {
                palette.push(p.rgb);
                palette.len() - 1
            }
        };
        let _ = write!(
            data,
            "{:.3},{:.3},{:.3},{:.3},{:.3},{},",
            p.a[0], p.a[1], p.b[0], p.b[1], p.a[2], c
        );
    }
    data.pop();
    let colours = palette
        .iter()
        .map(|c| format!("\"#{:02x}{:02x}{:02x}\"", c[0], c[1], c[2]))
        .collect::<Vec<_>>()
        .join(",");
    let width = pieces.first().map_or(0.4, |p| p.width);
    let title = title.replace(['<', '>', '&'], "_");
    format!(
        r#"<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>{title}</title>
<style>body{{margin:0;font:14px sans-serif}}#bar{{position:fixed;top:0;left:0;right:0;padding:6px;background:#fffc}}canvas{{display:block}}</style>
</head><body>
<div id="bar">{title}: drag to turn, wheel to zoom; layers up to <input id="upto" type="range" min="0" value="0"> <span id="n"></span></div>
<canvas id="c"></canvas>
<script>
const D=[{data}];
const P=[{colours}];
const H={layer_height},W={width};
const c=document.getElementById('c'),g=c.getContext('2d'),up=document.getElementById('upto'),nl=document.getElementById('n');
let az=-0.6,el=0.6,zoom=1,drag=null;
const N=D.length/6;let top=0,lo=[1e9,1e9],hi=[-1e9,-1e9];
for(let i=0;i<N;i++){{const k=6*i;top=Math.max(top,D[k+4]);lo=[Math.min(lo[0],D[k],D[k+2]),Math.min(lo[1],D[k+1],D[k+3])];hi=[Math.max(hi[0],D[k],D[k+2]),Math.max(hi[1],D[k+1],D[k+3])];}}
const layers=Math.round(top/H+0.5);up.max=layers-1;up.value=layers-1;
const cx=(lo[0]+hi[0])/2,cy=(lo[1]+hi[1])/2,cz=top/2,span=Math.max(hi[0]-lo[0],hi[1]-lo[1],top)+2;
function pr(x,y,z){{x-=cx;y-=cy;z-=cz;const sa=Math.sin(az),ca=Math.cos(az),se=Math.sin(el),ce=Math.cos(el);
const X=x*ca-y*sa,Y=x*sa+y*ca;return [X,z*ce+Y*se,Y*ce-z*se];}}
function draw(){{c.width=innerWidth;c.height=innerHeight;const s=Math.min(c.width,c.height)/span*zoom;
g.fillStyle='#fff';g.fillRect(0,0,c.width,c.height);g.lineCap='round';
const upto=(+up.value+1)*H;nl.textContent=(+up.value+1)+' of '+layers;const L=[];
for(let i=0;i<N;i++){{const k=6*i;if(D[k+4]>upto)continue;const a=pr(D[k],D[k+1],D[k+4]),b=pr(D[k+2],D[k+3],D[k+4]);L.push([a[2]+b[2],a,b,D[k+5],D[k+4]]);}}
L.sort((p,q)=>q[0]-p[0]);g.lineWidth=Math.max(1,W*s*0.9);
for(const [_,a,b,ci,z] of L){{g.strokeStyle=P[ci];g.globalAlpha=0.75+0.25*z/top;g.beginPath();
g.moveTo(c.width/2+a[0]*s,c.height/2-a[1]*s);g.lineTo(c.width/2+b[0]*s,c.height/2-b[1]*s);g.stroke();}}g.globalAlpha=1;}}
c.onmousedown=e=>drag=[e.clientX,e.clientY];onmouseup=()=>drag=null;
onmousemove=e=>{{if(!drag)return;az+=(e.clientX-drag[0])*0.01;el=Math.max(-1.5,Math.min(1.5,el+(e.clientY-drag[1])*0.01));drag=[e.clientX,e.clientY];draw();}};
c.onwheel=e=>{{e.preventDefault();zoom*=e.deltaY<0?1.1:1/1.1;draw();}};
up.oninput=draw;onresize=draw;draw();
</script></body></html>
"#
    )
}
