//! A headless EGL context (Mesa's software device here) holding MuJoCo's `mjrContext`.

use std::num::NonZeroU32;

use glutin::api::egl::context::PossiblyCurrentContext;
use glutin::api::egl::device::Device;
use glutin::api::egl::display::Display;
use glutin::api::egl::surface::Surface;
use glutin::config::{ConfigSurfaceTypes, ConfigTemplateBuilder};
use glutin::context::{ContextApi, ContextAttributesBuilder, GlProfile, Version};
use glutin::prelude::{GlDisplay, NotCurrentGlContext, PossiblyCurrentGlContext};
use glutin::surface::{PbufferSurface, SurfaceAttributesBuilder};
use mujoco_rs::prelude::*;
use mujoco_rs::wrappers::mj_rendering::MjrContext;

/// Why no offscreen context could be made.
#[derive(Debug, thiserror::Error)]
pub enum OffscreenError {
    #[error("image size {width}×{height} has a zero side")]
    ZeroSize { width: u32, height: u32 },
    #[error("no EGL device opened an OpenGL context: {0}")]
    NoDevice(String),
    #[error("could not make the EGL context current: {0}")]
    MakeCurrent(String),
}

/// An EGL pbuffer context with MuJoCo's rendering context created in it and set to draw into
/// MuJoCo's offscreen framebuffer.
pub struct Offscreen {
    // Field order is drop order: MuJoCo's GL objects go before the context that owns them.
    mjr: MjrContext,
    surface: Surface<PbufferSurface>,
    context: PossiblyCurrentContext,
}

impl std::fmt::Debug for Offscreen {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Offscreen").finish_non_exhaustive()
    }
}

impl Offscreen {
    /// Opens a context on the first EGL device that gives one and creates MuJoCo's rendering
    /// context for `model` in it (its offscreen buffer is the model's `offwidth`×`offheight`).
    pub fn new(model: &MjModel, width: u32, height: u32) -> Result<Self, OffscreenError> {
        crate::scissor::keep_linked();
        let size = NonZeroU32::new(width)
            .zip(NonZeroU32::new(height))
            .ok_or(OffscreenError::ZeroSize { width, height })?;
        let devices =
            Device::query_devices().map_err(|e| OffscreenError::NoDevice(e.to_string()))?;
        let mut failures = Vec::new();
        for device in devices {
            match open(&device, size) {
                Ok((context, surface)) => {
                    // SAFETY: `open` returned the context current on this thread.
                    let mut mjr = unsafe { MjrContext::new(model) };
                    mjr.offscreen();
                    return Ok(Self {
                        mjr,
                        surface,
                        context,
                    });
                }
                Err(e) => failures.push(e.to_string()),
            }
        }
        Err(OffscreenError::NoDevice(if failures.is_empty() {
            "no EGL devices".to_owned()
        } else {
            failures.join("; ")
        }))
    }

    /// Makes this context current on the calling thread (before any GL work through it).
    pub fn make_current(&self) -> Result<(), OffscreenError> {
        self.context
            .make_current(&self.surface)
            .map_err(|e| OffscreenError::MakeCurrent(e.to_string()))
    }

    /// MuJoCo's rendering context (valid while this context is current).
    pub fn mjr(&self) -> &MjrContext {
        &self.mjr
    }
}

impl Drop for Offscreen {
    fn drop(&mut self) {
        // `mjr_freeContext` deletes GL objects of whatever context is current.
        let _ = self.make_current();
    }
}

/// A compatibility-profile GL 2.0 context (what MuJoCo's fixed-function renderer needs) on a
/// pbuffer of `size`, made current.
fn open(
    device: &Device,
    (width, height): (NonZeroU32, NonZeroU32),
) -> glutin::error::Result<(PossiblyCurrentContext, Surface<PbufferSurface>)> {
    // SAFETY: `device` came from `Device::query_devices`; no native display is involved.
    let display = unsafe { Display::with_device(device, None)? };
    let template = ConfigTemplateBuilder::new()
        .with_surface_type(ConfigSurfaceTypes::PBUFFER)
        .with_alpha_size(0)
        .with_depth_size(24)
        .with_stencil_size(8)
        .build();
    // SAFETY: the template only asks for standard attributes of a valid display.
    let config = unsafe { display.find_configs(template)? }
        .next()
        .ok_or(glutin::error::ErrorKind::NotSupported("no pbuffer config"))?;
    let attributes = ContextAttributesBuilder::new()
        .with_profile(GlProfile::Compatibility)
        .with_context_api(ContextApi::OpenGl(Some(Version::new(2, 0))))
        .build(None);
    // SAFETY: `config` belongs to `display`; the attributes name a profile EGL validates.
    let context = unsafe { display.create_context(&config, &attributes)? };
    let surface_attributes = SurfaceAttributesBuilder::<PbufferSurface>::new().build(width, height);
    // SAFETY: `config` belongs to `display` and the size is non-zero.
    let surface = unsafe { display.create_pbuffer_surface(&config, &surface_attributes)? };
    let context = context.make_current(&surface)?;
    Ok((context, surface))
}
