//! A deterministic CPU renderer for Waggle's observer cameras.
//!
//! It draws what MuJoCo's fixed-function renderer draws for Waggle's scenes — planes, boxes and
//! triangle meshes, opaque, lit per vertex by directional lights with no specular term — and it
//! draws only what a frame needs: the pixels of one rectangle (the damage rectangle of a still
//! camera), and only the triangles of the bodies whose bounding spheres reach it, at a level of
//! detail chosen from each body's projected size.
//!
//! The output is the same bytes on any machine: geometry is transformed in `f64` with only
//! `+ − × ÷ √` (IEEE-exact, no contraction in Rust), screen positions are snapped to 1/256 px and
//! coverage is decided by integer edge functions with a top-left rule, and nothing depends on
//! threads or CPU features. The level-of-detail meshes come from meshoptimizer, once per model;
//! [`MeshLods::digest`] names their bytes so that a cache keyed on it never mixes two builds.
//!
//! - [`scene`]: the input (camera, lights, instances) — plain data, no MuJoCo.
//! - [`mesh`]: triangle meshes and their simplified levels.
//! - [`clip`]: camera-space clipping (near plane and a guard band).
//! - [`fill`]: the fixed-point triangle rasteriser into a rectangle.
//! - [`render`]: the frame: culling, level choice, lighting, drawing.

pub mod clip;
pub mod fill;
pub mod mesh;
pub mod render;
pub mod scene;

pub use mesh::{Mesh, MeshError, MeshLods};
pub use render::{RenderStats, Renderer};
pub use scene::{Camera, Instance, Light, RasterScene, Rect, Shape};

/// The renderer's name in cache keys and provenance; bumped whenever its bytes may change.
pub const RENDERER_ID: &str = "waggle-raster/1";
