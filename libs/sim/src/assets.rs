//! Locating the third-party assets unpacked by `deploy/setup.sh`.

use std::path::{Path, PathBuf};

/// Environment variable that overrides where `third_party/` is looked for.
pub const THIRD_PARTY_ENV: &str = "WAGGLE_THIRD_PARTY";

/// Why the assets could not be used.
#[derive(Debug, thiserror::Error)]
pub enum AssetError {
    #[error(
        "Crazyflie meshes not found at {0} — run `bash deploy/setup.sh` (or set {THIRD_PARTY_ENV})"
    )]
    MeshesMissing(PathBuf),
}

/// The `third_party/` folder: `$WAGGLE_THIRD_PARTY`, else the checkout this crate was built from.
pub fn third_party_dir() -> PathBuf {
    std::env::var_os(THIRD_PARTY_ENV)
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../third_party"))
}

/// Folder holding the Crazyflie 2.x meshes (`cf2x/*.stl`), checked for presence.
pub fn crazyflie_mesh_dir() -> Result<PathBuf, AssetError> {
    let dir = third_party_dir().join("crazyflie");
    let probe = dir.join("cf2x/cf2x_pcb.stl");
    if !probe.is_file() {
        return Err(AssetError::MeshesMissing(dir));
    }
    Ok(dir.canonicalize().unwrap_or(dir))
}
