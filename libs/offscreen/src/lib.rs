//! The one place in Waggle with raw GL/EGL (every `unsafe` here carries its justification).
//!
//! - [`context`]: a headless EGL context with MuJoCo's rendering context (`mjrContext`) in it,
//!   which the caller can make current again, so several renderers can share a thread.
//! - [`scissor`]: holds a GL scissor rectangle across `mjr_render`. MuJoCo's renderer sets the
//!   scissor to the whole viewport for its clear and then disables the scissor test, so a caller
//!   cannot limit rasterisation to a damage rectangle with MuJoCo's own API. MuJoCo loads its GL
//!   functions through the process's global `eglGetProcAddress`; this crate exports that symbol
//!   (the shared build script adds `--export-dynamic-symbol`), answers `glScissor` and
//!   `glDisable` with two thin wrappers, and forwards every other name to the real EGL. Outside a
//!   hold the wrappers forward unchanged.
//! - [`scene`]: read-only views of an `mjvScene`'s geoms (a raw array in the C struct).
//!
//! If the loader is not interposed (a binary linked without the export), a hold changes nothing
//! and MuJoCo rasterises the whole frame: pixels read back from the rectangle are the same, only
//! slower. [`scissor::is_interposed`] says which case applies.

pub mod context;
pub mod scene;
pub mod scissor;

pub use context::{Offscreen, OffscreenError};
pub use scissor::GlRect;
