//! Read-only access to what `mjv_updateScene` produced.

use mujoco_rs::prelude::*;
use mujoco_rs::wrappers::mj_visualization::{MjvGeom, MjvLight};

/// The scene's geoms, in the order `mjr_render` draws opaque geoms.
pub fn geoms(scene: &MjvScene) -> &[MjvGeom] {
    let ffi = scene.ffi();
    let n = usize::try_from(ffi.ngeom).unwrap_or(0);
    if n == 0 || ffi.geoms.is_null() {
        return &[];
    }
    // SAFETY: `mjv_updateScene` keeps `geoms` pointing at `maxgeom` initialised entries of which
    // the first `ngeom` are in use; the slice borrows `scene`, so the array outlives it and no
    // `&mut` update can run meanwhile.
    unsafe {
        std::slice::from_raw_parts(ffi.geoms, n.min(usize::try_from(ffi.maxgeom).unwrap_or(0)))
    }
}

/// The scene's lights in use (the headlight first when it is on).
pub fn lights(scene: &MjvScene) -> &[MjvLight] {
    let ffi = scene.ffi();
    let n = usize::try_from(ffi.nlight)
        .unwrap_or(0)
        .min(ffi.lights.len());
    &ffi.lights[..n]
}
