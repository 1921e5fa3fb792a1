//! Headless rendering of observer cameras ([`RenderPath`]): by the Rust renderer ([`raster`],
//! no GL at all), or by MuJoCo's renderer in an EGL context (Mesa's CPU rasteriser here),
//! full-frame or damage-limited — the reference the paper used.
//!
//! Both damage-limited paths keep each camera's last frame. Before drawing they compare the new
//! scene with the one the last frame was drawn from ([`crate::damage`]): nothing changed, the
//! frame is reused; some geoms moved under a still camera, only their rectangle is drawn again
//! (MuJoCo: a held GL scissor, [`offscreen::scissor`], and a read-back; Rust: only that
//! rectangle's pixels and the geoms reaching it); anything else, the whole frame is drawn. On
//! either renderer every frame equals its own full render, byte for byte.

use mujoco_rs::prelude::*;
use mujoco_rs::wrappers::mj_rendering::MjrRectangle;
use mujoco_rs::wrappers::mj_visualization::{MjvOption, MjvPerturb};
use offscreen::{GlRect, Offscreen};
use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX};

use crate::damage::{Snapshot, change};
use crate::mjcf::camera_name;
use crate::world::World;
pub use proto::RenderPath;
pub use proto::{FrameChange, PixelRect};
pub use raster::RENDERER_ID as RASTER_RENDERER_ID;

const W: usize = IMAGE_WIDTH_PX as usize;
const H: usize = IMAGE_HEIGHT_PX as usize;

/// Why rendering failed.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("could not create the EGL offscreen renderer: {0}")]
    Init(String),
    #[error("rendering failed: {0}")]
    Render(String),
    #[error("no camera for observer index {0}")]
    NoCamera(usize),
    #[error(transparent)]
    View(#[from] crate::raster_view::ViewError),
}

/// One rendered frame and how it differs from the same camera's previous frame.
#[derive(Debug, Clone, Copy)]
pub struct Rendered<'a> {
    /// Row-major RGB, top row first.
    pub rgb: &'a [u8],
    pub change: FrameChange,
}

/// How many renders took each route (for the benchmark and the camera's closing line).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RenderCounts {
    pub full: u64,
    pub damage: u64,
    pub skipped: u64,
    /// Pixels rasterised and read back by damage renders.
    pub damage_px: u64,
}

/// One camera's last frame and the scene it was drawn from.
struct Kept {
    rgb: Vec<u8>,
    snapshot: Option<Snapshot>,
}

/// Who draws the pixels.
enum Backend {
    /// MuJoCo's `mjr_render` in an EGL context; `scratch` holds read-back rows.
    Mujoco {
        offscreen: Offscreen,
        scratch: Vec<u8>,
    },
    /// The Rust renderer, over the model's meshes.
    Raster(raster::Renderer),
}

/// Renders any observer camera of one [`World`] into 640×480 RGB.
pub struct CameraRenderer {
    scene: MjvScene,
    backend: Backend,
    option: MjvOption,
    camera_ids: Vec<usize>,
    path: RenderPath,
    kept: Vec<Kept>,
    counts: RenderCounts,
    /// Applied to every scene the Rust renderer draws (tests break the renderer with it).
    edit: Option<fn(&mut raster::RasterScene)>,
}

