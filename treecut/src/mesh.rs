//! The triangle-mesh builder: bottom-up clustering of neighbouring nodes, so a user's own cloth
//! mesh gets a hierarchy without being a grid.

use glam::Vec3;

use crate::build::{LevelStack, quotient_edges};
use crate::{BuildError, Hierarchy};

/// Largest cluster the greedy pass forms around a seed; a leftover node joins a neighbouring
/// cluster, so a few clusters get one more. Four matches the grid's quadtree fanout.
const TARGET_FANOUT: usize = 4;

/// Density used for area-lumped vertex masses when the caller gives none, in kg/m².
pub const DEFAULT_AREAL_DENSITY: f32 = 1.0;

/// CSR adjacency of one level's graph.
struct Graph {
    offsets: Vec<u32>,
    targets: Vec<u32>,
}

impl Graph {
    fn new(n: usize, edges: &[[u32; 2]]) -> Graph {
        let mut offsets = vec![0u32; n + 1];
        for &[a, b] in edges {
            offsets[a as usize + 1] += 1;
            offsets[b as usize + 1] += 1;
        }
        for i in 0..n {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        let mut targets = vec![0u32; offsets[n] as usize];
        for &[a, b] in edges {
            targets[fill[a as usize] as usize] = b;
            fill[a as usize] += 1;
            targets[fill[b as usize] as usize] = a;
            fill[b as usize] += 1;
        }
        Graph { offsets, targets }
    }

    fn neighbours(&self, i: usize) -> &[u32] {
        &self.targets[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }
}

/// Groups the nodes of one connected level into clusters of neighbours.
///
/// Seeds are taken in index order (deterministic); each seed takes its nearest unassigned
/// neighbours up to [`TARGET_FANOUT`] members. A node left alone joins the smallest neighbouring
/// cluster, so every cluster has at least two members and the level at least halves. Clusters are
/// connected (a star around the seed, plus neighbours of it).
fn cluster_level(positions: &[Vec3], graph: &Graph) -> (Vec<u32>, usize) {
    let n = positions.len();
    let mut assign = vec![u32::MAX; n];
    let mut sizes: Vec<u32> = Vec::new();
    let mut candidates: Vec<(f32, u32)> = Vec::new();
    for seed in 0..n {
        if assign[seed] != u32::MAX {
            continue;
        }
        candidates.clear();
        candidates.extend(
            graph
                .neighbours(seed)
                .iter()
                .filter(|&&k| assign[k as usize] == u32::MAX)
                .map(|&k| (positions[k as usize].distance_squared(positions[seed]), k)),
        );
        if candidates.is_empty() {
            continue; // Decided after the pass: it joins a neighbouring cluster.
        }
        candidates.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let id = sizes.len() as u32;
        assign[seed] = id;
        let mut size = 1;
        for &(_, k) in candidates.iter().take(TARGET_FANOUT - 1) {
            assign[k as usize] = id;
            size += 1;
        }
        sizes.push(size);
    }
    for i in 0..n {
        if assign[i] != u32::MAX {
            continue;
        }
        // Every neighbour was taken by a cluster (else this node would have seeded one with it).
        let best = graph
            .neighbours(i)
            .iter()
            .map(|&k| assign[k as usize])
            .filter(|&c| c != u32::MAX)
            .min_by_key(|&c| (sizes[c as usize], c))
            .expect("a connected level with more than one node has no isolated node");
        assign[i] = best;
        sizes[best as usize] += 1;
    }
    (assign, sizes.len())
}

/// Number of connected components and a vertex outside vertex 0's component, by union-find.
fn components(n: usize, edges: &[[u32; 2]]) -> (usize, u32) {
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    let mut parent: Vec<u32> = (0..n as u32).collect();
    let mut count = n;
    for &[a, b] in edges {
        let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
        if ra != rb {
            parent[ra.max(rb) as usize] = ra.min(rb);
            count -= 1;
        }
    }
    let r0 = find(&mut parent, 0);
    let example = (0..n as u32)
        .find(|&v| find(&mut parent, v) != r0)
        .unwrap_or(0);
    (count, example)
}

impl Hierarchy {
    /// Builds a hierarchy over any connected triangle mesh by bottom-up clustering of neighbours.
    ///
    /// `masses` gives one mass per vertex; without it each vertex gets a third of the area of its
    /// triangles times [`DEFAULT_AREAL_DENSITY`]. Adjacency is the triangles' edges.
    ///
    /// Disconnected meshes (including vertices no triangle uses) are refused with
    /// [`BuildError::Disconnected`]: every node of a hierarchy is one connected patch, so separate
    /// pieces are separate cloths, each with its own hierarchy.
    pub fn from_mesh(
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        masses: Option<&[f32]>,
    ) -> Result<Hierarchy, BuildError> {
        if positions.is_empty() {
            return Err(BuildError::Empty("no vertices"));
        }
        if triangles.is_empty() {
            return Err(BuildError::Empty("no triangles"));
        }
        if positions.len() > 1 << 30 {
            return Err(BuildError::BadGridSize {
                cols: positions.len().min(u32::MAX as usize) as u32,
                rows: 1,
            });
        }
        let nv = positions.len() as u32;
        if let Some(v) = positions.iter().position(|p| !p.is_finite()) {
            return Err(BuildError::NonFinitePosition(v as u32));
        }
        let mut edges = Vec::with_capacity(triangles.len() * 3);
        for (t, tri) in triangles.iter().enumerate() {
            if let Some(&index) = tri.iter().find(|&&i| i >= nv) {
                return Err(BuildError::IndexOutOfRange {
                    triangle: t as u32,
                    index,
                    vertices: nv,
                });
            }
            let [a, b, c] = *tri;
            if a == b || b == c || a == c {
                return Err(BuildError::DegenerateTriangle(t as u32));
            }
            for (x, y) in [(a, b), (b, c), (c, a)] {
                edges.push([x.min(y), x.max(y)]);
            }
        }
        edges.sort_unstable();
        edges.dedup();
        let (count, example) = components(positions.len(), &edges);
        if count > 1 {
            return Err(BuildError::Disconnected {
                components: count,
                example,
            });
        }

        let masses = match masses {
            Some(m) if m.len() != positions.len() => {
                return Err(BuildError::MassCountMismatch {
                    masses: m.len(),
                    vertices: positions.len(),
                });
            }
            Some(m) => m.to_vec(),
            None => {
                let mut m = vec![0f32; positions.len()];
                for &[a, b, c] in triangles {
                    let (pa, pb, pc) = (
                        positions[a as usize],
                        positions[b as usize],
                        positions[c as usize],
                    );
                    let third = (pb - pa).cross(pc - pa).length() / 6.0 * DEFAULT_AREAL_DENSITY;
                    for v in [a, b, c] {
                        m[v as usize] += third;
                    }
                }
                m
            }
        };
        if let Some(v) = masses.iter().position(|m| !(m.is_finite() && *m > 0.0)) {
            return Err(BuildError::InvalidMass {
                vertex: v as u32,
                mass: masses[v],
            });
        }
        let mut parents = Vec::new();
        let mut level_pos = positions.to_vec();
        let mut level_mass = masses.clone();
        let mut level_edges = edges.clone();
        while level_pos.len() > 1 {
            let graph = Graph::new(level_pos.len(), &level_edges);
            let (assign, clusters) = cluster_level(&level_pos, &graph);
            let mut pos = vec![Vec3::ZERO; clusters];
            let mut mass = vec![0f32; clusters];
            for (i, &c) in assign.iter().enumerate() {
                pos[c as usize] += level_pos[i] * level_mass[i];
                mass[c as usize] += level_mass[i];
            }
            for (p, m) in pos.iter_mut().zip(&mass) {
                *p /= *m;
            }
            level_edges = quotient_edges(&level_edges, &assign);
            parents.push(assign);
            level_pos = pos;
            level_mass = mass;
        }
        Ok(LevelStack {
            positions: positions.to_vec(),
            masses,
            edges,
            parents,
        }
        .assemble())
    }
}
