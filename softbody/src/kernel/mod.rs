//! The XPBD distance-link kernel: one sweep over a colour batch of links, on the widest
//! vector unit the CPU has; and the substep's per-particle velocity update and prediction
//! ([`update_and_predict`]), two particles per register where AVX2 is there.
//!
//! Based on: M. Macklin, M. Müller, N. Chentanez, "XPBD: Position-Based Simulation of
//! Compliant Constrained Dynamics", Motion in Games 2016, section 3 (the compliant
//! constraint update with its Lagrange multiplier); substeps as in Macklin et al., "Small Steps
//! in Physics Simulation", SCA 2019.
//!
//! Per link (`w` = blend weight, `α̃ = α/h²`, `W = w_a + w_b` inverse masses):
//!
//! ```text
//! d = x_b - x_a,  len = max(|d|, floor),  C = len - rest
//! Δλ = (-w·C - α̃·λ) / (w·W + α̃)      (XPBD with stiffness scaled by w: α̃/w, multiplied through by w)
//! λ += Δλ,  x_a -= w_a·Δλ·d/len,  x_b += w_b·Δλ·d/len
//! ```
//!
//! computed with a single division and no negation: `s = -Δλ/len = (w·C + α̃·λ) / ((w·W + α̃)·len)`,
//! then `λ -= s·len`, `x_a += (w_a·s)·d`, `x_b -= (w_b·s)·d` (flipping the sign of `s` is exact, so
//! this is the update above, bit for bit). The divider is the slowest unit on the chain.
//!
//! A weight of 0 gives `Δλ = -α̃·λ/α̃ = -λ = 0` (λ starts each substep at 0): no effect,
//! without a branch. The denominator and the length have small floors so that links
//! between two pinned particles, or of zero length, stay finite instead of dividing by 0.
//!
//! # Storage and paths
//! Links are stored in blocks of [`LANES`] = 16 ([`Block`], structure of arrays inside a block,
//! 384 contiguous bytes). Within a colour batch no two links share a particle, so the links are
//! independent: the result does not depend on their order, and a whole block is computed at once
//! in vector lanes: gather the particles (one 16-byte load each: `xyz` and the inverse mass),
//! transpose four registers in their 128-bit lanes, compute lane-wise, transpose back, scatter.
//! [`KernelPath`] names the ways a block can be computed: one link at a time ([`KernelPath::Scalar`],
//! the reference), four at a time with `glam` (SSE2 on x86-64, NEON on aarch64), and on x86-64
//! eight (AVX2) or sixteen (AVX-512F) at a time, chosen at run time from what the CPU has
//! ([`KernelPath::detect`]). AVX2 gathers both halves of a block before solving either, so the
//! core has two independent dependency chains to overlap.
//!
//! A batch's last block is usually partial (a batch's length is rarely a multiple of 16, and a
//! cloth has eight or more colours). It is solved in vector lanes too (AVX2 eight at a time on
//! both x86 paths, `glam` four at a time on [`KernelPath::Lanes4`]): the lanes past the batch's
//! length gather the first link's particles instead of whatever stale indices they hold, and
//! only the real links' results are written back (test
//! `partial_blocks_match_scalar_and_leave_spare_lanes_alone`). Before, those links went one at a
//! time, which on small cloths was a tenth of the step: per default step (32 × 1, one thread's
//! CPU time, medians of eight runs of the two binaries interleaved) 12² 38.0 → 33.4 µs, 17²
//! 70.2 → 64.0, 24² 132.7 → 125.7, 33² 240.7 → 236.9, 65² 954 → 939.
//!
//! Why `std::arch` and not a SIMD crate (`pulp`, `wide`, `multiversion`): the kernel needs two
//! run-time paths and about fifteen value intrinsics (arithmetic, square root, in-lane shuffles,
//! 128-bit inserts and extracts), which safe `std::arch` gives since Rust 1.87 (1.89 for
//! AVX-512) without a dependency; particles cross into registers through `glam`'s safe
//! `Vec4 <-> __m128` conversions. The `unsafe` is the call into a `#[target_feature]` function
//! after the run-time feature check (in `x86.rs`), which is exactly what `multiversion` or
//! `pulp` would generate inside our crate or theirs, and the particle accesses of the vector
//! paths, which skip the bounds check per access (about a tenth of the kernel's instructions,
//! 8–10% of the Bullet-style 65² step): a batch's indices are checked by the link store once
//! per change of its links ([`solve_batch_unchecked`]'s contract; debug builds check them at
//! every sweep as well).
//!
//! # One sweep per substep
//! The default solver takes many substeps of one iteration each (Macklin et al. 2019). Then
//! every multiplier is 0 when its link is solved and no later sweep of the substep reads it:
//! [`solve_batch_unchecked`]'s `fresh` sweep neither loads nor stores them (and the body skips the reset
//! pass): the same bits as resetting and sweeping (test
//! `fresh_sweep_is_a_sweep_from_zero_multipliers`), about 9% less time per default step on the
//! 65² net (`SoftBody::step`, old and new binaries interleaved in one run: 1.06–1.14 ms →
//! 0.98–1.07 ms, together with the fused velocity update and prediction of `SoftBody::step`).
//!
//! # What bounds the AVX2 path (measured)
//! On the Bullet-topology 65² cloth (20 iterations, one thread; a 2-vCPU Zen 4 VM, about 3.3
//! GHz) the step runs at about 1.9 ns, some 6 cycles, per link-iteration, 98% of it in the block
//! kernel; a block of 16 links is about 380 instructions. Timer sampling piles a quarter of the
//! samples on the instructions just after `vsqrtps` and `vdivps`: retirement waits on the
//! square root → division chain of each half-block, and the reorder window holds about one
//! block, so two chains (the two halves, gathered before either is solved) overlap and no more.
//! Variants tried, each beside the kernel above in one run of interleaved binaries (medians of
//! 5–8, ms per step): the halves solved one after the other, 1.97 against 1.40 (one chain);
//! the next block's gathers issued before this block's scatters, 1.37–1.51 against 1.38–1.60
//! (no gain: the register file spills what the window would have overlapped); solving in the
//! particle layout (transposing only `|d|²` and `w_a + w_b`, broadcasting `s` back: a quarter
//! fewer shuffles), 1.70 (spills again); byte offsets stored instead of indices (no shift per
//! access), 1–2% (not kept); the same kernel compiled with AVX-512VL's 32 registers, 2.8 ns;
//! AVX-512 in the particle layout, 2.5 against 2.4 ns. As measurements only (wrong results):
//! without the transposes 10% faster, without the division 3%. Blocks whose links join
//! consecutive particles, loaded and stored as pairs with no index, insert or extract (a
//! synthetic two-row layout, 32,768 links, the same bits): 1.72–1.77 against 1.92–1.98 ns, a
//! tenth. The transposes and the square root → division chain stay; what would reach the ~1 ns
//! of a plain sweep over a regular grid is particles in a structure-of-arrays layout, so that
//! such blocks need no transpose either — a change of the body's storage, not of this kernel.
//!
//! # Determinism across paths
//! Every path performs the same IEEE-754 single-precision operations in the same order on every
//! lane: no fused multiply-add (it would round once instead of twice), no reciprocal estimates,
//! correctly rounded `sqrt` and division. So **all paths give bit-identical results** on every
//! machine, and a link gives the same bits wherever it sits in its batch (lanes or the scalar
//! tail) — which is what makes swap-removal of other links harmless. Tests check each
//! supported path against the scalar one bit for bit (tolerance zero).

