//! `mcls.json`: the plan's MCLs, bisectors and branch points, as the user's tools read them.

use hollowpath::{Plan, Target};
use serde_json::{json, Value};

fn pt(p: hollowpath::geometry::Point) -> Value {
    json!([p.x, p.y])
}

/// The document `{"mcls": [{"from", "to", "points"}], "bisectors", "branch_points", "stats"}`;
/// `to` is a hole index or `"wall"`, a matched pair is one MCL (feature, `p*`, feature).
pub fn mcls_json(plan: &Plan) -> Value {
    let mcls: Vec<Value> = plan
        .mcls
        .iter()
        .map(|m| {
            json!({
                "from": m.from,
                "to": match m.to { Target::Wall => json!("wall"), Target::Hole(j) => json!(j) },
                "points": plan.points(m).iter().map(|&p| pt(p)).collect::<Vec<_>>(),
            })
        })
        .collect();
    let bisectors: Vec<Value> = plan
        .bisectors()
        .iter()
        .map(|b| Value::Array(b.points.iter().map(|&p| pt(p)).collect()))
        .collect();
    let s = &plan.stats;
    json!({
        "mcls": mcls,
        "bisectors": bisectors,
        "branch_points": plan.cells.branch_points.iter().map(|&p| pt(p)).collect::<Vec<_>>(),
        "digest": format!("{:016x}", plan.digest()),
        "stats": {
            "grid_nodes": s.grid_nodes, "grid_h": s.grid_h, "boundary_nodes": s.boundary_nodes, "sweeps": s.sweeps,
            "residual": s.residual, "traced": s.traced, "failed_traces": s.failed_traces,
            "dropped_crossing": s.dropped_crossing, "dropped_crowded": s.dropped_crowded,
            "off_bisector": s.off_bisector,
            "matched_pairs": s.matched_pairs, "removed_unmatched": s.removed_unmatched,
            "relax_moves": s.relax_moves, "thinned": s.thinned, "removed_invalid": s.removed_invalid,
        },
    })
}
