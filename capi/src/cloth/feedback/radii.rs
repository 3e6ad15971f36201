//! The rest radius of every hierarchy node: how large a region a node stands for, which turns
//! salience into an on-screen size ([`super::PriorityModel::ScreenError`]).

use treecut::NodeId;

/// A rest radius per hierarchy node: the largest rest distance from the node to a finest
/// vertex it covers, or half the shortest rest edge at a leaf (the area a vertex stands for).
pub(crate) fn node_radii(h: &treecut::Hierarchy) -> Vec<f32> {
    let rest = h.rest_positions();
    let mut leaf_half = vec![f32::INFINITY; h.vertex_count()];
    for &[a, b] in h.leaf_edges() {
        let d = 0.5 * rest[h.leaf_of_vertex(a).index()].distance(rest[h.leaf_of_vertex(b).index()]);
        leaf_half[a as usize] = leaf_half[a as usize].min(d);
        leaf_half[b as usize] = leaf_half[b as usize].min(d);
    }
    (0..h.len())
        .map(|i| {
            let n = NodeId::new(i);
            let c = rest[i];
            if let Some(v) = h.vertex_of_leaf(n) {
                let r = leaf_half[v as usize];
                if r.is_finite() { r } else { 0.0 }
            } else {
                h.vertices(n)
                    .iter()
                    .map(|&v| c.distance(rest[h.leaf_of_vertex(v).index()]))
                    .fold(0.0f32, f32::max)
            }
        })
        .collect()
}
