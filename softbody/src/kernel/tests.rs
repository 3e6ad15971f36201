//! Every supported kernel path against the scalar reference, bit for bit.

use super::*;

/// A little deterministic generator (no dependency needed for test data).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> u32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 33) as u32
    }
    fn unit(&mut self) -> f32 {
        self.next() as f32 / (1u64 << 31) as f32
    }
}

/// `n` particles and a batch of `len` links over distinct particles (a random matching), with
/// pinned particles, zero compliance, zero weights and coincident ends among them.
fn batch(seed: u64, n: usize, len: usize) -> (Vec<Vec4>, Vec<Block>) {
    let mut rng = Lcg(seed);
    let mut p: Vec<Vec4> = (0..n)
        .map(|_| {
            let w = if rng.next().is_multiple_of(7) {
                0.0
            } else {
                0.1 + rng.unit()
            };
            Vec4::new(rng.unit(), rng.unit() - 0.5, rng.unit() * 0.3, w)
        })
        .collect();
    let mut order: Vec<u32> = (0..n as u32).collect();
    for i in (1..order.len()).rev() {
        order.swap(i, rng.next() as usize % (i + 1));
    }
    let mut blocks = vec![Block::default(); len.div_ceil(LANES)];
    for i in 0..len {
        let (a, b) = (order[2 * i], order[2 * i + 1]);
        if i % 11 == 5 {
            p[b as usize] = p[a as usize]; // coincident ends: the length floor
        }
        let blk = &mut blocks[i / LANES];
        let k = i % LANES;
        blk.a[k] = a;
        blk.b[k] = b;
        blk.rest[k] = rng.unit() * 0.2;
        blk.compliance[k] = if i % 3 == 0 { 0.0 } else { rng.unit() * 1e-3 };
        blk.weight[k] = match i % 5 {
            0 => 0.0,
            1 => rng.unit(),
            _ => 1.0,
        };
        // λ = 0 for weight-0 links, as at the start of every substep (their "no effect" case).
        blk.lambda[k] = if blk.weight[k] == 0.0 {
            0.0
        } else {
            (rng.unit() - 0.5) * 0.01
        };
    }
    (p, blocks)
}

fn bits(p: &[Vec4]) -> Vec<[u32; 4]> {
    p.iter().map(|v| v.to_array().map(f32::to_bits)).collect()
}

/// Every lane's multiplier, as bits (spare lanes too).
fn lambda_bits(b: &[Block]) -> Vec<u32> {
    b.iter()
        .flat_map(|blk| blk.lambda.map(f32::to_bits))
        .collect()
}

/// Every supported path gives exactly the scalar path's positions and multipliers, over
/// several sweeps, for batch lengths with and without a partial last block.
#[test]
fn every_path_matches_scalar_bitwise() {
    let paths: Vec<KernelPath> = KernelPath::supported().collect();
    assert!(paths.contains(&KernelPath::Scalar) && paths.contains(&KernelPath::Lanes4));
    for (seed, len) in [(1u64, 16usize), (2, 37), (3, 160), (4, 5), (5, 1000)] {
        let (p0, b0) = batch(seed, 2 * len + 9, len);
        let (mut p_ref, mut b_ref) = (p0.clone(), b0.clone());
        for _ in 0..5 {
            solve_batch(
                KernelPath::Scalar,
                p_ref.as_mut_slice(),
                &mut b_ref,
                len,
                3600.0,
                false,
            );
        }
        for &path in &paths {
            let (mut p, mut b) = (p0.clone(), b0.clone());
            for _ in 0..5 {
                solve_batch(path, p.as_mut_slice(), &mut b, len, 3600.0, false);
            }
            assert_eq!(bits(&p), bits(&p_ref), "{path:?}, {len} links");
            assert_eq!(
                lambda_bits(&b),
                lambda_bits(&b_ref),
                "{path:?}, {len} links"
            );
        }
        assert_ne!(bits(&p_ref), bits(&p0), "the sweep moved something");
    }
}

