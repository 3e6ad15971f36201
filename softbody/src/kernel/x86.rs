//! The AVX2 and AVX-512F block kernels (x86-64), selected at run time, and the AVX2 pass of a
//! substep's velocity update and prediction (two particles per register).
//!
//! # An exception to `deny(unsafe_code)`
//! A function compiled for a CPU feature (`#[target_feature]`) may only be called once the CPU
//! is known to have it, and Rust makes that call `unsafe`: the entry points (`blocks_avx512`,
//! `blocks_avx2`, `partial_avx2`, `update_and_predict_avx2`) call their kernel right after
//! `is_x86_feature_detected!` confirmed the feature. The kernels also gather and scatter
//! particles without a bounds check per access ([`Particles::get_unchecked`]): every entry
//! point is an `unsafe fn` whose contract is that the links' particle indices are below the
//! particle count, which the link store checks once per change of its links
//! (`LinkStore::check_in_range`). The rest is safe code: since Rust 1.87 (1.89 for AVX-512)
//! the `std::arch` value intrinsics are safe inside a function compiled with their feature,
//! particles move between `glam::Vec4` and `__m128` through `glam`'s safe conversions, and link
//! data is read from and written to the block's arrays by value.
//!
//! # Layout in registers
//! Register `r_j` (`j` = 0..3) holds, in its 128-bit lane `L`, the particle of link `4L + j`.
//! Transposing the four registers inside each 128-bit lane (`unpacklo/hi` + `shuffle`) gives
//! `x, y, z, w` registers whose lane `i` belongs to link `i`: the links stay in their natural
//! order, so the block's parameters are plain contiguous loads. The transpose is its own
//! inverse, which puts the results back for the scatter.
#![allow(unsafe_code)]

use super::{Block, DENOM_FLOOR, LANES, LENGTH_FLOOR, Particles};
use glam::Vec4;
use std::arch::x86_64::*;

/// Solves every block of `blocks` with AVX-512F; returns the number solved (0 if the CPU
/// lacks AVX-512F, leaving them to the caller's scalar loop).
///
/// # Safety
/// Every particle index of the blocks' links is below `p.count()`.
pub(super) unsafe fn blocks_avx512<P: Particles + ?Sized, const FRESH: bool>(
    p: &mut P,
    blocks: &mut [Block],
    inv_h2: f32,
) -> usize {
    if !is_x86_feature_detected!("avx512f") {
        return 0;
    }
    // SAFETY: the CPU supports AVX-512F (checked just above), which is what calling a function
    // compiled with `target_feature(enable = "avx512f")` requires; the indices are in range
    // (this function's contract, which is `run_avx512`'s).
    unsafe { run_avx512::<P, FRESH>(p, blocks, inv_h2) };
    blocks.len()
}

/// Solves every block of `blocks` with AVX2; returns the number solved (0 if the CPU lacks AVX2).
///
/// # Safety
/// Every particle index of the blocks' links is below `p.count()`.
pub(super) unsafe fn blocks_avx2<P: Particles + ?Sized, const FRESH: bool>(
    p: &mut P,
    blocks: &mut [Block],
    inv_h2: f32,
) -> usize {
    if !is_x86_feature_detected!("avx2") {
        return 0;
    }
    // SAFETY: the CPU supports AVX2 (checked just above), which is what calling a function
    // compiled with `target_feature(enable = "avx2")` requires; the indices are in range (this
    // function's contract, which is `run_avx2`'s).
    unsafe { run_avx2::<P, FRESH>(p, blocks, inv_h2) };
    blocks.len()
}

/// Solves the first `len` (`1..LANES`) links of a batch's last, partial block with AVX2, eight
/// lanes at a time; returns `false` (nothing solved) if the CPU lacks AVX2. The same bits as
/// the scalar loop it replaces.
///
/// # Safety
/// Both particle indices of each of the block's first `len` links are below `p.count()`.
pub(super) unsafe fn partial_avx2<P: Particles + ?Sized, const FRESH: bool>(
    p: &mut P,
    blk: &mut Block,
    len: usize,
    inv_h2: f32,
) -> bool {
    if !is_x86_feature_detected!("avx2") {
        return false;
    }
    // SAFETY: the CPU supports AVX2 (checked just above), which is what calling a function
    // compiled with `target_feature(enable = "avx2")` requires; the indices are in range (this
    // function's contract, which is `run_partial_avx2`'s).
    unsafe { run_partial_avx2::<P, FRESH>(p, blk, len, inv_h2) };
    true
}

