//! CPU skinning of GDBot's mesh (scaled to 1.8 m, its walk, 8 characters at spread phases) per
//! frame: every vertex with the exact palette (`full/`), and with held joints within 1 px at
//! every vertex (`held_1px/`, `animlod::SkinHoldJob`), the characters 5, 50 and 150 m in front
//! of a 1080-px-high camera, and with shared poses within 1 px (`shared_1px/`,
//! `animlod::PoseShare`: each character's phase bucket, prepared for all, held joints for the
//! characters too near to share; after warm-up the 256 kept poses cover the buckets the looping
//! clip visits, so a shared frame costs the lookups: 8 characters at 50 m measured 1.6 µs
//! against 170 µs with held joints and 517 µs in full). Each iteration advances the crowd one
//! 60 Hz frame, writes the palettes and skins; throughput is in vertices of the mesh (skinned,
//! held or shared).
use std::path::PathBuf;
use std::sync::Arc;

use animlod::{
    CharacterId, Crowd, HeldSkin, LodMode, PoseShare, Rig, SkinHoldJob, SkinHoldLayout, SkinningJob,
};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::{Mat4, Vec3};
use slod_experiments::crowd_large::{LargeSetup, metric_rig};

const CHARACTERS: usize = 8;

fn gdbot() -> Arc<Rig> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets/gltf/GDQuest_GDBot.glb");
    let base = animlod::build::import_path(&path).expect("asset");
    Arc::new(metric_rig(&base).expect("rig"))
}

fn crowd(rig: &Arc<Rig>, distance: f32) -> Crowd {
    let clip = rig.clip_by_name("walk").expect("walk");
    let duration = rig.clip(clip).unwrap().duration();
    let mut c = Crowd::new(rig.clone());
    for i in 0..CHARACTERS {
        let x = (i as f32 - CHARACTERS as f32 / 2.0) * 0.02 * distance;
        let id = c.add_character(Vec3::new(x, 0.0, -distance), clip).unwrap();
        c.set_time(id, duration * i as f32 / CHARACTERS as f32)
            .unwrap();
    }
    c.set_lod(LodMode::Off).unwrap();
    c
}

/// Skins a character's first mesh with held joints within 1 px.
fn skin_held_1px(
    crowd: &Crowd,
    id: CharacterId,
    layout: &SkinHoldLayout,
    palette: &mut [Mat4],
    state: &mut HeldSkin,
    positions: &mut [Vec3],
    normals: &mut [Vec3],
) {
    let mesh = &crowd.rig().meshes()[0];
    crowd.skinning_matrices(id, mesh.skin, palette).unwrap();
    let ppu = crowd.pixels_per_unit(id).unwrap();
    SkinHoldJob {
        mesh,
        layout,
        palette,
        tolerance: if ppu > 0.0 { 1.0 / ppu } else { f32::INFINITY },
        predict: false,
        state,
        positions,
        normals,
    }
    .run()
    .unwrap();
}

fn bench(c: &mut Criterion) {
    let rig = gdbot();
    let mesh = &rig.meshes()[0];
    let joints = rig.skin(mesh.skin).unwrap().joints.len();
    let layout = SkinHoldLayout::new(mesh, joints).unwrap();
    let n = mesh.vertex_count();
    let view = LargeSetup::new(1).view().unwrap();
    let mut g = c.benchmark_group("skin");
    g.throughput(Throughput::Elements((CHARACTERS * n) as u64));
    for distance in [5.0f32, 50.0, 150.0] {
        let mut palette = vec![Mat4::IDENTITY; joints];
        let mut out = vec![(vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]); CHARACTERS];
        let mut full = crowd(&rig, distance);
        g.bench_function(format!("full/{distance}m"), |b| {
            b.iter(|| {
                full.advance(1.0 / 60.0, &view).unwrap();
                let ids: Vec<_> = full.character_ids().collect();
                for (id, (p, q)) in ids.into_iter().zip(&mut out) {
                    full.skinning_matrices(id, mesh.skin, &mut palette).unwrap();
                    SkinningJob {
                        mesh,
                        palette: &palette,
                        positions: p,
                        normals: q,
                    }
                    .run()
                    .unwrap();
                }
            });
        });
        let mut held = crowd(&rig, distance);
        let mut states: Vec<HeldSkin> = (0..CHARACTERS).map(|_| HeldSkin::new(&layout)).collect();
        g.bench_function(format!("held_1px/{distance}m"), |b| {
            b.iter(|| {
                held.advance(1.0 / 60.0, &view).unwrap();
                let ids: Vec<_> = held.character_ids().collect();
                for ((id, (p, q)), state) in ids.into_iter().zip(&mut out).zip(&mut states) {
                    skin_held_1px(&held, id, &layout, &mut palette, state, p, q);
                }
            });
        });
        let mut shared = crowd(&rig, distance);
        let mut share = PoseShare::new(rig.clone(), 256, false).unwrap();
        let mut states: Vec<HeldSkin> = (0..CHARACTERS).map(|_| HeldSkin::new(&layout)).collect();
        g.bench_function(format!("shared_1px/{distance}m"), |b| {
            b.iter(|| {
                shared.advance(1.0 / 60.0, &view).unwrap();
                let ids: Vec<_> = shared.character_ids().collect();
                let mut poses: Vec<_> = ids
                    .iter()
                    .map(|&id| {
                        let ppu = shared.pixels_per_unit(id).unwrap();
                        let tol = if ppu > 0.0 { 1.0 / ppu } else { f32::INFINITY };
                        let (clip, t) = (shared.clip(id).unwrap(), shared.time(id).unwrap());
                        share.pose_for(clip, t, tol).unwrap()
                    })
                    .collect();
                share.keep_worthwhile(&mut poses);
                let used: Vec<_> = poses.iter().flatten().copied().collect();
                share.prepare(&used).unwrap();
                for (((&id, pose), (p, q)), state) in
                    ids.iter().zip(&poses).zip(&mut out).zip(&mut states)
                {
                    shared.set_pose_shared(id, pose.is_some()).unwrap();
                    if pose.is_some() {
                        state.reset();
                        continue;
                    }
                    skin_held_1px(&shared, id, &layout, &mut palette, state, p, q);
                }
            });
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
