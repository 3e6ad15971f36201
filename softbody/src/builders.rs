//! Builders: a regular grid cloth, Bullet's triangle-mesh cloth, and cloth from any triangle mesh.
//!
//! Links are emitted in a canonical order (sorted particle pairs, stretch before bend), so
//! the colouring, and with it every result, depends only on the input.

use crate::body::SoftBody;
use crate::error::SoftBodyError;
use crate::ids::ParticleId;
use crate::settings::{Material, SolverSettings};
use glam::Vec3;

/// A rectangular grid of particles: vertex `(i, j)` (column `i`, row `j`) has index
/// `j*cols + i` and rest position `origin + i*u + j*v`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridCloth {
    /// Vertices per row (>= 2).
    pub cols: u32,
    /// Rows (>= 2).
    pub rows: u32,
    /// Position of vertex (0, 0).
    pub origin: Vec3,
    /// Step from one column to the next.
    pub u: Vec3,
    /// Step from one row to the next.
    pub v: Vec3,
    /// Mass of every vertex.
    pub vertex_mass: f32,
    /// Add both diagonals of every quad (shear links).
    pub shear: bool,
    /// Add links two apart along rows and columns (bend links).
    pub bend: bool,
    /// Link material.
    pub material: Material,
}

impl GridCloth {
    /// A square `n×n` grid in the XZ plane (spacing `spacing`), shear links on, bend off.
    pub fn square(n: u32, spacing: f32, vertex_mass: f32) -> Self {
        Self {
            cols: n,
            rows: n,
            origin: Vec3::ZERO,
            u: Vec3::new(spacing, 0.0, 0.0),
            v: Vec3::new(0.0, 0.0, spacing),
            vertex_mass,
            shear: true,
            bend: false,
            material: Material::default(),
        }
    }

    /// Rest position of vertex (i, j).
    pub fn vertex(&self, i: u32, j: u32) -> Vec3 {
        self.origin + self.u * i as f32 + self.v * j as f32
    }

    /// Index of the four corner vertices (for pinning a "swinging net").
    pub fn corners(&self) -> [ParticleId; 4] {
        let (c, r) = (self.cols, self.rows);
        [0, c - 1, (r - 1) * c, r * c - 1].map(ParticleId::from_raw)
    }

    /// Builds the body.
    pub fn build(&self, settings: SolverSettings) -> Result<SoftBody, SoftBodyError> {
        if self.cols < 2 || self.rows < 2 {
            return Err(SoftBodyError::Degenerate(
                "a grid cloth needs at least 2x2 vertices",
            ));
        }
        for (what, x) in [
            ("grid origin", self.origin),
            ("grid u", self.u),
            ("grid v", self.v),
        ] {
            if !x.is_finite() {
                return Err(SoftBodyError::NotFinite { what });
            }
        }
        self.material.validate()?;
        let mut body = SoftBody::new(settings)?;
        for j in 0..self.rows {
            for i in 0..self.cols {
                body.add_particle(self.vertex(i, j), self.vertex_mass)?;
            }
        }
        let cols = self.cols;
        let id = |i: u32, j: u32| j * cols + i;
        let mut stretch: Vec<(u32, u32)> = Vec::new();
        let mut bend: Vec<(u32, u32)> = Vec::new();
        for j in 0..self.rows {
            for i in 0..self.cols {
                let right = i + 1 < self.cols;
                let up = j + 1 < self.rows;
                if right {
                    stretch.push((id(i, j), id(i + 1, j)));
                }
                if up {
                    stretch.push((id(i, j), id(i, j + 1)));
                }
                if self.shear && right && up {
                    stretch.push((id(i, j), id(i + 1, j + 1)));
                    stretch.push((id(i + 1, j), id(i, j + 1)));
                }
                if self.bend {
                    if i + 2 < self.cols {
                        bend.push((id(i, j), id(i + 2, j)));
                    }
                    if j + 2 < self.rows {
                        bend.push((id(i, j), id(i, j + 2)));
                    }
                }
            }
        }
        // Canonical order: sorted (smaller, larger) pairs, as the mesh builder and the
        // TreeCut body use, so equal link sets give equal colourings.
        for list in [&mut stretch, &mut bend] {
            for e in list.iter_mut() {
                *e = (e.0.min(e.1), e.0.max(e.1));
            }
            list.sort_unstable();
        }
        add_links(&mut body, &stretch, &bend, &self.material);
        Ok(body)
    }