use glam::{Mat4, Vec4};

mod shared;
#[cfg(target_arch = "x86_64")]
mod x86;

pub(crate) use shared::SharedParticles;

/// Where a kernel reads and writes particles: a plain slice (one thread owns them all), or a
/// [`SharedParticles`] view through which several threads solve disjoint parts of one colour
/// batch. Monomorphised, so the slice path compiles to what it did before the trait existed.
pub(crate) trait Particles {
    /// Particle `i` (panics if out of range).
    fn get(&self, i: usize) -> Vec4;
    /// Overwrites particle `i` (panics if out of range).
    fn set(&mut self, i: usize, v: Vec4);
    /// The number of particles: every index below it is in range.
    fn count(&self) -> usize;
    /// Particle `i` without a bounds check, for the vector kernels, whose callers have checked
    /// every index of the batch against [`Particles::count`] (the link store once per change
    /// of its links: see [`solve_batch_unchecked`]).
    ///
    /// # Safety
    /// `i < self.count()`.
    #[allow(unsafe_code)]
    unsafe fn get_unchecked(&self, i: usize) -> Vec4;
    /// Overwrites particle `i` without a bounds check (see [`Particles::get_unchecked`]).
    ///
    /// # Safety
    /// `i < self.count()`.
    #[allow(unsafe_code)]
    unsafe fn set_unchecked(&mut self, i: usize, v: Vec4);
}

