//! A deterministic mass-spring (XPBD) cloth and the TreeCut-SoftBody operations on it.
//!
//! * [`SoftBody`] — the plain solver: particles in structure-of-arrays form, distance links
//!   in graph-coloured batches, fixed time step with substeps and iterations, pins and
//!   kinematic anchors, gravity, external forces and damping. Same inputs, same bits.
//! * Builders: [`GridCloth`] (structural/shear/bend grid, and Bullet's triangle-mesh cloth via
//!   [`GridCloth::build_bullet`]) and [`MeshCloth`] (any triangle mesh).
//! * [`TreeCutSoftBody`] — simulation nodes are the active nodes of a `treecut::Cut`;
//!   refine/coarse run as blended two-half transitions that conserve mass and momentum.
//!
//! # Links: formulation
//! Links are XPBD distance constraints `C = |x_b − x_a| − rest` with compliance `α` (inverse
//! stiffness) and a blend weight `w ∈ [0, 1]` that multiplies the stiffness (`w = 0`: no effect).
//! Per substep of length `h`, with `α̃ = α/h²`, `W = w_a + w_b` and λ reset to 0:
//! `Δλ = (−w·C − α̃·λ)/(w·W + α̃)`, `x_a −= w_a Δλ n`, `x_b += w_b Δλ n`.
//!
//! **Resolution-independent material.** For cloth (a 2D sheet) a lattice of spacing `h` under a
//! strain `ε` across a width `W` has `W/h` links each stretched by `ε h`, so its sheet modulus is
//! the link stiffness `k` itself, independent of `h`: links of a self-similar lattice (a grid and
//! every level of its quadtree) get the *same* compliance whatever their rest length
//! ([`ComplianceScaling::Membrane`], the default). Masses add up the hierarchy, so areal density,
//! sag and wave speed are the same at every level. A 1D chain needs compliance per unit rest
//! length instead (`α = c·rest`: `n` links of `l/n` stretch like one of `l`,
//! [`ComplianceScaling::Chain`]); using that for cloth would make every coarser level four
//! times softer. Both are tested. With a fixed iteration count a very stiff material is limited by
//! convergence, which is faster on coarse meshes; a material whose compliance is not negligible
//! behaves the same at every resolution.
//!
//! # Links: colouring, deletion, determinism
//! A link goes into the first colour batch where neither of its particles has a link yet (first
//! fit on a 64-bit mask per particle: O(1), deterministic in insertion order; a particle with 64
//! colours used sends further links to an ordered overflow batch). Batches run in colour order;
//! inside one, no two links share a particle, so each link reads and writes only its own two
//! particles: order inside a batch does not matter, a block of links is computed at once in vector
//! lanes (16 with AVX-512, 8 with AVX2, 4 with SSE/NEON, chosen at run time: [`KernelPath`]; all
//! paths give the same bits, as none uses FMA), and removing a link is an O(1) swap-remove that leaves every other link computing exactly the
//! same bits (a deleted link and a link of weight 0 are indistinguishable; tested bit for bit).
//! Links are stored in blocks of sixteen (all fields of sixteen links in 384 contiguous bytes). No
//! hash maps, no time-dependent state, and threads change no bit (below): the same calls give
//! bit-identical results.
//!
//! # Threads
//! One large body can use several threads: a colour batch of at least
//! [`SolverSettings::parallel_min_links`] links (default
//! [`SolverSettings::DEFAULT_PARALLEL_MIN_LINKS`]) is cut into runs of whole blocks that the
//! threads of the *caller's* rayon pool (`rayon::current_num_threads()`; a host chooses by
//! installing a pool) solve at once, and then the per-particle loops (prediction, velocity
//! update, multiplier reset) are split as well. Since a batch's links share no particle, each
//! link computes the same bits whichever thread solves it and when: **results are
//! bit-identical for any number of threads** (tested on a grid and on a TreeCut body through
//! refines and coarses, at 1 and at the default 32 substeps). What stays on the calling thread:
//! smaller batches, the ordered overflow batch, group links, anchors and contacts. All of it is
//! shared out by one small team per step (the caller and spinning helpers, `team.rs`) that
//! lives for all the substeps: the caller publishes each split batch and each particle loop as
//! a *phase* of the team and runs the sequential parts between phases, at a cost of a fraction
//! of a microsecond per phase, which a step pays about `substeps × (iterations × colours + 2)`
//! times (`rayon::join` per batch gained nothing: rayon's idle worker falls asleep between
//! batches; a team and rayon particle loops per substep held a 129² cloth at the default
//! 32 substeps to 1.06–1.15× on two threads). Hence the default threshold of 4096
//! links per batch, about 8 µs of work on one core: split in two it leaves the synchronisation
//! under a tenth, which 129² Bullet-style cloths (about 8,300 links per colour) reach and 65²
//! ones (2,100) do not. Splitting
//! pays only when the pool's threads have cores to themselves: on an oversubscribed machine a
//! helper that loses its core mid-run makes the caller wait (use a one-thread pool or
//! `parallel_min_links = 0` there). The same goes for a host that already steps several bodies
//! at once on its pool: a body's helpers spin on pool threads for the whole of its step (a
//! helper that never gets a thread costs nothing: the caller then solves every run itself, and
//! cannot deadlock whatever the pool is doing). A body whose batches are all smaller never asks rayon for
//! anything, so small cloths do not even start the global pool.
//!
//! # TreeCut-SoftBody
//! Every particle stands for one hierarchy node ([`TreeCutSoftBody::particle_nodes`]). Links are
//! the *induced adjacency*: two simulated nodes are linked iff some finest mesh edge joins them,
//! rest length = distance of their hierarchy rest positions; on a grid quadtree that is the
//! structural and shear links at every level, and the finest cut is exactly the plain grid cloth (tested bit for
//! bit). Each particle has an incident-link list (with the particle at the other end), so no
//! operation searches all links.
//!
//! A parent and its children are never simulated at once. During a transition the parent is
//! *virtual*: the mass-weighted centroid of its real children, reached by *group links* solved in a
//! small sequential pass after the batches with the generalised XPBD gradient (`n` for the single
//! end, `−(m_i/M) n` for child `i`), which conserves momentum like a plain link.
//! * [`TreeCutSoftBody::begin_refine`]: children replace the parent (hierarchy masses; positions =
//!   parent position + `R·(rest offset)` with `R` the shape-matching rotation of the parent's
//!   neighbourhood, shifted so the centroid is exactly the parent's position; the parent's
//!   velocity), the parent's links become group links that fade out, child–neighbour links fade in,
//!   sibling links start at full weight.
//! * [`TreeCutSoftBody::begin_coarse`]: the children stay real; group links from their centroid to
//!   each external neighbour fade in while the children's external links fade out.
//! * After `blend_steps` steps [`TreeCutSoftBody::step`] ends them: refine drops the group links;
//!   coarse merges the children into one particle (total mass, centroid, mass-weighted mean
//!   velocity) whose group links become plain links.
//!
//! Nodes in transition and all their neighbours are locked in the cut until the end, so no
//! transition starts next to one in flight. The children of a refine collide at once by default;
//! with [`TransitionCollision::AtEnd`] they join collision when their refine ends, as the paper
//! does (section 3.4), which measured deep penetration during the blend.
//! Particle storage is dense (swap-removal), so after many operations neighbours sit far apart
//! in memory; once enough particles have come and gone, [`TreeCutSoftBody::step`] puts them
//! back in spatial order and re-colours the links ([`TreeCutSoftBody::renumber_particles`]: a
//! permutation of the state, contact state included; later results differ only by the new
//! solve order).
//!
//! # Colliders and wind
//! [`collide`]: planes, spheres, capsules and oriented boxes with thickness and friction, static
//! or moved by the host, projected once per substep after the links, behind a per-step broad
//! phase. A TreeCut node's collision radius covers its children. [`wind`]: a gusty field with
//! per-area drag and lift; a TreeCut node carries the area of the finest triangles it covers, so
//! the total force does not depend on the cut.
//! Pins belong to finest vertices; the node covering a pinned vertex is pinned where that vertex
//! sits on its anchor (see [`TreeCutSoftBody::pin_vertex`]). [`TreeCutSoftBody::reconstruct`] gives
//! every finest vertex a position (in the default [`ReconstructionMode::Mls`], a quadratic
//! least-squares fit to its node and the node's neighbours; or carried by the node's
//! shape-matching rotation, alone or blended with the neighbours'; outside the colliders in
//! every mode), and
//! [`reconstruction_error`] compares it with a full-resolution reference.
// The crate's `unsafe` is the call into the run-time selected AVX2/AVX-512 kernels, in
// `kernel/x86.rs`, and their particle accesses without a bounds check each (the link store
// checks a batch's indices once per change of its links: `links.rs`, `kernel/mod.rs`); the
// `Send`/`Sync` of the particle view that lets threads solve disjoint links of one colour batch
// (`kernel/shared.rs`), and its creation in `body.rs` (each argued where it is); everything else
// is safe code.
#![deny(unsafe_code)]
#![warn(missing_docs)]

mod body;
mod builders;
pub mod collide;
mod error;
mod group;
mod ids;
mod kernel;
mod links;
mod settings;
pub mod shape;
mod tc;
mod team;
pub mod wind;

#[cfg(test)]
mod body_tests;

pub use body::SoftBody;
pub use builders::{GridCloth, MeshCloth, VertexMasses, distance_two_pairs};
pub use collide::{ColliderDesc, ColliderId, Colliders, Shape, Transform};
pub use error::SoftBodyError;
pub use ids::{LinkId, ParticleId};
pub use kernel::KernelPath;
pub use links::LinkInfo;
pub use settings::{ComplianceScaling, Material, SolverSettings};
pub use tc::{
    DrawLink, ReconstructionError, ReconstructionMode, TransitionCollision, TransitionInfo,
    TransitionKind, TreeCutError, TreeCutSettings, TreeCutSoftBody, reconstruction_error,
};
/// The `treecut` crate this one builds on, re-exported so hosts use the same version.
pub use treecut;
pub use wind::{Wind, WindError, WindField, grid_triangles};
