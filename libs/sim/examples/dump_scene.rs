//! Prints the generated MJCF for N observers (default 3): `cargo run --example dump_scene -- 3`.

fn main() -> anyhow::Result<()> {
    let n: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(3);
    let dir = sim::assets::crazyflie_mesh_dir()?;
    print!("{}", sim::mjcf::scene_xml(n, &dir)?);
    Ok(())
}