#[allow(unsafe_code)]
impl Particles for [Vec4] {
    #[inline(always)]
    fn get(&self, i: usize) -> Vec4 {
        self[i]
    }
    #[inline(always)]
    fn set(&mut self, i: usize, v: Vec4) {
        self[i] = v;
    }
    #[inline(always)]
    fn count(&self) -> usize {
        self.len()
    }
    #[inline(always)]
    unsafe fn get_unchecked(&self, i: usize) -> Vec4 {
        // SAFETY: the caller guarantees `i < self.len()`.
        unsafe { *<[Vec4]>::get_unchecked(self, i) }
    }
    #[inline(always)]
    unsafe fn set_unchecked(&mut self, i: usize, v: Vec4) {
        // SAFETY: the caller guarantees `i < self.len()`.
        unsafe { *<[Vec4]>::get_unchecked_mut(self, i) = v };
    }
}

/// Floor for the constraint denominator `w·W + α̃` (two pinned ends with zero compliance).
pub(crate) const DENOM_FLOOR: f32 = 1e-12;
/// Floor for a link's current length (coincident ends).
pub(crate) const LENGTH_FLOOR: f32 = 1e-12;
/// Links per block: one AVX-512 register of `f32`.
pub(crate) const LANES: usize = 16;

/// How the link kernel computes a block of links. All paths give bit-identical results (see
/// the module docs); they differ only in speed. [`KernelPath::detect`] picks the fastest one the
/// CPU supports, and a body uses it unless told otherwise
/// ([`crate::SoftBody::set_kernel_path`], for tests and benchmarks).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum KernelPath {
    /// One link at a time: the reference arithmetic.
    Scalar,
    /// Four links at a time in 128-bit registers through `glam` (SSE2 on x86-64, NEON on
    /// aarch64, plain code elsewhere).
    Lanes4,
    /// Eight links at a time in 256-bit AVX2 registers (x86-64 only).
    Avx2,
    /// Sixteen links at a time in 512-bit AVX-512F registers (x86-64 only).
    Avx512,
}

impl KernelPath {
    /// Every path, narrowest first.
    pub const ALL: [KernelPath; 4] = [Self::Scalar, Self::Lanes4, Self::Avx2, Self::Avx512];

    /// Whether this CPU can run the path (checked at run time).
    pub fn is_supported(self) -> bool {
        match self {
            Self::Scalar | Self::Lanes4 => true,
            #[cfg(target_arch = "x86_64")]
            Self::Avx2 => std::arch::is_x86_feature_detected!("avx2"),
            #[cfg(target_arch = "x86_64")]
            Self::Avx512 => std::arch::is_x86_feature_detected!("avx512f"),
            #[cfg(not(target_arch = "x86_64"))]
            Self::Avx2 | Self::Avx512 => false,
        }
    }