/// A fresh sweep (multipliers known to be 0, not stored) moves the particles exactly as a
/// sweep after resetting the multipliers does, on every path and in the ordered sweep, and
/// leaves the stored multipliers as they were.
#[test]
fn fresh_sweep_is_a_sweep_from_zero_multipliers() {
    for (seed, len) in [(11u64, 37usize), (12, 160), (13, 7)] {
        let (p0, b0) = batch(seed, 2 * len + 9, len);
        // Multipliers left over from earlier sweeps: the fresh sweep must not read them.
        let (mut p_warm, mut stale) = (p0.clone(), b0.clone());
        solve_batch(
            KernelPath::Scalar,
            p_warm.as_mut_slice(),
            &mut stale,
            len,
            3600.0,
            false,
        );
        let mut zeroed = stale.clone();
        zeroed.iter_mut().for_each(|blk| blk.lambda = [0.0; LANES]);
        let (mut p_ref, mut b_ref) = (p0.clone(), zeroed);
        solve_batch(
            KernelPath::Scalar,
            p_ref.as_mut_slice(),
            &mut b_ref,
            len,
            3600.0,
            false,
        );
        for path in KernelPath::supported() {
            let (mut p, mut b) = (p0.clone(), stale.clone());
            solve_batch(path, p.as_mut_slice(), &mut b, len, 3600.0, true);
            assert_eq!(bits(&p), bits(&p_ref), "{path:?}, {len} links");
            assert_eq!(b, stale, "{path:?}: multipliers untouched");
        }
        let (mut p, mut b) = (p0.clone(), stale.clone());
        let (mut q, mut c) = (p0.clone(), b_ref.clone());
        c.iter_mut().for_each(|blk| blk.lambda = [0.0; LANES]);
        solve_ordered(p.as_mut_slice(), &mut b, len, 3600.0, true);
        solve_ordered(q.as_mut_slice(), &mut c, len, 3600.0, false);
        assert_eq!(bits(&p), bits(&q), "ordered, {len} links");
    }
}

/// The scalar path keeps inverse masses, leaves weight-0 links' particles and pinned particles
/// where they were, and moves the others.
#[test]
fn scalar_reference_properties() {
    let (p0, b0) = batch(9, 80, 32);
    let (mut p, mut b) = (p0.clone(), b0.clone());
    solve_batch(
        KernelPath::Scalar,
        p.as_mut_slice(),
        &mut b,
        32,
        3600.0,
        false,
    );
    assert!(
        p.iter()
            .zip(&p0)
            .all(|(x, y)| x.w.to_bits() == y.w.to_bits())
    );
    for i in 0..32 {
        let blk = &b0[i / LANES];
        let k = i % LANES;
        let (a, bb) = (blk.a[k] as usize, blk.b[k] as usize);
        if blk.weight[k] == 0.0 {
            assert_eq!(p[a], p0[a]);
            assert_eq!(p[bb], p0[bb]);
        }
        for q in [a, bb] {
            if p0[q].w == 0.0 {
                assert_eq!(p[q], p0[q], "pinned particle moved");
            }
        }
    }
    assert!(p.iter().zip(&p0).any(|(x, y)| x != y));
}

/// Only supported paths are reported, and the detected one is among them.
#[test]
fn detection_is_consistent() {
    assert!(KernelPath::detect().is_supported());
    assert!(KernelPath::Scalar.is_supported());
}

/// The last, partial block of a batch is solved in vector lanes on the paths that have them:
/// every length of it (1 to 15 links, alone and after whole blocks) gives the scalar path's
/// bits, and the lanes past the batch's length — which after a swap-removal hold a removed
/// link, with particle indices that may no longer exist — are neither read through nor
/// written: out-of-range indices and NaN parameters there change nothing, and keep their bits.
#[test]
fn partial_blocks_match_scalar_and_leave_spare_lanes_alone() {
    for whole in [0usize, 2] {
        for rest in 1..LANES {
            let len = whole * LANES + rest;
            let n = 2 * len + 5;
            let (p0, mut b0) = batch(100 + len as u64, n, len);
            let last = b0.last_mut().expect("a partial block");
            for k in rest..LANES {
                last.a[k] = (n + 1000 + k) as u32;
                last.b[k] = u32::MAX - k as u32;
                last.rest[k] = f32::NAN;
                last.compliance[k] = f32::NAN;
                last.weight[k] = f32::NAN;
                last.lambda[k] = f32::from_bits(0x7fc0_0000 + k as u32);
            }
            let spare = |b: &[Block]| -> Vec<u32> {
                let last = b.last().expect("a partial block");
                (rest..LANES)
                    .flat_map(|k| {
                        [
                            last.a[k],
                            last.b[k],
                            last.rest[k].to_bits(),
                            last.weight[k].to_bits(),
                            last.lambda[k].to_bits(),
                        ]
                    })
                    .collect()
            };
            for fresh in [false, true] {
                let (mut p_ref, mut b_ref) = (p0.clone(), b0.clone());
                for _ in 0..3 {
                    solve_batch(
                        KernelPath::Scalar,
                        p_ref.as_mut_slice(),
                        &mut b_ref,
                        len,
                        3600.0,
                        fresh,
                    );
                }
                for path in KernelPath::supported() {
                    let (mut p, mut b) = (p0.clone(), b0.clone());
                    for _ in 0..3 {
                        solve_batch(path, p.as_mut_slice(), &mut b, len, 3600.0, fresh);
                    }
                    let what = format!("{path:?}, {len} links, fresh {fresh}");
                    assert_eq!(bits(&p), bits(&p_ref), "{what}");
                    assert_eq!(lambda_bits(&b), lambda_bits(&b_ref), "{what}");
                    assert_eq!(spare(&b), spare(&b0), "{what}");
                }
                // (The test batch's first link has weight 0: one link alone moves nothing.)
                if len > 2 {
                    assert_ne!(bits(&p_ref), bits(&p0), "the sweep moved something");
                }
            }
        }
    }
}