impl CameraRenderer {
    /// Creates the offscreen context for `world`'s model; cameras render by `path`.
    pub fn new(world: &World, path: RenderPath) -> Result<Self, RenderError> {
        let model = world.model();
        let camera_ids = (0..world.observers())
            .map(|i| {
                model
                    .name_to_id(MjtObjBase::mjOBJ_CAMERA, &camera_name(i))
                    .ok_or(RenderError::NoCamera(i))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let backend = if path.is_mujoco() {
            let offscreen =
                Offscreen::new(model, u32::from(IMAGE_WIDTH_PX), u32::from(IMAGE_HEIGHT_PX))
                    .map_err(|e| RenderError::Init(e.to_string()))?;
            Backend::Mujoco {
                offscreen,
                scratch: Vec::new(),
            }
        } else {
            Backend::Raster(raster::Renderer::new(crate::raster_view::meshes(model)?))
        };
        // The model's geoms plus MuJoCo's usual headroom for decorations.
        let scene = MjvScene::new(model, model.ffi().ngeom as usize + 100);
        let kept = camera_ids
            .iter()
            .map(|_| Kept {
                rgb: vec![0; W * H * 3],
                snapshot: None,
            })
            .collect();
        Ok(Self {
            scene,
            backend,
            option: MjvOption::default(),
            camera_ids,
            path,
            kept,
            counts: RenderCounts::default(),
            edit: None,
        })
    }

    pub fn path(&self) -> RenderPath {
        self.path
    }

    pub fn counts(&self) -> RenderCounts {
        self.counts
    }

    /// The Rust renderer draws every mesh at this level of detail (0: the full mesh), or by its
    /// projected size with `None` (the default); MuJoCo's paths always draw full meshes.
    pub fn force_level_of_detail(&mut self, level: Option<usize>) {
        if let Backend::Raster(r) = &mut self.backend {
            r.force_level(level);
        }
    }

    /// Every scene the Rust renderer draws is first passed through `edit` (the reference
    /// comparison's tests build broken renderers with it); `None` draws scenes as they are.
    pub fn edit_raster_scene(&mut self, edit: Option<fn(&mut raster::RasterScene)>) {
        self.edit = edit;
    }

    /// What the Rust renderer has drawn so far; `None` on MuJoCo's paths.
    pub fn raster_stats(&self) -> Option<raster::RenderStats> {
        match &self.backend {
            Backend::Raster(r) => Some(r.total()),
            Backend::Mujoco { .. } => None,
        }
    }

    /// The level-of-detail meshes' digest ([`raster::MeshLods::digest`]); `None` on MuJoCo's
    /// paths.
    pub fn mesh_digest(&self) -> Option<u64> {
        match &self.backend {
            Backend::Raster(r) => Some(raster::MeshLods::digest(r.meshes())),
            Backend::Mujoco { .. } => None,
        }
    }

    /// Draws the observers' own airframes too (hidden by default: they are never in another
    /// observer's view, see [`crate::mjcf::OBSERVER_GEOM_GROUP`]).
    pub fn show_observers(&mut self, show: bool) {
        self.option.geomgroup[crate::mjcf::OBSERVER_GEOM_GROUP] = u8::from(show);
    }

    /// Renders observer `i`'s view of the current state; returns row-major RGB, top row first.
    pub fn render(&mut self, world: &mut World, observer: usize) -> Result<&[u8], RenderError> {
        Ok(self.render_change(world, observer)?.rgb)
    }

    /// Renders observer `i`'s view and says which pixels can differ from its previous frame.
    pub fn render_change(
        &mut self,
        world: &mut World,
        observer: usize,
    ) -> Result<Rendered<'_>, RenderError> {
        let cam = *self
            .camera_ids
            .get(observer)
            .ok_or(RenderError::NoCamera(observer))?;
        let mut camera = MjvCamera::new_fixed(cam);
        self.scene.update(
            world.data_mut(),
            &self.option,
            &MjvPerturb::default(),
            &mut camera,
        );
        let cameras = self.scene.ffi().camera.clone();
        let snapshot = Snapshot::new(
            cameras.clone(),
            offscreen::scene::lights(&self.scene),
            offscreen::scene::geoms(&self.scene),
        );
        let kept = &mut self.kept[observer];
        let change = match self.path {
            RenderPath::Full => FrameChange::All,
            RenderPath::Damage | RenderPath::Raster => {
                change(kept.snapshot.as_ref(), &snapshot, W as u16, H as u16)
            }
        };
        match change {
            FrameChange::Nothing => self.counts.skipped += 1,
            FrameChange::All => self.counts.full += 1,
            FrameChange::Within(r) => {
                self.counts.damage += 1;
                self.counts.damage_px += r.area_px() as u64;
            }
        }
        match &mut self.backend {
            Backend::Mujoco { offscreen, scratch } => {
                draw_mujoco(&mut self.scene, offscreen, scratch, &mut kept.rgb, change)?;
            }
            Backend::Raster(renderer) => {
                let rect = match change {
                    FrameChange::Nothing => None,
                    FrameChange::All => Some(raster::Rect::full(W as u16, H as u16)),
                    FrameChange::Within(r) => Some(raster::Rect {
                        x: r.x,
                        y: r.y,
                        width: r.width,
                        height: r.height,
                    }),
                };
                if let Some(rect) = rect {
                    let mut scene = crate::raster_view::scene(
                        &cameras,
                        offscreen::scene::lights(&self.scene),
                        offscreen::scene::geoms(&self.scene),
                        W as u16,
                        H as u16,
                    )?;
                    if let Some(edit) = self.edit {
                        edit(&mut scene);
                    }
                    renderer
                        .render(&scene, rect, &mut kept.rgb)
                        .map_err(|e| RenderError::Render(e.to_string()))?;
                }
            }
        }
        kept.snapshot = Some(snapshot);
        Ok(Rendered {
            rgb: &kept.rgb,
            change,
        })
    }
}

/// Draws `change` of the current scene with MuJoCo's renderer into the kept frame `rgb`.
fn draw_mujoco(
    scene: &mut MjvScene,
    offscreen: &Offscreen,
    scratch: &mut Vec<u8>,
    rgb: &mut [u8],
    change: FrameChange,
) -> Result<(), RenderError> {
    offscreen
        .make_current()
        .map_err(|e| RenderError::Render(e.to_string()))?;
    let full = MjrRectangle::new(0, 0, W as i32, H as i32);
    match change {
        FrameChange::Nothing => {}
        FrameChange::All => {
            scene.render(&full, offscreen.mjr());
            read(offscreen, scratch, full)?;
            paste(scratch, rgb, full);
        }
        FrameChange::Within(r) => {
            let gl = GlRect {
                left: i32::from(r.x),
                bottom: (H - usize::from(r.y) - usize::from(r.height)) as i32,
                width: i32::from(r.width),
                height: i32::from(r.height),
            };
            let mjr = offscreen.mjr();
            offscreen::scissor::hold(gl, || scene.render(&full, mjr));
            let rect = MjrRectangle::new(gl.left, gl.bottom, gl.width, gl.height);
            read(offscreen, scratch, rect)?;
            paste(scratch, rgb, rect);
        }
    }
    Ok(())
}

/// Whether damage renders rasterise only their rectangle in this process (MuJoCo's GL loader
/// came through `offscreen`'s scissor hold); if not, they rasterise everything and still read
/// back only the rectangle, with the same bytes.
pub fn scissor_interposed() -> bool {
    offscreen::scissor::is_interposed()
}

/// Reads `rect` of the offscreen buffer into `out` (bottom row first, as GL stores it).
fn read(offscreen: &Offscreen, out: &mut Vec<u8>, rect: MjrRectangle) -> Result<(), RenderError> {
    out.resize(rect.width as usize * rect.height as usize * 3, 0);
    offscreen
        .mjr()
        .read_pixels(Some(out), None, &rect)
        .map_err(|e| RenderError::Render(e.to_string()))
}

/// Copies GL rows of `rect` (bottom first) into the top-first frame `rgb`.
fn paste(rows: &[u8], rgb: &mut [u8], rect: MjrRectangle) {
    let row_bytes = rect.width as usize * 3;
    for (k, row) in rows.chunks_exact(row_bytes).enumerate() {
        let y = H - 1 - (rect.bottom as usize + k);
        let start = (y * W + rect.left as usize) * 3;
        rgb[start..start + row_bytes].copy_from_slice(row);
    }
}
