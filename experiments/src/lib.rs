//! The offline side of slod: the papers' experiments, their baselines and the helpers that
//! report them. Nothing here is needed to run slod in an engine; the demo, the tests and the
//! benches use it to measure the runtime crates.
//!
//! - [`net`] — the simulation paper's swinging net (`simulation-lod-treecut-softbody-bswdf.txt`,
//!   section 6): a full-resolution reference, feedback runs and static cuts, measured.
//! - [`engine`] — the engine scenes (issue 14): colliders, wind, a cape worn by a walking
//!   character, at full resolution and at 30% of the nodes.
//! - [`perception`] — every strategy on every scene family (the net, a close-up of a large
//!   cloth, off-screen, dolly and orbit, a flag in wind, a curtain on a moving rail, an irregular
//!   mesh, a 129² net) at the same node count, measured on screen against the reference.
//! - [`crowd`] — the thesis' crowd test (`animation-lod-bone-priority-thesis.txt`, chapter 13).
//! - [`rig`] — rigs built for the experiments from real ones ([`rig::grown_to`]).
//! - [`screen`] — what a viewer sees: on-screen error in pixels through a view, and pops.
//! - [`world`] — one frame budget for a whole world (issue 15): 16 cloths and a 1,000-character
//!   crowd along a street, a flying camera, 4 ms per frame, against a full-detail reference.
//! - [`overlap`] — the TreeCut evaluation off its step's critical path (issue 15): the net's
//!   evaluating steps with the evaluation before the solver and overlapped with it.
//! - [`rng`] — the one seeded generator; [`table`] — aligned plain-text tables.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod ablation;
pub mod crowd;
pub mod crowd_large;
pub mod engine;
pub mod net;
pub mod overlap;
pub mod perception;
pub mod rig;
pub mod rng;
pub mod screen;
pub mod table;
pub mod world;

/// Median of `v` (sorted in place; the upper of the two middle values for an even count); 0
/// when empty. The experiments' timing figures are medians of repeated runs, and so are the
/// demo's.
pub fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}
