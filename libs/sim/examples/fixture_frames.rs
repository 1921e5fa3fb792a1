//! Writes a short sequence of 100 Hz renders of O1's view while the performer accelerates
//! sideways and back — test fixtures for the event converter.
//! `cargo run -p sim --example fixture_frames -- OUT_DIR [FRAMES]`

use sim::control::Reference;
use sim::render::CameraRenderer;
use sim::world::World;

fn main() -> anyhow::Result<()> {
    let out = std::path::PathBuf::from(
        std::env::args()
            .nth(1)
            .ok_or_else(|| anyhow::anyhow!("usage: OUT_DIR [FRAMES]"))?,
    );
    let frames: u64 = std::env::args()
        .nth(2)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(16);
    std::fs::create_dir_all(&out)?;
    let mut world = World::new(3)?;
    let mut renderer = CameraRenderer::new(&world, sim::render::RenderPath::Full)?;
    let hover = proto::scene::PERFORMER_HOVER_M;
    for k in 0..frames {
        let t_ns = k * 10_000_000;
        world.step_until(t_ns);
        let phase = (t_ns as f64 * 1e-9) * std::f64::consts::TAU;
        world.set_reference(
            0,
            Reference::hover(
                [
                    hover[0] + 0.15 * phase.sin(),
                    hover[1],
                    hover[2] + 0.05 * (2.0 * phase).sin(),
                ],
                0.0,
            ),
        );
        let rgb = renderer.render(&mut world, 0)?.to_vec();
        image::save_buffer_with_format(
            out.join(format!("frame_{k:04}.png")),
            &rgb,
            640,
            480,
            image::ExtendedColorType::Rgb8,
            image::ImageFormat::Png,
        )?;
    }
    Ok(())
}
