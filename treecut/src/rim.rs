//! The rim of a hierarchy's finest mesh: which vertices lie on its boundary (free edges and the
//! outline of holes), found from the finest edges and the rest positions alone.
//!
//! An edge `u–v` is on the rim when every vertex adjacent to both lies on one side of it: the
//! triangles an interior edge separates lie on both sides, a boundary edge has faces on one side
//! only. Sides are compared with the normals `(x_v − x_u) × (x_w − x_u)` of the triangles the
//! common neighbours `w` span (opposite sides give opposite normals), so no global plane is
//! needed and a curved rest shape (a cape, a sleeve) works as well as a flat one. It holds for
//! meshes whose extra edges stay inside faces too: a grid's 8-neighbourhood (both diagonals of
//! a cell) puts the grid's outline, and only it, on the rim. An edge no triangle contains (a
//! chain) is on the rim as well.
//!
//! Why the cloth needs it: the TreeCut soft body of the simulation paper
//! (`simulation-lod-treecut-softbody-bswdf.txt`, section 3) coarsens the rim like any region,
//! but the stretch of a held sheet concentrates along its free edges and at its supports, and a
//! coarse rim node changes the motion of the whole sheet, not only its own region (see the
//! feedback loop's `rim_weight` in the `slod` crate for the measurements).

use glam::Vec3;

use crate::Hierarchy;

/// Per finest vertex (index = vertex index): whether it lies on the rim of the finest mesh
/// (an endpoint of a rim edge; see the module docs). O(E · degree).
pub fn rim_vertices(h: &Hierarchy) -> Vec<bool> {
    let n = h.vertex_count();
    let rest: Vec<Vec3> = (0..n as u32)
        .map(|v| h.rest_position(h.leaf_of_vertex(v)))
        .collect();
    let mut adjacency: Vec<Vec<u32>> = vec![Vec::new(); n];
    for &[u, v] in h.leaf_edges() {
        adjacency[u as usize].push(v);
        adjacency[v as usize].push(u);
    }
    adjacency.iter_mut().for_each(|a| {
        a.sort_unstable();
        a.dedup();
    });
    let mut rim = vec![false; n];
    let mut normals: Vec<Vec3> = Vec::new();
    for &[u, v] in h.leaf_edges() {
        let (a, b) = (&adjacency[u as usize], &adjacency[v as usize]);
        let (xu, e) = (rest[u as usize], rest[v as usize] - rest[u as usize]);
        normals.clear();
        let (mut i, mut j) = (0, 0);
        while i < a.len() && j < b.len() {
            match a[i].cmp(&b[j]) {
                std::cmp::Ordering::Less => i += 1,
                std::cmp::Ordering::Greater => j += 1,
                std::cmp::Ordering::Equal => {
                    let c = e.cross(rest[a[i] as usize] - xu);
                    if c.length_squared() > 0.0 {
                        normals.push(c);
                    }
                    i += 1;
                    j += 1;
                }
            }
        }
        let two_sided = normals
            .iter()
            .enumerate()
            .any(|(k, c)| normals[k + 1..].iter().any(|d| c.dot(*d) < 0.0));
        if !two_sided {
            rim[u as usize] = true;
            rim[v as usize] = true;
        }
    }
    rim
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::GridSpec;

    #[test]
    fn a_grid_rim_is_its_outline() {
        for (cols, rows) in [(5, 5), (8, 3), (33, 17)] {
            let spec = GridSpec::horizontal(cols, rows, 0.1, 1.0);
            let h = Hierarchy::grid(&spec).unwrap();
            let rim = rim_vertices(&h);
            for j in 0..rows {
                for i in 0..cols {
                    let outline = i == 0 || j == 0 || i + 1 == cols || j + 1 == rows;
                    assert_eq!(rim[spec.vertex(i, j) as usize], outline, "({i}, {j})");
                }
            }
        }
    }

    #[test]
    fn a_mesh_rim_includes_a_hole_and_survives_bending() {
        // A 5 × 5 vertex sheet, the centre cell's two triangles left out (a hole), wrapped
        // round a cylinder so no plane contains it.
        let side = 6u32;
        let positions: Vec<Vec3> = (0..side * side)
            .map(|k| {
                let (i, j) = ((k % side) as f32, (k / side) as f32);
                let a = 0.3 * i;
                Vec3::new(a.sin(), j * 0.2, a.cos())
            })
            .collect();
        let mut triangles = Vec::new();
        for j in 0..side - 1 {
            for i in 0..side - 1 {
                if (i, j) == (2, 2) {
                    continue;
                }
                let a = j * side + i;
                triangles.push([a, a + 1, a + side + 1]);
                triangles.push([a, a + side + 1, a + side]);
            }
        }
        let h = Hierarchy::from_mesh(&positions, &triangles, None).unwrap();
        let rim = rim_vertices(&h);
        for k in 0..side * side {
            let (i, j) = (k % side, k / side);
            let outline = i == 0 || j == 0 || i + 1 == side || j + 1 == side;
            let hole = (2..=3).contains(&i) && (2..=3).contains(&j);
            assert_eq!(rim[k as usize], outline || hole, "({i}, {j})");
        }
    }
}
