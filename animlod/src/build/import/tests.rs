//! Import tests on the real rigs in `assets/gltf`, on synthetic files covering what they lack
//! (STEP, CUBICSPLINE, normalised and sparse accessors, matrices, external buffers, several
//! skins), and on truncated and corrupted copies of the real files.

use std::path::PathBuf;

use glam::{Quat, Vec3};
use serde_json::{Value, json};

use crate::transform::rotation_angle;
use crate::{ImportError, Keys, Property, Rig};

pub(crate) fn asset(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../assets/gltf")
        .join(name)
}

fn read(name: &str) -> Vec<u8> {
    std::fs::read(asset(name)).unwrap()
}

/// (file, bones, joints, skins, clips)
const RIGS: [(&str, usize, usize, usize, usize); 5] = [
    ("GDQuest_GDBot.glb", 64, 63, 1, 7),
    ("RobotExpressive.glb", 46, 43, 4, 14),
    ("Godot_PlatformerRobot.glb", 28, 27, 1, 8),
    ("Fox.glb", 25, 24, 1, 3),
    ("SimpleSkin.gltf", 3, 2, 1, 1),
];

#[test]
fn real_rigs_import() {
    for (name, bones, joints, skins, clips) in RIGS {
        let rig = crate::build::import_path(&asset(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        let sk = rig.skeleton();
        assert_eq!(sk.len(), bones, "{name}");
        assert_eq!(
            sk.bones().filter(|&b| sk.is_joint(b)).count(),
            joints,
            "{name}"
        );
        assert_eq!(rig.skins().len(), skins, "{name}");
        assert_eq!(rig.clips().len(), clips, "{name}");
        for b in sk.bones() {
            if let Some(p) = sk.parent(b) {
                assert!(p < b, "{name}: parents first");
            }
        }
        // RobotExpressive's nodes are saved in a pose other than its bind pose (its "Body" joint
        // is turned ~16° from where its inverse bind matrix puts it), so the check below does not
        // apply to it.
        for skin in rig.skins().iter().filter(|_| name != "RobotExpressive.glb") {
            // In the bind pose, model × inverse bind is the same matrix for every joint of a skin
            // (the inverse of the mesh's bind-space transform; identity when the mesh sits at the
            // origin). This checks hierarchy, rest transforms and inverse bind matrices together.
            let model = sk.rest_model_matrices();
            let first = model[skin.joints[0].index()] * skin.inverse_bind[0];
            let tol = 2e-3
                * first
                    .to_cols_array()
                    .iter()
                    .fold(1.0f32, |m, x| m.max(x.abs()));
            for (j, ib) in skin.joints.iter().zip(&skin.inverse_bind) {
                let m = model[j.index()] * *ib;
                assert!(
                    m.abs_diff_eq(first, tol),
                    "{name} {}: {m} vs {first}",
                    sk.name(*j)
                );
            }
        }
        // The slice entry point gives the same rig.
        let dir = asset(name).parent().map(|p| p.to_path_buf());
        let again = crate::build::import_slice(&read(name), dir.as_deref()).unwrap();
        assert_eq!(again.bone_count(), bones);
    }
    // RobotExpressive's 4 skins share the same 43 joints; its morph-weight channels are skipped.
    let robot = crate::build::import_path(&asset("RobotExpressive.glb")).unwrap();
    assert!(
        robot
            .skins()
            .iter()
            .all(|s| s.joints == robot.skins()[0].joints)
    );
    assert_eq!(robot.import_report().weight_channels, 42);
}

#[test]
fn gdbot_scene_without_nodes_list() {
    let bytes = read("GDQuest_GDBot.glb");
    // gltf 1.4.1 on its own refuses the file (a scene without `nodes`, valid glTF) ...
    assert!(gltf::Gltf::from_slice(&bytes).is_err());
    // ... our pre-pass adds the empty list.
    let (json, _) = super::container::split(&bytes).unwrap();
    let raw: Value = serde_json::from_slice(json).unwrap();
    assert!(
        raw["scenes"]
            .as_array()
            .unwrap()
            .iter()
            .any(|s| s.get("nodes").is_none())
    );
    assert!(crate::build::import_slice(&bytes, None).is_ok());
}

#[test]
fn gdbot_walk_constant_channels() {
    let rig = crate::build::import_path(&asset("GDQuest_GDBot.glb")).unwrap();
    let walk = rig.clip(rig.clip_by_name("walk").unwrap()).unwrap();
    let s = walk.stats();
    assert_eq!(s.keyed, [63, 63, 63]);
    // 58 of 63 translation and all 63 scale channels never change. Rotation: 38 channels repeat
    // their first key exactly; 2 more only alternate between q and −q (the same rotation), so
    // 40 are constant once q and −q count as equal.
    assert_eq!(s.constant(Property::Translation), 58);
    assert_eq!(s.constant(Property::Scale), 63);
    assert_eq!(s.constant(Property::Rotation), 40);
    let raw_constant = walk
        .channels()
        .iter()
        .filter(|c| match &c.keys {
            Keys::Rotation(v) => v.iter().all(|q| {
                (glam::Vec4::from(*q) - glam::Vec4::from(v[0]))
                    .abs()
                    .max_element()
                    < 1e-6
            }),
            _ => false,
        })
        .count();
    assert_eq!(raw_constant, 38);
    assert_eq!(walk.animated_bone_count(), 25);
    assert_eq!(s.animated(), 5 + 23);
}

#[test]
fn sign_flipped_rotation_keys_in_real_rigs() {
    // Consecutive keys with a negative dot product: present in GDBot, RobotExpressive and the
    // platformer robot, absent in Fox. After import every rotation block is in one hemisphere.
    for (name, expect_flips) in [
        ("GDQuest_GDBot.glb", true),
        ("RobotExpressive.glb", true),
        ("Godot_PlatformerRobot.glb", true),
        ("Fox.glb", false),
    ] {
        let rig = crate::build::import_path(&asset(name)).unwrap();
        let flips: u32 = rig.clips().iter().map(|c| c.stats().hemisphere_flips).sum();
        assert_eq!(flips > 0, expect_flips, "{name}: {flips}");
        for (ci, clip) in rig.clips().iter().enumerate() {
            for block in &clip.rotations {
                let c = block.bones.len();
                for k in 1..block.keys.len() / c {
                    for i in 0..c {
                        assert!(block.keys[(k - 1) * c + i].dot(block.keys[k * c + i]) >= 0.0);
                    }
                }
            }
            // Sampling between flipped keys never swings through another pose: the sampled
            // rotation stays within the two keys' angle of each key.
            let p = rig.priorities(crate::ClipId::new(ci)).unwrap();
            for w in p.timeline().windows(2) {
                let (a, b) = (clip.sample_pose(w[0]), clip.sample_pose(w[1]));
                let mid = clip.sample_pose(0.5 * (w[0] + w[1]));
                for bone in 0..a.len() {
                    let span = rotation_angle(a[bone].rotation, b[bone].rotation);
                    assert!(rotation_angle(a[bone].rotation, mid[bone].rotation) <= span + 1e-3);
                }
            }
        }
    }
}

// ---------- synthetic files ----------

/// Builds a small glTF with a data-URI buffer.
#[derive(Default)]
struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    fn accessor(
        &mut self,
        bytes: &[u8],
        count: usize,
        ty: &str,
        ct: u32,
        normalized: bool,
    ) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()}));
        self.bin.extend_from_slice(bytes);
        let mut a = json!({"bufferView": self.views.len() - 1, "count": count, "type": ty, "componentType": ct});
        if normalized {
            a["normalized"] = json!(true);
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    fn floats(&mut self, v: &[f32], ty: &str) -> usize {
        let dims = match ty {
            "SCALAR" => 1,
            "VEC3" => 3,
            "VEC4" => 4,
            _ => 16,
        };
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        self.accessor(&bytes, v.len() / dims, ty, 5126, false)
    }

    fn finish(self, mut doc: Value) -> Vec<u8> {
        let b64 = base64(&self.bin);
        doc["asset"] = json!({"version": "2.0"});
        doc["buffers"] = json!([{"byteLength": self.bin.len(), "uri": format!("data:application/octet-stream;base64,{b64}")}]);
        doc["bufferViews"] = Value::Array(self.views);
        doc["accessors"] = Value::Array(self.accessors);
        serde_json::to_vec(&doc).unwrap()
    }
}