    /// The fastest supported path: AVX2, else AVX-512F, else four lanes.
    ///
    /// AVX2 comes first because it measured faster than AVX-512F on the machine this was
    /// tuned on (a Sapphire Rapids Xeon VM: about 1.9 against 2.9 CPU ns per link-iteration in
    /// the `step` bench; the VM has no hardware counters to say why — fewer shuffle ports and
    /// lower clocks for 512-bit work are the usual suspects).
    pub fn detect() -> Self {
        [Self::Avx2, Self::Avx512]
            .into_iter()
            .find(|p| p.is_supported())
            .unwrap_or(Self::Lanes4)
    }

    /// The supported paths, narrowest first.
    pub fn supported() -> impl Iterator<Item = KernelPath> {
        Self::ALL.into_iter().filter(|p| p.is_supported())
    }

    /// A short lowercase name (`scalar`, `lanes4`, `avx2`, `avx512`), for reports and benches.
    pub fn name(self) -> &'static str {
        match self {
            Self::Scalar => "scalar",
            Self::Lanes4 => "lanes4",
            Self::Avx2 => "avx2",
            Self::Avx512 => "avx512",
        }
    }
}

/// Sixteen links, one per lane.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(64))]
pub(crate) struct Block {
    pub(crate) a: [u32; LANES],
    pub(crate) b: [u32; LANES],
    pub(crate) rest: [f32; LANES],
    pub(crate) compliance: [f32; LANES],
    pub(crate) weight: [f32; LANES],
    pub(crate) lambda: [f32; LANES],
}

impl Block {
    /// Everything about the link in lane `k`.
    #[inline]
    pub(crate) fn lane(&self, k: usize) -> Lane {
        Lane {
            a: self.a[k],
            b: self.b[k],
            rest: self.rest[k],
            compliance: self.compliance[k],
            weight: self.weight[k],
            lambda: self.lambda[k],
        }
    }
    /// Puts a link into lane `k`.
    #[inline]
    pub(crate) fn set_lane(&mut self, k: usize, l: Lane) {
        self.a[k] = l.a;
        self.b[k] = l.b;
        self.rest[k] = l.rest;
        self.compliance[k] = l.compliance;
        self.weight[k] = l.weight;
        self.lambda[k] = l.lambda;
    }
}

/// One lane of a [`Block`] (moved between lanes without copying whole blocks).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Lane {
    a: u32,
    b: u32,
    rest: f32,
    compliance: f32,
    weight: f32,
    lambda: f32,
}

/// Solves lane `k` of a block alone; the reference arithmetic that every path reproduces.
/// `FRESH`: the link's multiplier is known to be 0 (the first sweep of a substep) and no later
/// sweep of the substep reads it, so it is neither loaded nor stored (see [`solve_batch_unchecked`]).
#[inline(always)]
pub(crate) fn solve_lane<P: Particles + ?Sized, const FRESH: bool>(
    p: &mut P,
    blk: &mut Block,
    k: usize,
    inv_h2: f32,
) {
    let (ia, ib) = (blk.a[k] as usize, blk.b[k] as usize);
    let pa = p.get(ia);
    let pb = p.get(ib);
    let (dx, dy, dz) = (pb.x - pa.x, pb.y - pa.y, pb.z - pa.z);
    let len = (dx * dx + dy * dy + dz * dz).sqrt().max(LENGTH_FLOOR);
    let weight = blk.weight[k];
    let lambda = if FRESH { 0.0 } else { blk.lambda[k] };
    let at = blk.compliance[k] * inv_h2;
    let c = len - blk.rest[k];
    let den = (weight * (pa.w + pb.w) + at).max(DENOM_FLOOR);
    // One division: s = -Δλ/len.
    let s = (weight * c + at * lambda) / (den * len);
    if !FRESH {
        blk.lambda[k] = lambda - s * len;
    }
    let (sa, sb) = (pa.w * s, pb.w * s);
    // The fourth lane (the inverse mass) is kept as it is.
    p.set(
        ia,
        Vec4::new(pa.x + dx * sa, pa.y + dy * sa, pa.z + dz * sa, pa.w),
    );
    p.set(
        ib,
        Vec4::new(pb.x - dx * sb, pb.y - dy * sb, pb.z - dz * sb, pb.w),
    );
}