    /// The grid as a triangle mesh with one diagonal per quad (`(i,j)–(i+1,j+1)`), as
    /// Bullet's cloth is made from an OBJ grid: positions and triangles.
    pub fn triangles(&self) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut pos = Vec::with_capacity((self.cols * self.rows) as usize);
        for j in 0..self.rows {
            for i in 0..self.cols {
                pos.push(self.vertex(i, j));
            }
        }
        let cols = self.cols;
        let id = |i: u32, j: u32| j * cols + i;
        let mut tris = Vec::new();
        for j in 0..self.rows.saturating_sub(1) {
            for i in 0..self.cols.saturating_sub(1) {
                tris.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                tris.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        (pos, tris)
    }

    /// Bullet's cloth: the triangle edges of [`GridCloth::triangles`] as stretch links plus
    /// distance-2 bend links (`shear`/`bend` flags are ignored). 65×65 gives 12,416 + 24,319 links.
    pub fn build_bullet(&self, settings: SolverSettings) -> Result<SoftBody, SoftBodyError> {
        if self.cols < 2 || self.rows < 2 {
            return Err(SoftBodyError::Degenerate(
                "a grid cloth needs at least 2x2 vertices",
            ));
        }
        let (pos, tris) = self.triangles();
        MeshCloth {
            positions: &pos,
            triangles: &tris,
            masses: VertexMasses::Uniform(self.vertex_mass),
            bend: true,
            material: self.material,
        }
        .build(settings)
    }
}

/// Per-vertex masses for [`MeshCloth`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum VertexMasses<'a> {
    /// Every vertex has this mass.
    Uniform(f32),
    /// One mass per vertex.
    PerVertex(&'a [f32]),
}

/// Cloth from any triangle mesh: every triangle edge is a stretch link; with `bend`, every
/// pair of vertices two edges apart (and not joined by an edge) gets a bend link, as Bullet's
/// `generateBendingConstraints(2)` does.
#[derive(Clone, Copy, Debug)]
pub struct MeshCloth<'a> {
    /// Vertex rest positions.
    pub positions: &'a [Vec3],
    /// Triangles as vertex index triples.
    pub triangles: &'a [[u32; 3]],
    /// Vertex masses.
    pub masses: VertexMasses<'a>,
    /// Generate distance-2 bend links.
    pub bend: bool,
    /// Link material.
    pub material: Material,
}

impl MeshCloth<'_> {
    /// Builds the body; bad indices, NaN positions and non-positive masses are refused.
    pub fn build(&self, settings: SolverSettings) -> Result<SoftBody, SoftBodyError> {
        self.material.validate()?;
        let n = self.positions.len();
        if let VertexMasses::PerVertex(m) = self.masses
            && m.len() != n
        {
            return Err(SoftBodyError::OutOfRange {
                what: "mass count",
                index: m.len(),
                len: n,
            });
        }
        let mut body = SoftBody::new(settings)?;
        for (i, &p) in self.positions.iter().enumerate() {
            let m = match self.masses {
                VertexMasses::Uniform(m) => m,
                VertexMasses::PerVertex(ms) => ms[i],
            };
            body.add_particle(p, m)?;
        }
        let mut edges: Vec<(u32, u32)> = Vec::with_capacity(self.triangles.len() * 3);
        for t in self.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                for v in [a, b] {
                    if v as usize >= n {
                        return Err(SoftBodyError::OutOfRange {
                            what: "triangle vertex",
                            index: v as usize,
                            len: n,
                        });
                    }
                }
                if a == b {
                    return Err(SoftBodyError::SelfLink(a as usize));
                }
                edges.push((a.min(b), a.max(b)));
            }
        }
        edges.sort_unstable();
        edges.dedup();
        let bend = if self.bend {
            distance_two_pairs(n, &edges)
        } else {
            Vec::new()
        };
        add_links(&mut body, &edges, &bend, &self.material);
        Ok(body)
    }
}

/// Vertex pairs whose shortest path along `edges` has exactly two edges (sorted, unique).
pub fn distance_two_pairs(vertex_count: usize, edges: &[(u32, u32)]) -> Vec<(u32, u32)> {
    // Adjacency in CSR form.
    let mut deg = vec![0u32; vertex_count + 1];
    for &(a, b) in edges {
        deg[a as usize + 1] += 1;
        deg[b as usize + 1] += 1;
    }
    for i in 0..vertex_count {
        deg[i + 1] += deg[i];
    }
    let mut fill = deg.clone();
    let mut adj = vec![0u32; edges.len() * 2];
    for &(a, b) in edges {
        adj[fill[a as usize] as usize] = b;
        fill[a as usize] += 1;
        adj[fill[b as usize] as usize] = a;
        fill[b as usize] += 1;
    }
    let nb = |v: usize| &adj[deg[v] as usize..deg[v + 1] as usize];
    let mut mark = vec![u32::MAX; vertex_count];
    let mut out = Vec::new();
    for v in 0..vertex_count {
        mark[v] = v as u32;
        for &u in nb(v) {
            mark[u as usize] = v as u32;
        }
        for &u in nb(v) {
            for &w in nb(u as usize) {
                if w as usize > v && mark[w as usize] != v as u32 {
                    mark[w as usize] = v as u32;
                    out.push((v as u32, w));
                }
            }
        }
    }
    out.sort_unstable();
    out
}

/// Adds stretch then bend links with rest lengths from the current positions.
fn add_links(
    body: &mut SoftBody,
    stretch: &[(u32, u32)],
    bend: &[(u32, u32)],
    material: &Material,
) {
    for (pairs, is_bend) in [(stretch, false), (bend, true)] {
        for &(a, b) in pairs {
            let rest = (body.position(ParticleId::from_raw(a))
                - body.position(ParticleId::from_raw(b)))
            .length();
            let c = if is_bend {
                material.bend(rest)
            } else {
                material.stretch(rest)
            };
            body.add_link_raw(a, b, rest, c, 1.0);
        }
    }
}
