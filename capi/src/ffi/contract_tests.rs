//! The header's documented limits are the checked ones, and the error names the argument at
//! fault (spacing, grid extent, gravity length, optional crowd statistics).

use super::*;

fn last() -> String {
    let mut buf = [0 as std::ffi::c_char; 512];
    let mut n = 0;
    // SAFETY: `buf` is valid for its length, `n` for a write.
    unsafe { slod_last_error(buf.as_mut_ptr(), buf.len(), &mut n) };
    // SAFETY: slod_last_error NUL-terminates within `buf`.
    unsafe { std::ffi::CStr::from_ptr(buf.as_ptr()) }
        .to_string_lossy()
        .into_owned()
}

struct World(*mut SlodWorld);
impl World {
    fn new() -> World {
        let mut w = std::ptr::null_mut();
        // SAFETY: valid desc and out pointer.
        let r = unsafe { slod_world_create(&slod_default_world_desc(), &mut w) };
        assert_eq!(r, SlodResult::Ok);
        World(w)
    }
    fn grid(&self, desc: &SlodClothDesc) -> (SlodResult, String) {
        let mut id = SlodClothId::default();
        // SAFETY: live world, valid desc and out pointer.
        let r = unsafe { slod_cloth_create_grid(self.0, desc, &mut id) };
        (r, last())
    }
}
impl Drop for World {
    fn drop(&mut self) {
        // SAFETY: created by slod_world_create, destroyed once.
        unsafe { slod_world_destroy(self.0) };
    }
}

#[test]
fn grid_limits_are_the_documented_ones() {
    let w = World::new();
    let small = SlodClothDesc {
        columns: 5,
        rows: 5,
        ..slod_default_cloth_desc()
    };
    // The documented spacing range [1e-6, 1e4]: both ends accepted, outside refused naming it.
    for spacing in [1.0e-6, 1.0e4] {
        let (r, msg) = w.grid(&SlodClothDesc { spacing, ..small });
        assert_eq!(r, SlodResult::Ok, "spacing {spacing}: {msg}");
    }
    for spacing in [1.0e-12, 0.0, 2.0e4, f32::NAN] {
        let (r, msg) = w.grid(&SlodClothDesc { spacing, ..small });
        assert_eq!(r, SlodResult::InvalidArgument, "spacing {spacing}");
        assert!(msg.contains("desc.spacing"), "spacing {spacing}: {msg}");
    }
    // A grid reaching beyond ±SLOD_MAX_COORDINATE is refused (400 × 1e4 m = 4e6 m).
    let (r, msg) = w.grid(&SlodClothDesc {
        columns: 400,
        rows: 2,
        spacing: 1.0e4,
        ..small
    });
    assert_eq!(r, SlodResult::InvalidArgument);
    assert!(msg.contains("desc.spacing"), "{msg}");
    // Gravity is limited by its length, not per component.
    let mut d = small;
    d.solver.gravity = [8.0e3, 8.0e3, 0.0];
    let (r, msg) = w.grid(&d);
    assert_eq!(r, SlodResult::InvalidArgument);
    assert!(msg.contains("desc.solver.gravity"), "{msg}");
    d.solver.gravity = [0.0, -9.999e3, 0.0];
    assert_eq!(w.grid(&d).0, SlodResult::Ok);
}

#[test]
fn crowd_statistics_are_optional() {
    let w = World::new();
    let bytes = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../assets/gltf/GDQuest_GDBot.glb"
    ))
    .unwrap();
    let (mut rig, mut crowd) = (SlodRigId::default(), SlodCrowdId::default());
    // SAFETY: live world; valid buffers and out pointers throughout.
    unsafe {
        assert_eq!(
            slod_rig_load_memory(w.0, bytes.as_ptr(), bytes.len(), &mut rig),
            SlodResult::Ok
        );
        assert_eq!(
            slod_crowd_create(w.0, rig, &slod_default_crowd_desc(), &mut crowd),
            SlodResult::Ok
        );
        assert_eq!(
            slod_crowd_advance(w.0, crowd, 0.016, std::ptr::null_mut()),
            SlodResult::Ok,
            "{}",
            last()
        );
    }
}