/// Lane-wise square root (SSE `sqrtps` once LLVM merges the lanes; IEEE-exact either way).
#[inline(always)]
fn sqrt4(v: Vec4) -> Vec4 {
    Vec4::new(v.x.sqrt(), v.y.sqrt(), v.z.sqrt(), v.w.sqrt())
}

/// Lanes `o..o + 4` of a block, in 128-bit registers: gather, transpose, compute, scatter.
#[inline(always)]
fn solve_quad<P: Particles + ?Sized, const FRESH: bool>(
    p: &mut P,
    blk: &mut Block,
    o: usize,
    inv_h2: f32,
) {
    let ia = [0, 1, 2, 3].map(|k| blk.a[o + k] as usize);
    let ib = [0, 1, 2, 3].map(|k| blk.b[o + k] as usize);
    // Columns are particles; after the transpose the columns are x, y, z, w of four particles.
    let ta = Mat4::from_cols(p.get(ia[0]), p.get(ia[1]), p.get(ia[2]), p.get(ia[3])).transpose();
    let tb = Mat4::from_cols(p.get(ib[0]), p.get(ib[1]), p.get(ib[2]), p.get(ib[3])).transpose();
    let (ax, ay, az, aw) = (ta.x_axis, ta.y_axis, ta.z_axis, ta.w_axis);
    let (bx, by, bz, bw) = (tb.x_axis, tb.y_axis, tb.z_axis, tb.w_axis);
    let lane = |v: &[f32; LANES]| Vec4::new(v[o], v[o + 1], v[o + 2], v[o + 3]);
    let (dx, dy, dz) = (bx - ax, by - ay, bz - az);
    let len = sqrt4(dx * dx + dy * dy + dz * dz).max(Vec4::splat(LENGTH_FLOOR));
    let at = lane(&blk.compliance) * inv_h2;
    let wk = lane(&blk.weight);
    let lk = if FRESH { Vec4::ZERO } else { lane(&blk.lambda) };
    let cc = len - lane(&blk.rest);
    let den = (wk * (aw + bw) + at).max(Vec4::splat(DENOM_FLOOR));
    let s = (wk * cc + at * lk) / (den * len);
    if !FRESH {
        blk.lambda[o..o + 4].copy_from_slice(&(lk - s * len).to_array());
    }
    let (sa, sb) = (aw * s, bw * s);
    let na = Mat4::from_cols(ax + dx * sa, ay + dy * sa, az + dz * sa, aw).transpose();
    let nb = Mat4::from_cols(bx - dx * sb, by - dy * sb, bz - dz * sb, bw).transpose();
    for k in 0..4 {
        p.set(ia[k], na.col(k));
        p.set(ib[k], nb.col(k));
    }
}

/// [`solve_batch_unchecked`] after checking every particle index of the batch against `p`
/// (one pass over the indices): the kernel tests' entry point. The link store checks its
/// indices once per change of its links instead, not per sweep.
#[cfg(test)]
#[allow(unsafe_code)]
pub(crate) fn solve_batch<P: Particles + ?Sized>(
    path: KernelPath,
    p: &mut P,
    blocks: &mut [Block],
    len: usize,
    inv_h2: f32,
    fresh: bool,
) {
    assert!(
        indices_below(blocks, len, p.count()),
        "link kernel: a particle index is out of range"
    );
    // SAFETY: every index of the first `len` links was just checked below `p.count()`.
    unsafe { solve_batch_unchecked(path, p, blocks, len, inv_h2, fresh) }
}

