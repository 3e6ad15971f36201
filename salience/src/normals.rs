//! Per-node normals estimated from the neighbour lists alone, for callers (such as a cut cloth)
//! that have nodes and links but no triangle mesh for the current resolution.

use glam::Vec3;

use crate::error::SalienceError;
use crate::neighbours::Neighbours;

/// Estimates a unit normal per node from the positions of its neighbours, into `out`.
///
/// For node `i` with edge vectors `e_a = x_a − x_i` to its neighbours, the normal is the sum of
/// all pairwise cross products `e_a × e_b` (a < b), each flipped to agree with `hints[i]`
/// before it is added. Neighbour lists carry no winding order, so the sign must come from
/// somewhere: pass last evaluation's normals, or the rest-state normals, or one constant
/// orientation repeated. Each cross product is weighted by the area of the triangle it spans,
/// so near-collinear pairs count little. Cost O(k²) per node with k neighbours (28 cross
/// products for k = 8); no allocation.
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
        let mut sum = Vec3::ZERO;
        for (a, &ja) in row.iter().enumerate() {
            let ea = positions[ja as usize] - x;
            for &jb in &row[a + 1..] {
                let c = ea.cross(positions[jb as usize] - x);
                sum += if c.dot(hint) < 0.0 { -c } else { c };
            }
        }
        // Relative to the neighbourhood's size: below this the cross products are rounding noise.
        let scale = row
            .iter()
            .map(|&j| (positions[j as usize] - x).length_squared())
            .fold(0.0f32, f32::max);
        *o = if sum.length() > 1.0e-6 * scale {
            sum.normalize()
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
