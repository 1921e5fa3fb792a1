//! Headless rendering of observer cameras through MuJoCo's EGL offscreen renderer.

use mujoco_rs::prelude::*;
use mujoco_rs::renderer::MjRenderer;
use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX};

use crate::mjcf::camera_name;
use crate::world::World;

/// Why rendering failed.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("could not create the EGL offscreen renderer: {0}")]
    Init(String),
    #[error("rendering failed: {0}")]
    Render(String),
    #[error("no camera for observer index {0}")]
    NoCamera(usize),
}

/// Renders any observer camera of one [`World`] into 640×480 RGB.
pub struct CameraRenderer {
    renderer: MjRenderer,
    camera_ids: Vec<usize>,
}

impl CameraRenderer {
    /// Creates the offscreen context for `world`'s model.
    pub fn new(world: &World) -> Result<Self, RenderError> {
        let model = world.model();
        let camera_ids = (0..world.observers())
            .map(|i| {
                model
                    .name_to_id(MjtObjBase::mjOBJ_CAMERA, &camera_name(i))
                    .ok_or(RenderError::NoCamera(i))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let renderer = MjRenderer::builder()
            .width(u32::from(IMAGE_WIDTH_PX))
            .height(u32::from(IMAGE_HEIGHT_PX))
            .build(model)
            .map_err(|e| RenderError::Init(format!("{e} ({e:?})")))?;
        Ok(Self {
            renderer,
            camera_ids,
        })
    }

    /// Draws the observers' own airframes too (hidden by default: they are never in another
    /// observer's view, see [`crate::mjcf::OBSERVER_GEOM_GROUP`]).
    pub fn show_observers(&mut self, show: bool) {
        self.renderer.opts_mut().geomgroup[crate::mjcf::OBSERVER_GEOM_GROUP] = u8::from(show);
    }

    /// Renders observer `i`'s view of the current state; returns row-major RGB, top row first.
    pub fn render(&mut self, world: &mut World, observer: usize) -> Result<&[u8], RenderError> {
        let cam = *self
            .camera_ids
            .get(observer)
            .ok_or(RenderError::NoCamera(observer))?;
        self.renderer.set_camera(MjvCamera::new_fixed(cam));
        self.renderer
            .sync_data(world.data_mut())
            .map_err(|e| RenderError::Render(e.to_string()))?;
        self.renderer
            .render()
            .map_err(|e| RenderError::Render(e.to_string()))?;
        self.renderer
            .rgb_flat()
            .ok_or_else(|| RenderError::Render("RGB output disabled".into()))
    }
}