/// # Safety
/// The CPU has AVX-512F; every particle index of the blocks' links is below `p.count()`.
#[target_feature(enable = "avx512f")]
unsafe fn run_avx512<P: Particles + ?Sized, const FRESH: bool>(
    p: &mut P,
    blocks: &mut [Block],
    inv_h2: f32,
) {
    for blk in blocks {
        // SAFETY: the block's indices are in range (this function's contract).
        unsafe { block_avx512::<P, FRESH>(p, blk, inv_h2) };
    }
}

// ---- AVX-512F: sixteen links ----

#[target_feature(enable = "avx512f")]
#[inline]
fn load16(v: &[f32; LANES]) -> __m512 {
    _mm512_setr_ps(
        v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8], v[9], v[10], v[11], v[12], v[13],
        v[14], v[15],
    )
}

#[target_feature(enable = "avx512f")]
#[inline]
fn store16(v: __m512, out: &mut [f32; LANES]) {
    let q = [
        _mm512_extractf32x4_ps::<0>(v),
        _mm512_extractf32x4_ps::<1>(v),
        _mm512_extractf32x4_ps::<2>(v),
        _mm512_extractf32x4_ps::<3>(v),
    ];
    for (l, q) in q.into_iter().enumerate() {
        out[4 * l..4 * l + 4].copy_from_slice(&Vec4::from(q).to_array());
    }
}

// Gather, transpose and scatter are macros rather than functions: a `#[target_feature]`
// function cannot be `#[inline(always)]`, and one that is not inlined passes its registers
// through memory.

/// In-lane 4×4 transpose of four registers (its own inverse).
macro_rules! transpose {
    ($r:expr, $unpacklo:ident, $unpackhi:ident, $shuffle:ident) => {{
        let r = $r;
        let t0 = $unpacklo(r[0], r[1]);
        let t1 = $unpacklo(r[2], r[3]);
        let t2 = $unpackhi(r[0], r[1]);
        let t3 = $unpackhi(r[2], r[3]);
        [
            $shuffle::<0x44>(t0, t1),
            $shuffle::<0xEE>(t0, t1),
            $shuffle::<0x44>(t2, t3),
            $shuffle::<0xEE>(t2, t3),
        ]
    }};
}

/// Gathers the particles of sixteen links: `x, y, z, w` registers in link order.
macro_rules! gather16 {
    ($p:expr, $idx:expr) => {{
        let (p, idx): (&P, &[u32; LANES]) = (&*$p, $idx);
        // SAFETY: every index of `idx` (from `o` on: the links gathered) is below `p.count()`
        // (the contract of the `unsafe fn` this expands in).
        let at = |k: usize| -> __m128 { unsafe { p.get_unchecked(idx[k] as usize) }.into() };
        let row = |j: usize| {
            let v = _mm512_castps128_ps512(at(j));
            let v = _mm512_insertf32x4::<1>(v, at(4 + j));
            let v = _mm512_insertf32x4::<2>(v, at(8 + j));
            _mm512_insertf32x4::<3>(v, at(12 + j))
        };
        transpose!(
            [row(0), row(1), row(2), row(3)],
            _mm512_unpacklo_ps,
            _mm512_unpackhi_ps,
            _mm512_shuffle_ps
        )
    }};
}

/// Writes `x, y, z, w` registers back to the particles of sixteen links.
macro_rules! scatter16 {
    ($p:expr, $idx:expr, $xyzw:expr) => {{
        let (p, idx): (&mut P, &[u32; LANES]) = ($p, $idx);
        let r = transpose!(
            $xyzw,
            _mm512_unpacklo_ps,
            _mm512_unpackhi_ps,
            _mm512_shuffle_ps
        );
        let mut set = |k: usize, v: __m128| {
            // SAFETY: every index of `idx` (from `o` on: the links scattered) is below
            // `p.count()` (the contract of the `unsafe fn` this expands in).
            unsafe { p.set_unchecked(idx[k] as usize, v.into()) }
        };
        for j in 0..4 {
            set(j, _mm512_extractf32x4_ps::<0>(r[j]));
            set(4 + j, _mm512_extractf32x4_ps::<1>(r[j]));
            set(8 + j, _mm512_extractf32x4_ps::<2>(r[j]));
            set(12 + j, _mm512_extractf32x4_ps::<3>(r[j]));
        }
    }};
}

