//! A skinned mesh of a rig and CPU linear-blend skinning (Magnenat-Thalmann, Laperrière and
//! Thalmann, "Joint-dependent local deformations for hand animation and object grasping",
//! Graphics Interface 1988 — the standard "linear blend skinning"): each vertex is moved by the
//! weighted sum of up to four joints' skinning matrices (model × inverse bind), the glTF
//! `JOINTS_0`/`WEIGHTS_0` attributes.

use glam::{Mat4, Vec3, Vec4};

use crate::error::{BuildError, CrowdError};
use crate::ids::SkinId;

/// One skinned mesh (all skinned primitives of a glTF mesh node, concatenated): bind-pose
/// positions and normals in the skeleton's model space, and per vertex four joint indices (into
/// its skin's joint list) with their weights. Plain runtime data.
#[derive(Clone, Debug, PartialEq)]
pub struct SkinnedMesh {
    /// Name (glTF mesh name, or `mesh<i>`).
    pub name: String,
    /// The skin whose joints the indices refer to.
    pub skin: SkinId,
    /// Bind-pose positions.
    pub positions: Vec<Vec3>,
    /// Bind-pose normals (unit length).
    pub normals: Vec<Vec3>,
    /// Per vertex: four indices into the skin's joints.
    pub joints: Vec<[u16; 4]>,
    /// Per vertex: the four weights, summing to 1.
    pub weights: Vec<[f32; 4]>,
}

impl SkinnedMesh {
    /// Checks the mesh against its skin's joint count: equal attribute lengths, finite values,
    /// joint indices in range, non-negative weights with a positive sum (normalised here to 1).
    pub fn validated(mut self, skin_joints: usize) -> Result<SkinnedMesh, BuildError> {
        let n = self.positions.len();
        let bad = |what: &str| BuildError::NonFinite {
            what: format!("mesh {:?}: {what}", self.name),
        };
        if self.normals.len() != n || self.joints.len() != n || self.weights.len() != n {
            return Err(bad("attribute lengths differ"));
        }
        if self
            .positions
            .iter()
            .chain(&self.normals)
            .any(|v| !v.is_finite())
        {
            return Err(bad("non-finite position or normal"));
        }
        if self
            .joints
            .iter()
            .flatten()
            .any(|&j| j as usize >= skin_joints)
        {
            return Err(bad("joint index beyond its skin"));
        }
        for w in &mut self.weights {
            let sum: f32 = w.iter().sum();
            if w.iter().any(|x| !x.is_finite() || *x < 0.0) || sum.is_nan() || sum <= 0.0 {
                return Err(bad("weights must be finite, >= 0 and not all 0"));
            }
            w.iter_mut().for_each(|x| *x /= sum);
        }
        for nrm in &mut self.normals {
            *nrm = nrm.normalize_or(Vec3::Y);
        }
        Ok(self)
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }
}

/// One character's CPU skinning of one mesh, as a job with named fields (as ozz-animation's
/// skinning job): `positions[v] = Σ_k w_k · palette[j_k] · bind_position[v]`, normals likewise
/// with the blended matrix's linear part, renormalised (exact for rotations and uniform scale).
#[derive(Debug)]
pub struct SkinningJob<'a> {
    /// The mesh.
    pub mesh: &'a SkinnedMesh,
    /// Skinning matrices of the mesh's skin, one per joint (model × inverse bind).
    pub palette: &'a [Mat4],
    /// Output positions, one per vertex.
    pub positions: &'a mut [Vec3],
    /// Output normals, one per vertex.
    pub normals: &'a mut [Vec3],
}

impl SkinningJob<'_> {
    /// Runs the job. Refused, writing nothing, if an output holds fewer values than the mesh
    /// has vertices or the palette has fewer matrices than a vertex's joint index needs.
    pub fn run(self) -> Result<(), CrowdError> {
        let m = self.mesh;
        let n = m.vertex_count();
        for given in [self.positions.len(), self.normals.len()] {
            if given < n {
                return Err(CrowdError::BufferTooSmall { needed: n, given });
            }
        }
        let need = m
            .joints
            .iter()
            .flatten()
            .map(|&j| j as usize + 1)
            .max()
            .unwrap_or(0);
        if self.palette.len() < need {
            return Err(CrowdError::BufferTooSmall {
                needed: need,
                given: self.palette.len(),
            });
        }
        for v in 0..n {
            (self.positions[v], self.normals[v]) = skin_vertex(m, self.palette, v);
        }
        Ok(())
    }
}

