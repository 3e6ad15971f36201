//! The four engine scenes: what each cloth is, what it touches, what moves it, and where the
//! camera is.

use std::path::Path;
use std::sync::Arc;

use animlod::{BoneId, CharacterId, Crowd, Rig};
use glam::{Quat, Vec3};
use salience::View;
use slod::cloth::{AdaptiveCloth, BoneAttachments, ClothError};
use softbody::{ColliderDesc, Shape, Transform, TreeCutSettings, WindField, grid_triangles};
use treecut::{Cut, GridSpec, Hierarchy};

/// Which scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneKind {
    /// A 2 m cloth dropped onto a sphere standing on the ground; it drapes.
    DrapeSphere,
    /// A 2 m × 1 m flag on a pole (a thin capsule) in gusty wind.
    FlagWind,
    /// A cape pinned to the torso of GDBot walking, ten body capsules and spheres on its bones.
    CapeWalk,
    /// A 1 m cloth on a box tilted past its friction angle; it slides off onto the ground.
    SlideBox,
}

impl SceneKind {
    /// Every scene, in report order.
    pub const ALL: [SceneKind; 4] = [
        SceneKind::DrapeSphere,
        SceneKind::FlagWind,
        SceneKind::CapeWalk,
        SceneKind::SlideBox,
    ];

    /// The report name.
    pub fn name(self) -> &'static str {
        match self {
            SceneKind::DrapeSphere => "drape_sphere",
            SceneKind::FlagWind => "flag_wind",
            SceneKind::CapeWalk => "cape_walk",
            SceneKind::SlideBox => "slide_box",
        }
    }
}

/// A character wearing the cloth: its crowd, its id and the cloth's ties to its bones.
#[derive(Debug)]
struct Wearer {
    crowd: Crowd,
    character: CharacterId,
    attachments: BoneAttachments,
}

/// One scene, ready to step.
#[derive(Debug)]
pub struct SceneInstance {
    /// The cloth.
    pub cloth: AdaptiveCloth,
    /// The camera (1080 px high) every step and every measurement sees through.
    pub view: View,
    wearer: Option<Wearer>,
}

impl SceneInstance {
    /// One frame: the character (if any) advances and carries the cloth's pins and colliders,
    /// then the cloth steps; both see the same view.
    pub fn frame(&mut self) -> Result<(), ClothError> {
        if let Some(w) = &mut self.wearer {
            let dt = self.cloth.body().settings().solver.dt;
            w.crowd.advance(dt, &self.view)?;
            w.attachments
                .apply(&mut self.cloth, &w.crowd, w.character)?;
        }
        self.cloth.step(&self.view)
    }
}

/// The camera: 1920 × 1080 px, 50° vertical field of view.
fn camera(eye: Vec3, target: Vec3) -> Result<View, ClothError> {
    Ok(View::look_at(
        eye,
        target,
        Vec3::Y,
        50f32.to_radians(),
        1920,
        1080,
    )?)
}

/// The grid of a scene at `size` vertices per side (the flag has half as many rows).
pub(crate) fn scene_grid(kind: SceneKind, size: u32) -> GridSpec {
    let n = size.max(3);
    let step = |len: f32, count: u32| len / (count - 1) as f32;
    match kind {
        SceneKind::DrapeSphere => {
            let mut g = GridSpec::horizontal(n, n, step(2.0, n), 0.5);
            g.origin.y = 1.3;
            g
        }
        SceneKind::FlagWind => {
            let rows = n / 2 + 1;
            GridSpec {
                cols: n,
                rows,
                origin: Vec3::new(0.0, 2.0, 0.0),
                u: Vec3::X * step(2.0, n),
                v: -Vec3::Y * step(1.0, rows),
                vertex_mass: 0.3 / (n * rows) as f32,
            }
        }
        SceneKind::CapeWalk => GridSpec {
            cols: n,
            rows: n,
            origin: Vec3::new(-0.25, 0.83, -0.2),
            u: Vec3::X * step(0.5, n),
            v: -Vec3::Y * step(0.6, n),
            vertex_mass: 0.15 / (n * n) as f32,
        },
        SceneKind::SlideBox => {
            let rot = slide_rotation();
            let spacing = step(1.0, n);
            GridSpec {
                cols: n,
                rows: n,
                origin: rot * Vec3::new(-0.5, 0.106, -0.5),
                u: rot * Vec3::X * spacing,
                v: rot * Vec3::Z * spacing,
                vertex_mass: 0.25 / (n * n) as f32,
            }
        }
    }
}

/// The slide box's tilt: 30° about z, past the 21.8° friction angle of μ = 0.4.
fn slide_rotation() -> Quat {
    Quat::from_rotation_z(-30f32.to_radians())
}

fn collider(shape: Shape, transform: Transform, friction: f32) -> ColliderDesc {
    ColliderDesc {
        shape,
        transform,
        friction,
        ..ColliderDesc::default()
    }
}

/// The GDBot rig from the repository's assets.
fn gdbot(assets: &Path) -> Result<Arc<Rig>, ClothError> {
    let rig = animlod::build::import_path(&assets.join("GDQuest_GDBot.glb")).map_err(|e| {
        ClothError::Feedback {
            field: "assets",
            reason: if matches!(e, animlod::ImportError::Io { .. }) {
                "GDQuest_GDBot.glb not found"
            } else {
                "GDQuest_GDBot.glb did not load"
            },
        }
    })?;
    Ok(Arc::new(rig))
}

fn bone(rig: &Rig, name: &str) -> Result<BoneId, ClothError> {
    rig.skeleton().find(name).ok_or(ClothError::Feedback {
        field: "rig",
        reason: "GDBot lacks a bone the cape scene uses",
    })
}

