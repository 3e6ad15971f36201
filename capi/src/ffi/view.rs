//! The world's view: the camera and light the host sets (once per frame, typically), kept by
//! the world as one [`salience::View`] and passed to every cloth's step and every crowd's
//! advance. Before the host sets a camera the world sees through [`View::default`].

use super::boundary::{arg, arg_mut, boundary};
use super::result::{FfiError, SlodResult};
use super::world::SlodWorld;
use glam::Vec3;
use salience::View;

/// The host's camera: a pinhole with a vertical field of view, a viewport in pixels and a near
/// plane. Plain data: the host fills every field (there is no default).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlodCamera {
    /// Eye position, world units.
    pub position: [f32; 3],
    /// Viewing direction (need not be unit length, must not be zero).
    pub forward: [f32; 3],
    /// Image up direction (not parallel to `forward`).
    pub up: [f32; 3],
    /// Vertical field of view in radians, in (0, π).
    pub fov_y_radians: f32,
    /// Viewport width in pixels (> 0).
    pub viewport_width: u32,
    /// Viewport height in pixels (> 0).
    pub viewport_height: u32,
    /// Near plane distance (> 0, finite): the crowd treats what is nearer as not visible.
    pub near_plane: f32,
}

/// Kind of light (values of `SlodLight::kind`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlodLightKind {
    /// No light: salience uses the animation features alone.
    None = 0,
    /// A directional light; `vector` points towards the light.
    Directional = 1,
    /// A point light; `vector` is its position.
    Point = 2,
}

/// The light the cloth salience multiplies by (Lambertian: `ambient + diffuse · max(0, n·l)`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlodLight {
    /// A `SlodLightKind` value.
    pub kind: u32,
    /// Direction towards the light (directional) or its position (point).
    pub vector: [f32; 3],
    /// Ambient term (finite, >= 0, ambient + diffuse <= 1; 0.2 is typical).
    pub ambient: f32,
    /// Diffuse term (finite, >= 0, ambient + diffuse <= 1; 0.8 is typical).
    pub diffuse: f32,
}

impl SlodCamera {
    /// The view this camera describes (keeping `light`), or an error naming the bad field.
    pub(crate) fn to_view(self, light: Option<salience::Light>) -> Result<View, FfiError> {
        let view = View::new(
            Vec3::from(self.position),
            Vec3::from(self.forward),
            Vec3::from(self.up),
            self.fov_y_radians,
            self.viewport_width,
            self.viewport_height,
        )
        .map_err(|e| FfiError::invalid("camera", e))?;
        let view = view
            .with_near(self.near_plane)
            .map_err(|e| FfiError::invalid("camera.near_plane", e))?;
        view.with_light(light)
            .map_err(|e| FfiError::invalid("light", e))
    }
}

impl SlodLight {
    /// The salience light (`None` for `SLOD_LIGHT_KIND_NONE`), or an error naming the bad field.
    pub(crate) fn to_salience(self) -> Result<Option<salience::Light>, FfiError> {
        let v = Vec3::from(self.vector);
        let light = match self.kind {
            0 => return Ok(None),
            1 => salience::Light::directional(v, self.ambient, self.diffuse),
            2 => salience::Light::point(v, self.ambient, self.diffuse),
            k => return Err(FfiError::invalid("light.kind", format!("unknown kind {k}"))),
        };
        light
            .validate()
            .map_err(|e| FfiError::invalid("light", e))?;
        Ok(Some(light))
    }
}

/// Sets the camera every cloth and crowd of the world sees from now on.
///
/// Until a host sets one, a world sees from the origin along −Z with +Y up, a 60° vertical
/// field of view, a 1920 × 1080 viewport and a 0.01 near plane. The light set by
/// `slod_world_set_light` stays.
///
/// Invalid values (NaN, zero viewport, field of view outside (0, π), zero or parallel
/// directions, near plane not > 0) return `SLOD_RESULT_INVALID_ARGUMENT` and the previous camera
/// stays. Cloths pick it up at their next `slod_cloth_step`, crowds at their next
/// `slod_crowd_advance`. Threads: mutates the world. The struct is copied; the host keeps it.
///
/// # Safety
/// `world` must be NULL or a live world used by no other thread; `camera` NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_world_set_camera(
    world: *mut SlodWorld,
    camera: *const SlodCamera,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        // SAFETY: caller contract: NULL or a valid camera.
        let camera = *unsafe { arg(camera, "camera") }?;
        world.view = camera.to_view(world.view.light().copied())?;
        Ok(())
    })
}

/// Sets (or with kind `SLOD_LIGHT_KIND_NONE` clears) the light cloth salience uses.
///
/// Invalid values (NaN, unknown kind, zero direction, negative terms, ambient + diffuse > 1)
/// return `SLOD_RESULT_INVALID_ARGUMENT` and the previous light stays. Cloths pick it up at
/// their next step. Threads: mutates the world. The struct is copied; the host keeps it.
///
/// # Safety
/// `world` must be NULL or a live world used by no other thread; `light` NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_world_set_light(
    world: *mut SlodWorld,
    light: *const SlodLight,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        // SAFETY: caller contract: NULL or a valid light.
        let light = *unsafe { arg(light, "light") }?;
        world.view = world
            .view
            .with_light(light.to_salience()?)
            .map_err(|e| FfiError::invalid("light", e))?;
        Ok(())
    })
}
