use slod::cloth::{AdaptiveCloth, ClothBudget, FeedbackSettings};
use slod_experiments::net::NetConfig;
use std::time::Instant;
use treecut::{Cut, Hierarchy};
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let ms: f32 = std::env::args()
        .nth(1)
        .map_or(0.557, |a| a.parse().unwrap());
    let c = NetConfig::paper()?;
    let spec = c.grid();
    let h = std::sync::Arc::new(Hierarchy::grid(&spec)?);
    let mut cloth = AdaptiveCloth::new(h.clone(), Cut::finest(&h), c.body, spec.u.cross(spec.v))?;
    for (i, j) in [
        (0, 0),
        (c.size - 1, 0),
        (0, c.size - 1),
        (c.size - 1, c.size - 1),
    ] {
        cloth
            .body_mut()
            .pin_vertex(spec.vertex(i, j), spec.position(i, j))?;
    }
    cloth.set_feedback(Some(FeedbackSettings {
        budget: ClothBudget::TargetStepMs(ms),
        ..c.feedback
    }))?;
    let mut w = Vec::new();
    for step in 0..200 {
        let t = Instant::now();
        cloth.step(&c.view)?;
        w.push(t.elapsed().as_secs_f64() * 1e3);
        if w.len() == 5 {
            let m: f64 = w.iter().sum::<f64>() / 5.0;
            let s = cloth.stats();
            if step < 130 {
                println!(
                    "{:3} {:.3} nodes {} budget {} proj {} ref {} coa {} inflight {}",
                    step - 4,
                    m,
                    cloth.node_count(),
                    s.node_budget,
                    s.projected_nodes,
                    s.refines,
                    s.coarses,
                    cloth.body().transitions_in_flight()
                );
            }
            w.clear();
        }
    }
    Ok(())
}