/// Vertex `v` of `m` skinned with `p` (long enough): its position and unit normal. Always
/// inlined: as a call it cost a fifth of a skinned vertex (its result went through the stack).
#[inline(always)]
pub(crate) fn skin_vertex(m: &SkinnedMesh, p: &[Mat4], v: usize) -> (Vec3, Vec3) {
    let (j, w) = (m.joints[v], m.weights[v]);
    let blend = |axis: fn(&Mat4) -> Vec4| {
        axis(&p[j[0] as usize]) * w[0]
            + axis(&p[j[1] as usize]) * w[1]
            + axis(&p[j[2] as usize]) * w[2]
            + axis(&p[j[3] as usize]) * w[3]
    };
    let b = Mat4::from_cols(
        blend(|m| m.x_axis),
        blend(|m| m.y_axis),
        blend(|m| m.z_axis),
        blend(|m| m.w_axis),
    );
    (
        b.transform_point3(m.positions[v]),
        b.transform_vector3(m.normals[v]).normalize_or(Vec3::Y),
    )
}

/// Blends two skinned copies of one mesh (the skinned key poses of a character, see
/// [`crate::Crowd::key_poses`]): `out = from + (to − from) · weight` for positions and normals.
/// Linear-blend skinning is linear in the palette, so the positions equal skinning the blended
/// model matrices; the normals are blended without renormalising (a renderer normalises them;
/// between two unit normals a few degrees apart the length stays within 1e-3 of 1).
#[derive(Debug)]
pub struct SkinBlendJob<'a> {
    /// Skinned positions and normals of the earlier key pose.
    pub from: (&'a [Vec3], &'a [Vec3]),
    /// Skinned positions and normals of the later key pose.
    pub to: (&'a [Vec3], &'a [Vec3]),
    /// Weight of `to`, in [0, 1].
    pub weight: f32,
    /// Output positions.
    pub positions: &'a mut [Vec3],
    /// Output normals.
    pub normals: &'a mut [Vec3],
}

