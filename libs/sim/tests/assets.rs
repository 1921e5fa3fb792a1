//! A missing or corrupt Crazyflie mesh is refused when the world is built, naming the file,
//! before any renderer sees it.

use std::path::{Path, PathBuf};

use proto::scene::Formation;
use sim::world::World;

/// A copy of the unpacked meshes in a fresh directory, for one test to damage.
fn mesh_copy(tag: &str) -> PathBuf {
    let from = sim::assets::crazyflie_mesh_dir().expect("meshes (deploy/setup.sh)");
    let to = std::env::temp_dir().join(format!("waggle-meshes-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&to);
    std::fs::create_dir_all(to.join("cf2x")).unwrap();
    for entry in std::fs::read_dir(from.join("cf2x")).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, to.join("cf2x").join(path.file_name().unwrap())).unwrap();
    }
    to
}

fn refusal(dir: &Path) -> String {
    let formation = Formation::standard(3).unwrap();
    match World::with_formation_in(&formation, dir) {
        Ok(_) => panic!(
            "a world was built from the damaged meshes in {}",
            dir.display()
        ),
        Err(e) => e.to_string(),
    }
}

#[test]
fn the_intact_copy_builds() {
    let dir = mesh_copy("intact");
    World::with_formation_in(&Formation::standard(3).unwrap(), &dir).expect("intact meshes");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_missing_mesh_is_refused_naming_the_file() {
    let dir = mesh_copy("missing");
    std::fs::remove_file(dir.join("cf2x/cf2x_battery.stl")).unwrap();
    let why = refusal(&dir);
    assert!(why.contains("cf2x_battery.stl"), "{why}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_corrupt_mesh_is_refused_naming_the_file() {
    let dir = mesh_copy("corrupt");
    let path = dir.join("cf2x/cf2x_motor-holder.stl");
    let bytes = std::fs::read(&path).unwrap();
    // Cut in the middle of its triangles: the count in the header no longer matches.
    std::fs::write(&path, &bytes[..bytes.len() / 2 + 7]).unwrap();
    let why = refusal(&dir);
    assert!(why.contains("cf2x_motor-holder.stl"), "{why}");
    let _ = std::fs::remove_dir_all(&dir);
}