/// One sweep over a batch of `len` links (in `blocks`) that share no particle. `fresh`: every
/// multiplier is 0 (the substep's first sweep) and none is read again before the next reset
/// (its only sweep: one iteration per substep, the default), so the multipliers are neither
/// loaded nor stored — the same bits, less memory traffic, and no reset pass needed.
///
/// The vector paths gather and scatter particles without a bounds check each (there were 32
/// per block of 16 links, about a tenth of the kernel's instructions; the Bullet-style 65²
/// cloth's step is 8–10% faster without them), hence the contract.
///
/// # Safety
/// Every particle index (`a` and `b`) of the first `len` links of `blocks` is below
/// `p.count()` (see [`indices_below`]).
#[allow(unsafe_code)]
pub(crate) unsafe fn solve_batch_unchecked<P: Particles + ?Sized>(
    path: KernelPath,
    p: &mut P,
    blocks: &mut [Block],
    len: usize,
    inv_h2: f32,
    fresh: bool,
) {
    debug_assert!(indices_below(blocks, len, p.count()));
    // SAFETY: this function's contract is `batch`'s.
    unsafe {
        if fresh {
            batch::<P, true>(path, p, blocks, len, inv_h2);
        } else {
            batch::<P, false>(path, p, blocks, len, inv_h2);
        }
    }
}

/// Whether both particle indices of each of the first `len` links of `blocks` are below
/// `count`: what [`solve_batch_unchecked`] needs. One vector maximum per block.
pub(crate) fn indices_below(blocks: &[Block], len: usize, count: usize) -> bool {
    let full = len / LANES;
    let below = |a: &[u32], b: &[u32]| {
        let max = a.iter().zip(b).fold(0u32, |m, (&i, &j)| m.max(i).max(j));
        (max as usize) < count
    };
    blocks.len() * LANES >= len
        && blocks[..full].iter().all(|blk| below(&blk.a, &blk.b))
        && (len == full * LANES || {
            let n = len - full * LANES;
            below(&blocks[full].a[..n], &blocks[full].b[..n])
        })
}

/// # Safety
/// As [`solve_batch_unchecked`].
#[allow(unsafe_code)]
unsafe fn batch<P: Particles + ?Sized, const FRESH: bool>(
    path: KernelPath,
    p: &mut P,
    blocks: &mut [Block],
    len: usize,
    inv_h2: f32,
) {
    let full = len / LANES;
    let done = match path {
        KernelPath::Scalar => 0,
        KernelPath::Lanes4 => {
            for blk in &mut blocks[..full] {
                for o in (0..LANES).step_by(4) {
                    solve_quad::<P, FRESH>(p, blk, o, inv_h2);
                }
            }
            full
        }
        #[cfg(target_arch = "x86_64")]
        KernelPath::Avx2 => {
            // SAFETY: the full blocks' links are among the first `len`, whose indices the
            // caller guarantees below `p.count()`.
            unsafe { x86::blocks_avx2::<P, FRESH>(p, &mut blocks[..full], inv_h2) }
        }
        #[cfg(target_arch = "x86_64")]
        KernelPath::Avx512 => {
            // SAFETY: as for `Avx2` just above.
            unsafe { x86::blocks_avx512::<P, FRESH>(p, &mut blocks[..full], inv_h2) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        KernelPath::Avx2 | KernelPath::Avx512 => 0,
    };
    // The last, partial block (a batch's length is rarely a multiple of 16: on the perception
    // net at 30% of its nodes the partial blocks held 2–3% of the links and, lane by lane, about
    // a tenth of the kernel's time) in vector lanes where the path has them, then whatever is
    // left (everything when the vector path could not run) lane by lane: the same bits.
    let mut from = done * LANES;
    if done == full && len > from {
        let rest = len - from;
        let solved = match path {
            KernelPath::Scalar => 0,
            KernelPath::Lanes4 => {
                let quads = rest / 4 * 4;
                for o in (0..quads).step_by(4) {
                    solve_quad::<P, FRESH>(p, &mut blocks[full], o, inv_h2);
                }
                quads
            }
            #[cfg(target_arch = "x86_64")]
            KernelPath::Avx2 | KernelPath::Avx512 => {
                // SAFETY: the block's first `rest` links are among the first `len`, whose
                // indices the caller guarantees below `p.count()`.
                if unsafe { x86::partial_avx2::<P, FRESH>(p, &mut blocks[full], rest, inv_h2) } {
                    rest
                } else {
                    0
                }
            }
            #[cfg(not(target_arch = "x86_64"))]
            KernelPath::Avx2 | KernelPath::Avx512 => 0,
        };
        from += solved;
    }
    for i in from..len {
        solve_lane::<P, FRESH>(p, &mut blocks[i / LANES], i % LANES, inv_h2);
    }
}

/// One sweep over links that may share particles: strictly in order, one lane at a time
/// (`fresh` as in [`solve_batch_unchecked`]).
pub(crate) fn solve_ordered<P: Particles + ?Sized>(
    p: &mut P,
    blocks: &mut [Block],
    len: usize,
    inv_h2: f32,
    fresh: bool,
) {
    for i in 0..len {
        let (blk, k) = (&mut blocks[i / LANES], i % LANES);
        if fresh {
            solve_lane::<P, true>(p, blk, k, inv_h2);
        } else {
            solve_lane::<P, false>(p, blk, k, inv_h2);
        }
    }
}

#[cfg(test)]
mod tests;

/// The per-substep constants of the prediction: substep `h`, its damping factor, gravity (with
/// 0 in `w`) and `1 / h`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MotionConsts {
    pub(crate) h: f32,
    pub(crate) damp: f32,
    pub(crate) g: Vec4,
    pub(crate) inv_h: f32,
}

/// The particle arrays one substep's velocity update and prediction run over (equal lengths).
pub(crate) struct MotionSlices<'a> {
    pub(crate) x: &'a mut [Vec4],
    pub(crate) v: &'a mut [Vec4],
    pub(crate) f: &'a [Vec4],
    pub(crate) prev: &'a mut [Vec4],
}