/// The link update on whole registers (see the module docs of `kernel` for the formula): takes
/// the gathered `x, y, z, w` of both ends and the links' parameters, returns the new λ and the
/// new `x, y, z, w` of both ends. One body for both widths, named by their intrinsics.
macro_rules! solve_registers {
    (
        $a:expr, $b:expr, $rest:expr, $compliance:expr, $weight:expr, $lambda:expr, $inv_h2:expr;
        $sub:ident, $add:ident, $mul:ident, $div:ident, $sqrt:ident, $max:ident, $set1:ident
    ) => {{
        let [ax, ay, az, aw] = $a;
        let [bx, by, bz, bw] = $b;
        let (dx, dy, dz) = ($sub(bx, ax), $sub(by, ay), $sub(bz, az));
        let len2 = $add($add($mul(dx, dx), $mul(dy, dy)), $mul(dz, dz));
        let len = $max($sqrt(len2), $set1(LENGTH_FLOOR));
        let at = $mul($compliance, $set1($inv_h2));
        let (wk, lk) = ($weight, $lambda);
        let c = $sub(len, $rest);
        let den = $max($add($mul(wk, $add(aw, bw)), at), $set1(DENOM_FLOOR));
        let s = $div($add($mul(wk, c), $mul(at, lk)), $mul(den, len));
        let (sa, sb) = ($mul(aw, s), $mul(bw, s));
        (
            $sub(lk, $mul(s, len)),
            [
                $add(ax, $mul(dx, sa)),
                $add(ay, $mul(dy, sa)),
                $add(az, $mul(dz, sa)),
                aw,
            ],
            [
                $sub(bx, $mul(dx, sb)),
                $sub(by, $mul(dy, sb)),
                $sub(bz, $mul(dz, sb)),
                bw,
            ],
        )
    }};
}

/// # Safety
/// The CPU has AVX-512F; every particle index of `blk` is below `p.count()`.
#[target_feature(enable = "avx512f")]
#[inline]
unsafe fn block_avx512<P: Particles + ?Sized, const FRESH: bool>(
    p: &mut P,
    blk: &mut Block,
    inv_h2: f32,
) {
    let lambda = if FRESH {
        _mm512_setzero_ps()
    } else {
        load16(&blk.lambda)
    };
    let (lambda, na, nb) = solve_registers!(
        gather16!(p, &blk.a), gather16!(p, &blk.b), load16(&blk.rest),
        load16(&blk.compliance), load16(&blk.weight), lambda, inv_h2;
        _mm512_sub_ps, _mm512_add_ps, _mm512_mul_ps, _mm512_div_ps, _mm512_sqrt_ps,
        _mm512_max_ps, _mm512_set1_ps
    );
    if !FRESH {
        store16(lambda, &mut blk.lambda);
    }
    scatter16!(p, &blk.a, na);
    scatter16!(p, &blk.b, nb);
}

// ---- AVX2: eight links (lanes `o..o + 8` of a block) ----

#[target_feature(enable = "avx2")]
#[inline]
fn load8(v: &[f32; LANES], o: usize) -> __m256 {
    _mm256_setr_ps(
        v[o],
        v[o + 1],
        v[o + 2],
        v[o + 3],
        v[o + 4],
        v[o + 5],
        v[o + 6],
        v[o + 7],
    )
}

#[target_feature(enable = "avx2")]
#[inline]
fn store8(v: __m256, out: &mut [f32; LANES], o: usize) {
    let lo = Vec4::from(_mm256_castps256_ps128(v)).to_array();
    let hi = Vec4::from(_mm256_extractf128_ps::<1>(v)).to_array();
    out[o..o + 4].copy_from_slice(&lo);
    out[o + 4..o + 8].copy_from_slice(&hi);
}

/// Gathers the particles of links `o..o + 8`: `x, y, z, w` registers in link order.
macro_rules! gather8 {
    ($p:expr, $idx:expr, $o:expr) => {{
        let (p, idx, o): (&P, &[u32; LANES], usize) = (&*$p, $idx, $o);
        // SAFETY: every index of `idx` (from `o` on: the links gathered) is below `p.count()`
        // (the contract of the `unsafe fn` this expands in).
        let at = |k: usize| -> __m128 { unsafe { p.get_unchecked(idx[o + k] as usize) }.into() };
        let row = |j: usize| _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(at(j)), at(4 + j));
        transpose!(
            [row(0), row(1), row(2), row(3)],
            _mm256_unpacklo_ps,
            _mm256_unpackhi_ps,
            _mm256_shuffle_ps
        )
    }};
}