impl SkinBlendJob<'_> {
    /// Runs the job over every vertex of the outputs. Refused, writing nothing, when an input
    /// holds fewer values than the outputs or the weight is not in [0, 1].
    pub fn run(self) -> Result<(), CrowdError> {
        let n = self.positions.len();
        if self.normals.len() != n {
            return Err(CrowdError::BufferTooSmall {
                needed: n,
                given: self.normals.len(),
            });
        }
        for given in [self.from.0, self.from.1, self.to.0, self.to.1].map(<[Vec3]>::len) {
            if given < n {
                return Err(CrowdError::BufferTooSmall { needed: n, given });
            }
        }
        if !(0.0..=1.0).contains(&self.weight) {
            return Err(crate::error::invalid("weight", "must be in [0, 1]"));
        }
        let w = self.weight;
        let lerp = |out: &mut [Vec3], a: &[Vec3], b: &[Vec3]| {
            for ((o, a), b) in out.iter_mut().zip(a).zip(b) {
                *o = *a + (*b - *a) * w;
            }
        };
        lerp(self.positions, self.from.0, self.to.0);
        lerp(self.normals, self.from.1, self.to.1);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Quat;

    fn mesh() -> SkinnedMesh {
        SkinnedMesh {
            name: "m".into(),
            skin: SkinId::new(0),
            positions: vec![Vec3::X, Vec3::Y],
            normals: vec![Vec3::Z, Vec3::Z],
            joints: vec![[0, 1, 0, 0], [1, 0, 0, 0]],
            weights: vec![[1.0, 1.0, 0.0, 0.0], [2.0, 0.0, 0.0, 0.0]],
        }
        .validated(2)
        .unwrap()
    }

    #[test]
    fn blends_joints_by_weight() {
        let m = mesh();
        assert_eq!(m.weights[0], [0.5, 0.5, 0.0, 0.0]);
        let turn = Mat4::from_quat(Quat::from_rotation_z(std::f32::consts::FRAC_PI_2));
        let palette = [Mat4::IDENTITY, Mat4::from_translation(Vec3::Z) * turn];
        let (mut p, mut n) = (vec![Vec3::ZERO; 2], vec![Vec3::ZERO; 2]);
        SkinningJob {
            mesh: &m,
            palette: &palette,
            positions: &mut p,
            normals: &mut n,
        }
        .run()
        .unwrap();
        // Vertex 0: half identity (X), half turned and lifted (Y + Z).
        assert!(p[0].abs_diff_eq(Vec3::new(0.5, 0.5, 0.5), 1e-6), "{}", p[0]);
        // Vertex 1 follows joint 1 alone: Y turned to −X, lifted by Z.
        assert!(
            p[1].abs_diff_eq(Vec3::new(-1.0, 0.0, 1.0), 1e-6),
            "{}",
            p[1]
        );
        assert!(n[1].abs_diff_eq(Vec3::Z, 1e-6));
    }

    #[test]
    fn blending_skinned_copies_equals_skinning_the_blended_palette() {
        let m = mesh();
        let turn = |a: f32| Mat4::from_quat(Quat::from_rotation_z(a));
        let pa = [Mat4::IDENTITY, Mat4::from_translation(Vec3::Z) * turn(0.3)];
        let pb = [turn(-0.2), Mat4::from_translation(Vec3::X) * turn(1.1)];
        let skin = |p: &[Mat4]| {
            let (mut pos, mut nrm) = (vec![Vec3::ZERO; 2], vec![Vec3::ZERO; 2]);
            SkinningJob {
                mesh: &m,
                palette: p,
                positions: &mut pos,
                normals: &mut nrm,
            }
            .run()
            .unwrap();
            (pos, nrm)
        };
        let (a, b) = (skin(&pa), skin(&pb));
        let w = 0.3;
        let mixed: Vec<Mat4> = pa
            .iter()
            .zip(&pb)
            .map(|(x, y)| *x * (1.0 - w) + *y * w)
            .collect();
        let direct = skin(&mixed);
        let (mut pos, mut nrm) = (vec![Vec3::ZERO; 2], vec![Vec3::ZERO; 2]);
        SkinBlendJob {
            from: (&a.0, &a.1),
            to: (&b.0, &b.1),
            weight: w,
            positions: &mut pos,
            normals: &mut nrm,
        }
        .run()
        .unwrap();
        for (p, q) in pos.iter().zip(&direct.0) {
            assert!(p.abs_diff_eq(*q, 1e-5), "{p} {q}");
        }
        let bad = SkinBlendJob {
            from: (&a.0, &a.1),
            to: (&b.0, &b.1),
            weight: f32::NAN,
            positions: &mut pos,
            normals: &mut nrm,
        }
        .run();
        assert!(bad.is_err());
    }

    #[test]
    fn bad_meshes_and_buffers_are_refused() {
        let mut m = mesh();
        m.joints[0][0] = 7;
        assert!(m.clone().validated(2).is_err());
        let mut m2 = mesh();
        m2.weights[1] = [0.0; 4];
        assert!(m2.validated(2).is_err());
        let m = mesh();
        let mut p = vec![Vec3::ZERO; 1];
        let mut n = vec![Vec3::ZERO; 2];
        let e = SkinningJob {
            mesh: &m,
            palette: &[Mat4::IDENTITY; 2],
            positions: &mut p,
            normals: &mut n,
        }
        .run();
        assert!(matches!(
            e,
            Err(CrowdError::BufferTooSmall {
                needed: 2,
                given: 1
            })
        ));
        assert_eq!(p[0], Vec3::ZERO);
        let mut p = vec![Vec3::ZERO; 2];
        let e = SkinningJob {
            mesh: &m,
            palette: &[Mat4::IDENTITY; 1],
            positions: &mut p,
            normals: &mut n,
        }
        .run();
        assert!(e.is_err());
    }
}