/// Builds a scene at `size` vertices per side on `cut` (a cut of the scene's hierarchy, see
/// [`scene_hierarchy`]); `assets` is the directory of the glTF rigs.
pub fn build_scene(
    kind: SceneKind,
    hierarchy: &Arc<Hierarchy>,
    spec: &GridSpec,
    cut: Cut,
    assets: &Path,
) -> Result<SceneInstance, ClothError> {
    let settings = TreeCutSettings::default();
    let mut cloth = AdaptiveCloth::new(hierarchy.clone(), cut, settings, spec.u.cross(spec.v))?;
    cloth
        .body_mut()
        .set_surface(&grid_triangles(spec.cols, spec.rows))?;
    let ground = |y: f32| {
        collider(
            Shape::Plane,
            Transform::plane(Vec3::new(0.0, y, 0.0), Vec3::Y),
            0.6,
        )
    };
    let mut wearer = None;
    let view = match kind {
        SceneKind::DrapeSphere => {
            cloth.add_collider(collider(
                Shape::Sphere { radius: 0.5 },
                Transform::from_position(Vec3::new(0.0, 0.5, 0.0)),
                0.5,
            ))?;
            cloth.add_collider(ground(0.0))?;
            camera(Vec3::new(0.0, 2.2, 3.6), Vec3::new(0.0, 0.6, 0.0))?
        }
        SceneKind::FlagWind => {
            for j in 0..spec.rows {
                cloth
                    .body_mut()
                    .pin_vertex(spec.vertex(0, j), spec.position(0, j))?;
            }
            cloth.add_collider(collider(
                Shape::Capsule {
                    radius: 0.025,
                    half_length: 1.5,
                },
                Transform::from_position(Vec3::new(-0.03, 1.5, 0.0)),
                0.3,
            ))?;
            cloth.set_wind(Some(WindField {
                velocity: Vec3::new(8.0, 0.0, 3.0),
                gust: 0.35,
                gust_frequency: 0.7,
                gust_wavelength: 3.0,
                seed: 11,
                ..WindField::default()
            }))?;
            camera(Vec3::new(1.0, 1.6, 4.0), Vec3::new(1.0, 1.4, 0.0))?
        }
        SceneKind::CapeWalk => {
            let rig = gdbot(assets)?;
            let walk = rig.clip_by_name("walk").ok_or(ClothError::Feedback {
                field: "rig",
                reason: "GDBot has no walk clip",
            })?;
            let mut crowd = Crowd::new(rig.clone());
            let character = crowd.add_character(Vec3::ZERO, walk)?;
            let bones = rig.bone_count();
            let mut attachments = BoneAttachments::new();
            // Body: torso and head, arms and legs, on the bones they move with (+y runs along
            // each bone).
            let capsule = |radius, half_length| Shape::Capsule {
                radius,
                half_length,
            };
            let along = |d: f32| Transform::from_position(Vec3::Y * d);
            let body: [(&str, Shape, Transform); 10] = [
                ("torso", capsule(0.15, 0.1), along(0.2)),
                ("head", Shape::Sphere { radius: 0.16 }, along(0.12)),
                ("upperarm.L", capsule(0.05, 0.08), along(0.1)),
                ("upperarm.R", capsule(0.05, 0.08), along(0.1)),
                ("lowerarm.L", capsule(0.045, 0.06), along(0.07)),
                ("lowerarm.R", capsule(0.045, 0.06), along(0.07)),
                ("upperleg.L", capsule(0.07, 0.06), along(0.07)),
                ("upperleg.R", capsule(0.07, 0.06), along(0.07)),
                ("lowerleg.L", capsule(0.06, 0.08), along(0.1)),
                ("lowerleg.R", capsule(0.06, 0.08), along(0.1)),
            ];
            for (name, shape, local) in body {
                let id = cloth.add_collider(collider(shape, Transform::IDENTITY, 0.4))?;
                attachments.attach_collider(&cloth, bones, id, bone(&rig, name)?, local)?;
            }
            // The cape's top row hangs from the torso where it is at rest.
            let torso = bone(&rig, "torso")?;
            let model = crowd.model_matrices(character)?[torso.index()];
            let inverse = model.inverse();
            for i in 0..spec.cols {
                let at = spec.position(i, 0);
                let offset = inverse.transform_point3(at);
                attachments.pin_vertex(&cloth, bones, spec.vertex(i, 0), torso, offset)?;
            }
            attachments.teleport_colliders(&mut cloth, &crowd, character)?;
            attachments.apply(&mut cloth, &crowd, character)?;
            wearer = Some(Wearer {
                crowd,
                character,
                attachments,
            });
            camera(Vec3::new(1.4, 1.0, -2.0), Vec3::new(0.0, 0.55, 0.0))?
        }
        SceneKind::SlideBox => {
            cloth.add_collider(collider(
                Shape::Box {
                    half_extents: Vec3::new(1.0, 0.1, 0.8),
                },
                Transform {
                    position: Vec3::ZERO,
                    rotation: slide_rotation(),
                },
                0.4,
            ))?;
            cloth.add_collider(ground(-1.0))?;
            camera(Vec3::new(0.0, 0.5, 4.0), Vec3::new(0.4, -0.4, 0.0))?
        }
    };
    Ok(SceneInstance {
        cloth,
        view,
        wearer,
    })
}

/// The hierarchy of a scene's grid.
pub fn scene_hierarchy(
    kind: SceneKind,
    size: u32,
) -> Result<(GridSpec, Arc<Hierarchy>), ClothError> {
    let spec = scene_grid(kind, size);
    Ok((spec, Arc::new(Hierarchy::grid(&spec)?)))
}