/// Writes `x, y, z, w` registers back to the particles of the first `n` of links `o..o + 8`
/// (the lanes past them are not links: a batch's last, partial block).
macro_rules! scatter8_first {
    ($p:expr, $idx:expr, $o:expr, $xyzw:expr, $n:expr) => {{
        let (p, idx, o, n): (&mut P, &[u32; LANES], usize, usize) = ($p, $idx, $o, $n);
        let r = transpose!(
            $xyzw,
            _mm256_unpacklo_ps,
            _mm256_unpackhi_ps,
            _mm256_shuffle_ps
        );
        let mut set = |k: usize, v: __m128| {
            // SAFETY: every index of `idx` (from `o` on: the links scattered) is below
            // `p.count()` (the contract of the `unsafe fn` this expands in).
            unsafe { p.set_unchecked(idx[o + k] as usize, v.into()) }
        };
        for j in 0..4 {
            if j < n {
                set(j, _mm256_castps256_ps128(r[j]));
            }
            if 4 + j < n {
                set(4 + j, _mm256_extractf128_ps::<1>(r[j]));
            }
        }
    }};
}

/// Writes `x, y, z, w` registers back to the particles of links `o..o + 8` (all eight: the
/// constant count folds the lane checks away).
macro_rules! scatter8 {
    ($p:expr, $idx:expr, $o:expr, $xyzw:expr) => {
        scatter8_first!($p, $idx, $o, $xyzw, 8)
    };
}

/// New λ and new `x, y, z, w` of both ends, for links `o..o + 8` of a block.
type Solved8 = (__m256, [__m256; 4], [__m256; 4]);

#[target_feature(enable = "avx2")]
#[inline]
fn solve8<const FRESH: bool>(
    blk: &Block,
    o: usize,
    a: [__m256; 4],
    b: [__m256; 4],
    inv_h2: f32,
) -> Solved8 {
    let lambda = if FRESH {
        _mm256_setzero_ps()
    } else {
        load8(&blk.lambda, o)
    };
    solve_registers!(
        a, b, load8(&blk.rest, o), load8(&blk.compliance, o), load8(&blk.weight, o),
        lambda, inv_h2;
        _mm256_sub_ps, _mm256_add_ps, _mm256_mul_ps, _mm256_div_ps, _mm256_sqrt_ps,
        _mm256_max_ps, _mm256_set1_ps
    )
}

/// # Safety
/// The CPU has AVX2; every particle index of the blocks' links is below `p.count()`.
#[target_feature(enable = "avx2")]
unsafe fn run_avx2<P: Particles + ?Sized, const FRESH: bool>(
    p: &mut P,
    blocks: &mut [Block],
    inv_h2: f32,
) {
    for blk in blocks {
        // The two halves are independent (a batch's links share no particle): gathering both
        // before solving either gives the core two dependency chains to overlap.
        let (a0, b0) = (gather8!(p, &blk.a, 0), gather8!(p, &blk.b, 0));
        let (a1, b1) = (gather8!(p, &blk.a, 8), gather8!(p, &blk.b, 8));
        let (l0, na0, nb0) = solve8::<FRESH>(blk, 0, a0, b0, inv_h2);
        let (l1, na1, nb1) = solve8::<FRESH>(blk, 8, a1, b1, inv_h2);
        if !FRESH {
            store8(l0, &mut blk.lambda, 0);
            store8(l1, &mut blk.lambda, 8);
        }
        scatter8!(p, &blk.a, 0, na0);
        scatter8!(p, &blk.b, 0, nb0);
        scatter8!(p, &blk.a, 8, na1);
        scatter8!(p, &blk.b, 8, nb1);
    }
}