fn base64(data: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in data.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for i in 0..4 {
            if i <= c.len() {
                s.push(A[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// Three nodes: 0 (armature, matrix transform) → 1 (joint) → 2 (joint); plus node 3 (a mesh
/// node, not in the skeleton). Animations cover STEP, LINEAR, CUBICSPLINE, normalised
/// rotations and a sparse accessor.
fn synthetic() -> (Builder, Value) {
    let mut b = Builder::default();
    let t2 = b.floats(&[0.0, 1.0], "SCALAR");
    let t3 = b.floats(&[0.0, 0.5, 1.0], "SCALAR");
    // STEP translation of joint 1.
    let step = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 2.0, 0.0, 0.0], "VEC3");
    // CUBICSPLINE scale of joint 2: (in, value, out) × 2 keys, value 1 → 3, zero tangents.
    let cubic = b.floats(
        &[
            0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 3.0, 3.0, 3.0, 0.0, 0.0,
            0.0,
        ],
        "VEC3",
    );
    // Normalised SHORT rotations of joint 2: identity → 90° about Z.
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let q: Vec<u8> = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, s, s]
        .iter()
        .flat_map(|&x: &f32| ((x * 32767.0).round() as i16).to_le_bytes())
        .collect();
    let rot = b.accessor(&q, 2, "VEC4", 5122, true);
    // Sparse: base translation keys all (0, 1, 0); key 1 replaced by (5, 1, 0).
    let base = b.floats(&[0.0, 1.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let idx = b.accessor(&[1u8, 0, 0, 0], 1, "SCALAR", 5121, false);
    let val = b.floats(&[5.0, 1.0, 0.0], "VEC3");
    let idx_view = b.accessors[idx]["bufferView"].clone();
    let val_view = b.accessors[val]["bufferView"].clone();
    b.accessors[base]["sparse"] = json!({"count": 1, "indices": {"bufferView": idx_view, "componentType": 5121},
        "values": {"bufferView": val_view}});
    let ibm: Vec<f32> = glam::Mat4::IDENTITY
        .to_cols_array()
        .iter()
        .chain(
            glam::Mat4::from_translation(Vec3::NEG_Y)
                .to_cols_array()
                .iter(),
        )
        .copied()
        .collect();
    let ibm = b.floats(&ibm, "MAT4");
    let m = glam::Mat4::from_translation(Vec3::new(0.0, 0.0, 2.0)).to_cols_array();
    let doc = json!({
        "scene": 0,
        "scenes": [{"nodes": [0, 3]}],
        "nodes": [
            {"name": "armature", "matrix": m, "children": [1]},
            {"name": "hip", "children": [2]},
            {"name": "spine", "translation": [0.0, 1.0, 0.0]},
            {"name": "mesh", "skin": 0, "translation": [9.0, 0.0, 0.0]}
        ],
        "skins": [{"joints": [1, 2], "inverseBindMatrices": ibm}, {"joints": [2]}],
        "animations": [
            {"name": "mixed",
             "samplers": [
                {"input": t3, "output": step, "interpolation": "STEP"},
                {"input": t2, "output": cubic, "interpolation": "CUBICSPLINE"},
                {"input": t2, "output": rot},
                {"input": t2, "output": base},
                {"input": t2, "output": base}
             ],
             "channels": [
                {"sampler": 0, "target": {"node": 1, "path": "translation"}},
                {"sampler": 1, "target": {"node": 2, "path": "scale"}},
                {"sampler": 2, "target": {"node": 2, "path": "rotation"}},
                {"sampler": 3, "target": {"node": 2, "path": "translation"}},
                {"sampler": 4, "target": {"node": 3, "path": "translation"}}
             ]}
        ]
    });
    (b, doc)
}

#[test]
fn synthetic_interpolations_and_accessors() {
    let (b, doc) = synthetic();
    let bytes = b.finish(doc);
    let rig = crate::build::import_slice(&bytes, None).unwrap();
    let sk = rig.skeleton();
    assert_eq!(sk.len(), 3);
    assert_eq!(sk.name(crate::BoneId::from_raw(0)), "armature");
    assert!(!sk.is_joint(crate::BoneId::from_raw(0)));
    assert_eq!(
        sk.rest(crate::BoneId::from_raw(0)).translation,
        Vec3::new(0.0, 0.0, 2.0)
    );
    assert_eq!(rig.skins().len(), 2);
    assert_eq!(rig.skins()[1].inverse_bind[0], glam::Mat4::IDENTITY);
    assert_eq!(rig.import_report().non_skeleton_channels, 1);
    let clip = &rig.clips()[0];
    let p = clip.sample_pose(0.75);
    // STEP holds key 1 in [0.5, 1).
    assert_eq!(p[1].translation, Vec3::X);
    // CUBICSPLINE with zero tangents: 1 + 2·smoothstep(0.75).
    let sm = 3.0 * 0.5625 - 2.0 * 0.421875;
    assert!((p[2].scale.x - (1.0 + 2.0 * sm)).abs() < 1e-5);
    // Normalised shorts decode to unit quaternions; interpolation is shortest path: 67.5°.
    assert!(
        rotation_angle(
            p[2].rotation,
            Quat::from_rotation_z(0.75 * std::f32::consts::FRAC_PI_2)
        ) < 1e-3
    );
    // Sparse substitution: key 1 is (5, 1, 0).
    assert!((p[2].translation - Vec3::new(3.75, 1.0, 0.0)).length() < 1e-5);
}

#[test]
fn external_buffer_needs_base_dir() {
    let (b, mut doc) = synthetic();
    let bin = b.bin.clone();
    let bytes = b.finish(doc.take());
    let mut doc: Value = serde_json::from_slice(&bytes).unwrap();
    doc["buffers"][0]["uri"] = json!("my%20rig.bin");
    let text = serde_json::to_vec(&doc).unwrap();
    let dir = std::env::temp_dir().join(format!("animlod-import-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("my rig.bin"), &bin).unwrap();
    std::fs::write(dir.join("rig.gltf"), &text).unwrap();
    assert!(matches!(
        crate::build::import_slice(&text, None),
        Err(ImportError::Buffer { .. })
    ));
    assert!(crate::build::import_path(&dir.join("rig.gltf")).is_ok());
    std::fs::remove_file(dir.join("my rig.bin")).unwrap();
    assert!(matches!(
        crate::build::import_path(&dir.join("rig.gltf")),
        Err(ImportError::Io { .. })
    ));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Applies `edit` to the synthetic document and imports it.
fn import_edited(edit: impl FnOnce(&mut Value)) -> Result<Rig, ImportError> {
    let (b, mut doc) = synthetic();
    let bytes = b.finish(doc.take());
    let mut doc: Value = serde_json::from_slice(&bytes).unwrap();
    edit(&mut doc);
    crate::build::import_slice(&serde_json::to_vec(&doc).unwrap(), None)
}

#[test]
fn malformed_documents_are_clear_errors() {
    use ImportError as E;
    type Case = (
        &'static str,
        Box<dyn FnOnce(&mut Value)>,
        fn(&ImportError) -> bool,
    );
    let cases: Vec<Case> = vec![
        ("no skin", Box::new(|d| d["skins"] = json!([])), |e| {
            matches!(e, E::NoSkin)
        }),
        (
            "bad child",
            Box::new(|d| d["nodes"][1]["children"] = json!([99])),
            |e| matches!(e, E::Hierarchy(_)),
        ),
        (
            "two parents",
            Box::new(|d| d["nodes"][0]["children"] = json!([1, 2])),
            |e| matches!(e, E::Hierarchy(_)),
        ),
        (
            "cycle",
            Box::new(|d| d["nodes"][2]["children"] = json!([0])),
            |e| matches!(e, E::Hierarchy(_)),
        ),
        (
            "bad joint",
            Box::new(|d| d["skins"][0]["joints"] = json!([1, 42])),
            |e| matches!(e, E::Skin { .. }),
        ),
        (
            "target node",
            Box::new(|d| d["animations"][0]["channels"][0]["target"]["node"] = json!(9999)),
            |e| matches!(e, E::Animation { .. }),
        ),
        (
            "sampler index",
            Box::new(|d| d["animations"][0]["channels"][0]["sampler"] = json!(77)),
            |e| matches!(e, E::Animation { .. }),
        ),
        (
            "u32 rotation",
            Box::new(|d| d["accessors"][4]["componentType"] = json!(5125)),
            |e| matches!(e, E::Accessor { .. }),
        ),
        (
            "unnormalized short rotation",
            Box::new(|d| d["accessors"][4]["normalized"] = json!(false)),
            |e| matches!(e, E::Accessor { .. }),
        ),
        (
            "wrong type",
            Box::new(|d| d["accessors"][2]["type"] = json!("VEC4")),
            |e| matches!(e, E::Accessor { .. }),
        ),
        (
            "count too large",
            Box::new(|d| d["accessors"][2]["count"] = json!(1000)),
            |e| matches!(e, E::Accessor { .. }),
        ),
        (
            "huge count",
            Box::new(|d| d["accessors"][2]["count"] = json!(1u64 << 40)),
            |e| matches!(e, E::Accessor { .. }),
        ),
        (
            "view offset",
            Box::new(|d| d["bufferViews"][2]["byteOffset"] = json!(1u64 << 33)),
            |e| matches!(e, E::Accessor { .. }),
        ),
        (
            "small stride",
            Box::new(|d| d["bufferViews"][2]["byteStride"] = json!(4)),
            |e| matches!(e, E::Accessor { .. }),
        ),
        (
            "missing view",
            Box::new(|d| d["accessors"][2]["bufferView"] = json!(500)),
            |e| matches!(e, E::Accessor { .. }),
        ),
        (
            "sparse index range",
            Box::new(|d| d["accessors"][5]["sparse"]["count"] = json!(3)),
            |e| matches!(e, E::Accessor { .. }),
        ),
        (
            "key count",
            Box::new(|d| d["animations"][0]["samplers"][0]["input"] = json!(0)),
            |e| matches!(e, E::Animation { .. }),
        ),
        (
            "times not increasing",
            Box::new(|d| d["animations"][0]["samplers"][2]["input"] = json!(8)),
            |e| matches!(e, E::Animation { .. } | E::Accessor { .. }),
        ),
        (
            "bad path",
            Box::new(|d| d["animations"][0]["channels"][0]["target"]["path"] = json!("colour")),
            |e| matches!(e, E::Json(_) | E::Animation { .. }),
        ),
        (
            "bad interpolation",
            Box::new(|d| d["animations"][0]["samplers"][0]["interpolation"] = json!("BOUNCY")),
            |e| matches!(e, E::Json(_) | E::Animation { .. }),
        ),
        (
            "required meshopt",
            Box::new(|d| d["extensionsRequired"] = json!(["EXT_meshopt_compression"])),
            |e| matches!(e, E::UnsupportedExtension(_)),
        ),
        (
            "bad base64",
            Box::new(|d| {
                d["buffers"][0]["uri"] = json!("data:application/octet-stream;base64,@@@");
            }),
            |e| matches!(e, E::Buffer { .. }),
        ),
        (
            "NaN matrix",
            Box::new(|d| d["nodes"][0]["matrix"][0] = json!(1e39)),
            |e| matches!(e, E::Hierarchy(_) | E::Json(_)),
        ),
        (
            "zero rotation",
            Box::new(|d| d["nodes"][2]["rotation"] = json!([0.0, 0.0, 0.0, 0.0])),
            |e| matches!(e, E::Hierarchy(_)),
        ),
    ];
    for (what, edit, ok) in cases {
        let e = import_edited(edit)
            .err()
            .unwrap_or_else(|| panic!("{what}: imported"));
        assert!(ok(&e), "{what}: {e}");
        assert!(!e.to_string().is_empty());
    }
    // Quantization required: stripped, imports fine.
    assert!(import_edited(|d| d["extensionsRequired"] = json!(["KHR_mesh_quantization"])).is_ok());
}

#[test]
fn nan_keys_are_refused() {
    let mut bytes = read("Fox.glb");
    // Overwrite the first float of the BIN chunk region used by animation outputs with NaN:
    // find the Walk clip's first output accessor and poison it.
    let (json, bin) = super::container::split(&bytes).unwrap();
    let doc: Value = serde_json::from_slice(json).unwrap();
    let bin_start = bin.unwrap().as_ptr() as usize - bytes.as_ptr() as usize;
    let out = doc["animations"][0]["samplers"][0]["output"]
        .as_u64()
        .unwrap() as usize;
    let view = doc["accessors"][out]["bufferView"].as_u64().unwrap() as usize;
    let off = doc["bufferViews"][view]["byteOffset"].as_u64().unwrap_or(0) as usize
        + doc["accessors"][out]["byteOffset"].as_u64().unwrap_or(0) as usize;
    bytes[bin_start + off..bin_start + off + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    let e = crate::build::import_slice(&bytes, None).unwrap_err();
    assert!(matches!(e, ImportError::Accessor { .. }), "{e}");
}

/// The project's seeded generator (PCG-64 MCG), 31 bits per draw.
struct Rng(rand_pcg::Pcg64Mcg);
impl Rng {
    fn new(seed: u64) -> Rng {
        Rng(rand_core::SeedableRng::seed_from_u64(seed))
    }
    fn next(&mut self) -> u64 {
        rand_core::RngCore::next_u64(&mut self.0) >> 33
    }
}

/// Any rig that loads yields finite bounds and finite model matrices at every time of every
/// clip (sampled at 17 times including both ends, through a crowd at full detail).
fn assert_finite_everywhere(rig: &Rig, ctx: &str) {
    let (centre, radius) = rig.bounds();
    assert!(
        centre.is_finite() && radius.is_finite(),
        "{ctx}: bounds {centre} {radius}"
    );
    let rig = std::sync::Arc::new(rig.clone());
    for (c, clip) in rig.clips().iter().enumerate() {
        let mut crowd = crate::Crowd::new(rig.clone());
        let id = crowd
            .add_character(Vec3::ZERO, crate::ClipId::new(c))
            .unwrap();
        let view =
            salience::View::look_at(Vec3::new(0.0, 1.0, 5.0), Vec3::ZERO, Vec3::Y, 1.0, 640, 480)
                .unwrap();
        let dt = clip.duration().max(1e-3) / 16.0;
        for k in 0..17 {
            if k > 0 {
                crowd.advance(dt, &view).unwrap();
            } else {
                crowd.advance(0.0, &view).unwrap();
            }
            let m = crowd.model_matrices(id).unwrap();
            assert!(
                m.iter().all(|m| m.is_finite()),
                "{ctx}: clip {c} at step {k}: non-finite model matrix"
            );
        }
    }
}

/// Single-byte flips of every real rig (several per rig): whatever loads is finite everywhere.
#[test]
fn byte_flipped_rigs_that_load_are_finite_everywhere() {
    let mut loaded = 0;
    for (name, ..) in RIGS {
        let bytes = read(name);
        assert_finite_everywhere(&crate::build::import_slice(&bytes, None).unwrap(), name);
        let mut rng = Rng::new(0xF11F ^ bytes.len() as u64);
        let tries = if bytes.len() > 1_000_000 { 8 } else { 40 };
        for i in 0..tries {
            let mut copy = bytes.clone();
            let at = rng.next() as usize % copy.len();
            copy[at] ^= 1 << (rng.next() % 8);
            match crate::build::import_slice(&copy, None) {
                Err(ImportError::Panicked(m)) => panic!("{name} flip {i}: panicked: {m}"),
                Err(_) => {}
                Ok(rig) => {
                    loaded += 1;
                    assert_finite_everywhere(&rig, &format!("{name} flip {i} at {at}"));
                }
            }
        }
    }
    assert!(loaded > 0, "some flips must still load");
}

/// A binary glTF (GLB) of `doc` (JSON chunk, padded to 4 bytes with spaces) and `bin`.
fn glb(doc: &Value, bin: &[u8]) -> Vec<u8> {
    let mut j = serde_json::to_vec(doc).unwrap();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&((12 + 8 + j.len() + 8 + bin.len()) as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x4E4F534Au32.to_le_bytes());
    out.extend_from_slice(&j);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x004E4942u32.to_le_bytes());
    out.extend_from_slice(bin);
    out
}

/// An accessor whose byte offset is not a multiple of its component size, and a rotation key
/// whose squared length overflows, are refused with an error naming the accessor.
#[test]
fn misaligned_accessors_and_overflowing_rotations_are_refused() {
    let bytes = read("Godot_PlatformerRobot.glb");
    let (json, bin) = super::container::split(&bytes).unwrap();
    let doc: Value = serde_json::from_slice(json).unwrap();
    let rebuild = glb;
    let bin = bin.unwrap();
    assert!(crate::build::import_slice(&rebuild(&doc, bin), None).is_ok());
    // The rotation output accessor of the first rotation channel.
    let anim = &doc["animations"][0];
    let channel = anim["channels"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["target"]["path"] == "rotation")
        .unwrap();
    let sampler = channel["sampler"].as_u64().unwrap() as usize;
    let acc = anim["samplers"][sampler]["output"].as_u64().unwrap() as usize;
    // Misaligned by 2 bytes (and one element shorter, so it still fits).
    let mut d = doc.clone();
    let off = d["accessors"][acc]["byteOffset"].as_u64().unwrap_or(0);
    d["accessors"][acc]["byteOffset"] = json!(off + 2);
    let n = d["accessors"][acc]["count"].as_u64().unwrap();
    d["accessors"][acc]["count"] = json!(n - 1);
    match crate::build::import_slice(&rebuild(&d, bin), None) {
        Err(ImportError::Accessor { index, reason }) => {
            assert_eq!(index, acc);
            assert!(
                reason.contains("multiple of the component size"),
                "{reason}"
            );
        }
        other => panic!("misaligned accessor: {other:?}"),
    }
    // A key component of 2e19: its squared length overflows f32.
    let view = doc["accessors"][acc]["bufferView"].as_u64().unwrap() as usize;
    let at = doc["bufferViews"][view]["byteOffset"].as_u64().unwrap_or(0) as usize + off as usize;
    let mut b = bin.to_vec();
    b[at..at + 4].copy_from_slice(&2.0e19f32.to_le_bytes());
    match crate::build::import_slice(&rebuild(&doc, &b), None) {
        Err(ImportError::Accessor { index, reason }) => {
            assert_eq!(index, acc);
            assert!(reason.contains("rotation key 0"), "{reason}");
        }
        other => panic!("overflowing rotation: {other:?}"),
    }
}

#[test]
fn truncated_copies_fail_cleanly() {
    for (name, ..) in RIGS {
        let bytes = read(name);
        let mut rng = Rng::new(name.len() as u64);
        let mut cuts: Vec<usize> = vec![0, 1, 4, 11, 12, 19, 20, bytes.len() / 2, bytes.len() - 1];
        cuts.extend((0..12).map(|_| rng.next() as usize % bytes.len()));
        for cut in cuts {
            let r = crate::build::import_slice(&bytes[..cut], None);
            match r {
                Err(ImportError::Panicked(m)) => panic!("{name} cut at {cut}: panicked: {m}"),
                Err(_) => {}
                Ok(_) => panic!("{name} cut at {cut}: imported a truncated file"),
            }
        }
    }
}

#[test]
fn corrupted_copies_never_panic() {
    // Random byte corruption in the JSON and binary parts of every rig: the import may succeed
    // (a changed key value is still a valid file) or fail, but never panics — not even a panic
    // caught by the importer's own guard, which would mean a check is missing.
    let mut outcomes = [0usize; 2];
    for (name, ..) in RIGS {
        let bytes = read(name);
        let (json, _) = super::container::split(&bytes).unwrap();
        let json_len = json.len();
        let mut rng = Rng::new(0x5EED ^ bytes.len() as u64);
        let tries = if bytes.len() > 1_000_000 { 6 } else { 30 };
        for i in 0..tries {
            let mut copy = bytes.clone();
            let in_json = i % 2 == 0;
            for _ in 0..1 + rng.next() % 8 {
                let at = if in_json || bytes.len() <= json_len + 20 {
                    (if name.ends_with(".glb") { 20 } else { 0 }) + rng.next() as usize % json_len
                } else {
                    20 + json_len + rng.next() as usize % (bytes.len() - json_len - 20)
                };
                copy[at] = (rng.next() & 0xFF) as u8;
            }
            match crate::build::import_slice(&copy, None) {
                Err(ImportError::Panicked(m)) => panic!("{name} try {i}: panicked: {m}"),
                Err(_) => outcomes[1] += 1,
                Ok(rig) => {
                    outcomes[0] += 1;
                    assert_finite_everywhere(&rig, &format!("{name} try {i}"));
                }
            }
        }
    }
    assert!(
        outcomes[1] > 0,
        "some corruptions must be detected: {outcomes:?}"
    );
}

#[test]
fn structurally_corrupted_real_file() {
    // Targeted edits of GDBot's real JSON: the cases DESIGN.md lists as reaching panics inside
    // gltf (bad channel targets, corrupted accessor indices, U32 rotations).
    let bytes = read("Godot_PlatformerRobot.glb");
    let (json, bin) = super::container::split(&bytes).unwrap();
    let doc: Value = serde_json::from_slice(json).unwrap();
    let rebuild = |doc: &Value| glb(doc, bin.unwrap());
    assert!(crate::build::import_slice(&rebuild(&doc), None).is_ok());
    let rot_sampler = doc["animations"][0]["channels"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["target"]["path"] == "rotation")
        .unwrap()["sampler"]
        .as_u64()
        .unwrap() as usize;
    let rot_out = doc["animations"][0]["samplers"][rot_sampler]["output"]
        .as_u64()
        .unwrap() as usize;
    type Edit = Box<dyn Fn(&mut Value)>;
    let mut edits: Vec<Edit> = vec![
        Box::new(|d| d["animations"][0]["channels"][3]["target"]["node"] = json!(100_000)),
        Box::new(|d| d["animations"][0]["samplers"][0]["input"] = json!(100_000)),
        Box::new(|d| d["animations"][0]["samplers"][0]["output"] = json!(-1)),
        Box::new(move |d| d["accessors"][rot_out]["componentType"] = json!(5125)),
        Box::new(|d| d["skins"][0]["inverseBindMatrices"] = json!(0)),
        Box::new(move |d| {
            let v = d["accessors"][rot_out]["bufferView"].as_u64().unwrap() as usize;
            d["bufferViews"][v]["buffer"] = json!(3);
        }),
        Box::new(|d| d["buffers"][0]["byteLength"] = json!(1u64 << 40)),
    ];
    for (i, edit) in edits.iter_mut().enumerate() {
        let mut d = doc.clone();
        edit(&mut d);
        match crate::build::import_slice(&rebuild(&d), None) {
            Err(ImportError::Panicked(m)) => panic!("edit {i} panicked: {m}"),
            Err(_) => {}
            Ok(_) => panic!("edit {i} imported"),
        }
    }
}
