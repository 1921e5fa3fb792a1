//! Renders observer cameras of the nominal formation with both renderers and prints, per view,
//! the grey levels of floor, wall and performer and the performer's silhouette IoU; writes the
//! frames as PNGs into the directory given (default: none).
//! `cargo run --release -p sim --example compare_renderers [OUT_DIR]`

use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX};
use sim::render::{CameraRenderer, RenderPath};
use sim::world::World;

const W: usize = IMAGE_WIDTH_PX as usize;
const H: usize = IMAGE_HEIGHT_PX as usize;

fn main() -> anyhow::Result<()> {
    if std::env::var_os("DRIFT").is_some() {
        return drift();
    }
    let out = std::env::args().nth(1).map(std::path::PathBuf::from);
    let mut world = World::new(3)?;
    let mut mj = CameraRenderer::new(&world, RenderPath::Full)?;
    let mut rs = CameraRenderer::new(&world, RenderPath::Raster)?;
    if let Ok(level) = std::env::var("LEVEL") {
        rs.force_level_of_detail(Some(level.parse()?));
    }
    for i in 0..3 {
        let a = mj.render(&mut world, i)?.to_vec();
        let b = rs.render(&mut world, i)?.to_vec();
        // Pixel samples: top-centre (wall), bottom-centre (floor), image centre.
        for (name, x, y) in [
            ("wall", W / 2, 40),
            ("floor", W / 2, H - 20),
            ("centre", W / 2, H / 2),
        ] {
            let o = (y * W + x) * 3;
            println!(
                "O{} {name:6} mujoco {:?} raster {:?}",
                i + 1,
                &a[o..o + 3],
                &b[o..o + 3]
            );
        }
        println!(
            "O{}: raster so far {:?}, counts {:?}",
            i + 1,
            rs.raster_stats(),
            rs.counts()
        );
        let differ = a.chunks(3).zip(b.chunks(3)).filter(|(p, q)| p != q).count();
        println!("O{}: {differ} pixels differ", i + 1);
        if let Some(dir) = &out {
            std::fs::create_dir_all(dir)?;
            for (tag, img) in [("mujoco", &a), ("raster", &b)] {
                image::save_buffer(
                    dir.join(format!("O{}-{tag}.png", i + 1)),
                    img,
                    W as u32,
                    H as u32,
                    image::ColorType::Rgb8,
                )?;
            }
        }
    }
    Ok(())
}

/// Prints what the Rust renderer does per render while the performer drifts (the bench's
/// common case).
#[allow(dead_code)]
fn drift() -> anyhow::Result<()> {
    let mut world = World::new(3)?;
    let mut rs = CameraRenderer::new(&world, RenderPath::Raster)?;
    for k in 1..=5u64 {
        let p = proto::scene::PERFORMER_HOVER_M;
        world.set_pose(0, [1e-3 * k as f64, p[1], p[2]], [1.0, 0.0, 0.0, 0.0]);
        world.forward_at(k * 10_000_000);
        rs.render(&mut world, 0)?;
        println!("{k}: {:?} {:?}", rs.counts(), rs.raster_stats());
    }
    Ok(())
}