/// The first `len` links of a partial block (see [`partial_avx2`]). Lanes from `len` on are
/// not links: whatever they hold (a removed link's data, particle indices that may be out of
/// range now) is never gathered through nor written back. Their particle indices are replaced
/// by the first link's in a local copy, so the gather stays in range, their results are
/// dropped, and the block's own arrays keep their bits (λ is stored for the real links only).
/// A half with a single link is left to the scalar lane, which is cheaper there.
///
/// # Safety
/// The CPU has AVX2; both particle indices of each of the block's first `len` links are below
/// `p.count()`.
#[target_feature(enable = "avx2")]
unsafe fn run_partial_avx2<P: Particles + ?Sized, const FRESH: bool>(
    p: &mut P,
    blk: &mut Block,
    len: usize,
    inv_h2: f32,
) {
    debug_assert!(len > 0 && len < LANES);
    let (mut a, mut b) = (blk.a, blk.b);
    a[len..].fill(blk.a[0]);
    b[len..].fill(blk.b[0]);
    for o in (0..len).step_by(8) {
        let n = (len - o).min(8);
        if n == 1 {
            super::solve_lane::<P, FRESH>(p, blk, o, inv_h2);
            continue;
        }
        let (ga, gb) = (gather8!(p, &a, o), gather8!(p, &b, o));
        let (l, na, nb) = solve8::<FRESH>(blk, o, ga, gb, inv_h2);
        if !FRESH {
            let mut lambda = [0f32; LANES];
            store8(l, &mut lambda, 0);
            blk.lambda[o..o + n].copy_from_slice(&lambda[..n]);
        }
        scatter8_first!(p, &a, o, na, n);
        scatter8_first!(p, &b, o, nb, n);
    }
}

// ---- The fused velocity update and prediction of a substep, two particles per register ----

/// [`update_and_predict`](super::update_and_predict) with AVX2, two particles per register
/// (the one-particle loop where the CPU lacks AVX2). The same operations per lane as the
/// one-particle loop, so the same bits. About a tenth of the default step (32 substeps × 1
/// iteration) of the 65² net: 0.580 → 0.504 ms (medians of eleven interleaved runs).
pub(super) fn update_and_predict_avx2(m: &super::MotionConsts, s: super::MotionSlices<'_>) {
    if is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2 (checked just above), which is all that calling a
        // function compiled with `target_feature(enable = "avx2")` requires.
        unsafe { run_update_and_predict_avx2(m, s) };
    } else {
        super::update_and_predict_lanes(m, s);
    }
}

/// Two `Vec4`s as one register (safe: `glam`'s conversions and an in-register insert).
#[target_feature(enable = "avx2")]
#[inline]
fn pair(a: Vec4, b: Vec4) -> __m256 {
    _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(a.into()), b.into())
}

/// The register's two halves back as `Vec4`s.
#[target_feature(enable = "avx2")]
#[inline]
fn unpair(r: __m256) -> (Vec4, Vec4) {
    (
        Vec4::from(_mm256_castps256_ps128(r)),
        Vec4::from(_mm256_extractf128_ps::<1>(r)),
    )
}

#[target_feature(enable = "avx2")]
fn run_update_and_predict_avx2(m: &super::MotionConsts, s: super::MotionSlices<'_>) {
    let super::MotionSlices { x, v, f, prev } = s;
    let (h, damp, inv_h) = (
        _mm256_set1_ps(m.h),
        _mm256_set1_ps(m.damp),
        _mm256_set1_ps(m.inv_h),
    );
    let g = pair(m.g, m.g);
    let (zero, one) = (_mm256_setzero_ps(), _mm256_set1_ps(1.0));
    let pairs = x.len() / 2;
    let (x2, v2, f2, p2) = (
        x[..2 * pairs].chunks_exact_mut(2),
        v[..2 * pairs].chunks_exact_mut(2),
        f[..2 * pairs].chunks_exact(2),
        prev[..2 * pairs].chunks_exact_mut(2),
    );
    for (((x, v), f), prev) in x2.zip(v2).zip(f2).zip(p2) {
        let xx = pair(x[0], x[1]);
        let ended = _mm256_mul_ps(_mm256_sub_ps(xx, pair(prev[0], prev[1])), inv_h);
        (prev[0], prev[1]) = (x[0], x[1]);
        // Each particle's inverse mass in all four of its lanes; free = 1 where it is > 0.
        let w = _mm256_permute_ps::<0xFF>(xx);
        let free = _mm256_and_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(w, zero), one);
        let force = _mm256_mul_ps(pair(f[0], f[1]), w);
        let vel = _mm256_mul_ps(
            _mm256_add_ps(
                _mm256_mul_ps(ended, damp),
                _mm256_mul_ps(_mm256_add_ps(g, force), h),
            ),
            free,
        );
        (x[0], x[1]) = unpair(_mm256_add_ps(xx, _mm256_mul_ps(vel, h)));
        (v[0], v[1]) = unpair(vel);
    }
    let tail = super::MotionSlices {
        x: &mut x[2 * pairs..],
        v: &mut v[2 * pairs..],
        f: &f[2 * pairs..],
        prev: &mut prev[2 * pairs..],
    };
    super::update_and_predict_lanes(m, tail);
}