/// One particle's predicted position and velocity from its position `x` (inverse mass in
/// `w`), velocity `v` and external force `f`: pinned particles (`w = 0`) keep still, damping
/// acts on the carried velocity only (so it does not weaken static loads).
#[inline(always)]
pub(crate) fn predict_particle(m: &MotionConsts, x: Vec4, v: Vec4, f: Vec4) -> (Vec4, Vec4) {
    let free = if x.w > 0.0 { 1.0 } else { 0.0 };
    let vel = (v * m.damp + (m.g + f * x.w) * m.h) * free;
    (x + vel * m.h, vel)
}

/// The velocity of the substep that ends (`(x − prev) / h`) and the prediction of the next,
/// per particle, in one pass: on x86-64 with AVX2 two particles per register (unless `path`
/// is [`KernelPath::Scalar`] or [`KernelPath::Lanes4`]), else one at a time; the same bits
/// either way (test `motion_pass_matches_on_every_path`).
pub(crate) fn update_and_predict(path: KernelPath, m: &MotionConsts, s: MotionSlices<'_>) {
    debug_assert!(s.x.len() == s.v.len() && s.x.len() == s.f.len() && s.x.len() == s.prev.len());
    #[cfg(target_arch = "x86_64")]
    if matches!(path, KernelPath::Avx2 | KernelPath::Avx512) {
        // Falls back to the one-particle loop itself where the CPU lacks AVX2.
        x86::update_and_predict_avx2(m, s);
        return;
    }
    let _ = path;
    update_and_predict_lanes(m, s);
}

/// [`update_and_predict`] one particle at a time.
pub(crate) fn update_and_predict_lanes(m: &MotionConsts, s: MotionSlices<'_>) {
    let MotionSlices { x, v, f, prev } = s;
    for (((x, v), f), prev) in x.iter_mut().zip(v).zip(f).zip(prev) {
        let ended = (*x - *prev) * m.inv_h;
        *prev = *x;
        (*x, *v) = predict_particle(m, *x, ended, *f);
    }
}