/// The index check the unchecked kernels rely on: it sees an out-of-range end in a full block
/// and in the live lanes of a partial one, ignores the stale lanes past the batch's length,
/// and refuses a length the blocks cannot hold.
#[test]
fn index_check_covers_live_lanes_only() {
    let (p, mut b) = batch(7, 200, 40);
    let n = p.len();
    assert!(indices_below(&b, 40, n));
    // A stale lane past the length (a removed link's leftovers) does not count.
    b[2].a[10] = n as u32 + 5;
    assert!(indices_below(&b, 40, n));
    // Live lanes do: the first link of the partial block, a full block's last lane.
    b[2].b[0] = n as u32;
    assert!(!indices_below(&b, 40, n));
    b[2].b[0] = 0;
    b[0].a[15] = u32::MAX;
    assert!(!indices_below(&b, 40, n));
    b[0].a[15] = 1;
    assert!(indices_below(&b, 40, n));
    // Fewer particles than an end needs, and more links than the blocks hold.
    assert!(!indices_below(&b, 40, 10));
    assert!(!indices_below(&b, 49, n));
}

/// A batch with an end past the particles panics before any particle moves (it would read out
/// of bounds otherwise).
#[test]
fn out_of_range_batch_is_refused_on_every_path() {
    for path in KernelPath::supported() {
        let (mut p, mut b) = batch(8, 100, 33);
        b[1].b[3] = p.len() as u32;
        let before = bits(&p);
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            solve_batch(path, p.as_mut_slice(), &mut b, 33, 3600.0, false);
        }));
        assert!(
            r.is_err(),
            "{path:?} solved a batch with an end out of range"
        );
        assert_eq!(bits(&p), before, "{path:?} moved particles before refusing");
    }
}

/// The substep's fused velocity update and prediction gives the one-particle loop's bits on
/// every path, for even and odd particle counts, with pinned particles, damping and forces.
#[test]
fn motion_pass_matches_on_every_path() {
    let m = MotionConsts {
        h: 1.0 / 1920.0,
        damp: 0.999,
        g: Vec4::new(0.0, -9.81, 0.0, 0.0),
        inv_h: 1920.0,
    };
    for n in [0usize, 1, 2, 7, 64, 101] {
        let mut rng = Lcg(n as u64 + 3);
        let mut data = |w: bool| -> Vec<Vec4> {
            (0..n)
                .map(|i| {
                    let inv_mass = if !w {
                        rng.unit()
                    } else if i % 5 == 0 {
                        0.0
                    } else {
                        0.5 + rng.unit()
                    };
                    Vec4::new(rng.unit(), rng.unit() - 0.5, rng.unit(), inv_mass)
                })
                .collect()
        };
        let (x, prev, f, v) = (data(true), data(true), data(false), data(false));
        let run = |path: Option<KernelPath>| {
            let (mut x, mut prev, mut v) = (x.clone(), prev.clone(), v.clone());
            let s = MotionSlices {
                x: &mut x,
                v: &mut v,
                f: &f,
                prev: &mut prev,
            };
            match path {
                Some(path) => update_and_predict(path, &m, s),
                None => update_and_predict_lanes(&m, s),
            }
            (bits(&x), bits(&v), bits(&prev))
        };
        let reference = run(None);
        for path in KernelPath::supported() {
            assert_eq!(run(Some(path)), reference, "{path:?}, {n} particles");
        }
    }
}
