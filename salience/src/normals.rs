//! Per-node normals estimated from the neighbour lists alone, for callers (such as a cut cloth)
//! that have nodes and links but no triangle mesh for the current resolution.

use glam::Vec3;

use crate::error::SalienceError;
use crate::neighbours::Neighbours;

/// Estimates a unit normal per node from the positions of its neighbours, into `out`.
///
/// For node `i`, take the points `{x_i} ∪ {x_j : j ∈ N(i)}` and their covariance `C` about
/// their mean. The normal is the direction of least spread, the eigenvector of `C`'s smallest
/// eigenvalue, found by one step of inverse iteration from `hints[i]`: `n ∝ adj(C) · hint`
/// (the adjugate is `C⁻¹` up to a positive factor, and stays defined when `C` is singular).
/// For a flat neighbourhood `C` has rank 2 and `adj(C)` is a multiple of `n nᵀ`, so the result
/// is exact whatever the hint, as long as the hint is not perpendicular to the surface; for a
/// curved one the error is the hint's error times `λ_min / λ_mid`, small for the smooth
/// neighbourhoods of a cloth. Because `adj(C)` is positive semi-definite the result stays on the
/// hint's side: neighbour lists carry no winding order, so the sign comes from the hint (pass
/// last evaluation's normals, or the rest-state normals, or one constant orientation).
/// Cost O(k) per node with k neighbours (about 80 flops for k = 8, against 28 cross products
/// for pairwise triangle normals); no allocation.
///
/// A node whose neighbours are all collinear with it (or that has fewer than two) gets its hint,
/// normalised (zero if the hint is zero). On error `out` is untouched.
pub fn estimate_normals(
    positions: &[Vec3],
    neighbours: &Neighbours<'_>,
    hints: &[Vec3],
    out: &mut [Vec3],
) -> Result<(), SalienceError> {
    let n = positions.len();
    for (what, found) in [
        ("neighbour table", neighbours.node_count()),
        ("hints", hints.len()),
        ("out", out.len()),
    ] {
        if found != n {
            return Err(SalienceError::LengthMismatch {
                what,
                expected: n,
                found,
            });
        }
    }
    for (i, ((&x, &hint), o)) in positions.iter().zip(hints).zip(out.iter_mut()).enumerate() {
        let row = neighbours.of(i);
        // Offsets from x_i; x_i itself is the point at offset 0.
        let (mut sum, mut xx, mut yy, mut zz, mut xy, mut xz, mut yz) =
            (Vec3::ZERO, 0f32, 0f32, 0f32, 0f32, 0f32, 0f32);
        for &j in row {
            let e = positions[j as usize] - x;
            sum += e;
            xx += e.x * e.x;
            yy += e.y * e.y;
            zz += e.z * e.z;
            xy += e.x * e.y;
            xz += e.x * e.z;
            yz += e.y * e.z;
        }
        let m = sum / (row.len() + 1) as f32;
        // Centred covariance: Σ e eᵀ − (k + 1) m mᵀ, with m·(k+1) = sum.
        let c0 = Vec3::new(xx - sum.x * m.x, xy - sum.x * m.y, xz - sum.x * m.z);
        let c1 = Vec3::new(c0.y, yy - sum.y * m.y, yz - sum.y * m.z);
        let c2 = Vec3::new(c0.z, c1.z, zz - sum.z * m.z);
        // Rows of the adjugate of a symmetric matrix are cross products of its columns.
        let a0 = c1.cross(c2);
        let a1 = c2.cross(c0);
        let a2 = c0.cross(c1);
        let n = Vec3::new(a0.dot(hint), a1.dot(hint), a2.dot(hint));
        // adj(C) scales with the square of the spread: relative to that, below this the
        // neighbourhood is a line (or a point) and has no normal.
        let trace = c0.x + c1.y + c2.z;
        *o = if n.length() > 1.0e-6 * trace * trace * hint.length() {
            n.normalize()
        } else {
            hint.normalize_or_zero()
        };
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::neighbours::NeighbourLists;

    #[test]
    fn grid_normals_follow_the_surface_and_the_hint() {
        // A 4×4 grid in the plane z = 0.5·x (tilted about y), 4-neighbourhood.
        let side = 4u32;
        let positions: Vec<Vec3> = (0..side * side)
            .map(|k| {
                let (x, y) = ((k % side) as f32, (k / side) as f32);
                Vec3::new(x, y, 0.5 * x)
            })
            .collect();
        let mut edges = Vec::new();
        for y in 0..side {
            for x in 0..side {
                let k = y * side + x;
                if x + 1 < side {
                    edges.push([k, k + 1]);
                }
                if y + 1 < side {
                    edges.push([k, k + side]);
                }
            }
        }
        let lists = NeighbourLists::from_undirected_edges(positions.len(), &edges).unwrap();
        let expected = Vec3::new(-0.5, 0.0, 1.0).normalize();
        for hint in [Vec3::Z, -Vec3::Z] {
            let hints = vec![hint; positions.len()];
            let mut out = vec![Vec3::ZERO; positions.len()];
            estimate_normals(&positions, &lists.as_neighbours(), &hints, &mut out).unwrap();
            for nrm in &out {
                assert!((*nrm - expected * hint.z).length() < 1e-5, "{nrm}");
            }
        }
    }

    /// On a curved patch (a sphere) the estimate stays close to the true normal even from a
    /// hint 60° off, and flips with the hint.
    #[test]
    fn curved_neighbourhoods_give_close_normals() {
        let r = 10.0f32;
        let centre = Vec3::new(0.0, 0.0, r);
        let on_sphere = |dx: f32, dy: f32| {
            let d = Vec3::new(dx, dy, -r).normalize();
            centre + d * r
        };
        let mut positions = vec![on_sphere(0.0, 0.0)];
        let mut edges = Vec::new();
        for k in 0..8 {
            let a = k as f32 * std::f32::consts::FRAC_PI_4;
            positions.push(on_sphere(a.cos(), a.sin()));
            edges.push([0, k + 1]);
        }
        let lists = NeighbourLists::from_undirected_edges(positions.len(), &edges).unwrap();
        let truth = -Vec3::Z;
        for hint in [Vec3::new(0.0, 1.7, -1.0), Vec3::new(0.0, -1.7, 1.0)] {
            let hints = vec![hint; positions.len()];
            let mut out = vec![Vec3::ZERO; positions.len()];
            estimate_normals(&positions, &lists.as_neighbours(), &hints, &mut out).unwrap();
            let expected = truth * hint.z.signum() * -1.0;
            assert!(out[0].dot(expected) > 0.999, "{} vs {expected}", out[0]);
        }
    }

    #[test]
    fn degenerate_rows_fall_back_and_errors_leave_out_alone() {
        let positions = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        let lists = NeighbourLists::from_undirected_edges(3, &[[0, 1], [1, 2]]).unwrap();
        let hints = [Vec3::Y * 3.0; 3];
        let mut out = [Vec3::ZERO; 3];
        estimate_normals(&positions, &lists.as_neighbours(), &hints, &mut out).unwrap();
        assert!(out.iter().all(|n| *n == Vec3::Y));
        let mut short = [Vec3::ONE; 2];
        assert!(estimate_normals(&positions, &lists.as_neighbours(), &hints, &mut short).is_err());
        assert_eq!(short, [Vec3::ONE; 2]);
    }
}
