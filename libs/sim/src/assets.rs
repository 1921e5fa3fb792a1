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
    #[error("Crazyflie mesh {path} is unusable: {reason} — run `bash deploy/setup.sh` again")]
    MeshUnusable { path: PathBuf, reason: String },
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

/// Checks that each of `files` (relative to `mesh_dir`) is a readable, whole STL: a binary STL
/// whose length matches its triangle count, or an ASCII STL that ends its solid. MuJoCo's own
/// message for a bad mesh is cut to a fixed length, which can drop the file's name; this check
/// names it in full.
pub fn check_meshes(mesh_dir: &Path, files: &[&str]) -> Result<(), AssetError> {
    for file in files {
        let path = mesh_dir.join(file);
        let unusable = |reason: String| AssetError::MeshUnusable {
            path: path.clone(),
            reason,
        };
        let bytes = std::fs::read(&path).map_err(|e| unusable(e.to_string()))?;
        stl_shape(&bytes).map_err(unusable)?;
    }
    Ok(())
}

/// `Ok` when `bytes` have the shape of a whole STL file, else why not.
fn stl_shape(bytes: &[u8]) -> Result<(), String> {
    const HEADER: usize = 80;
    const TRIANGLE: usize = 50;
    if bytes.len() >= HEADER + 4 {
        let count = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
        let expected = count
            .checked_mul(TRIANGLE)
            .and_then(|b| b.checked_add(HEADER + 4));
        if expected == Some(bytes.len()) && count > 0 {
            return Ok(());
        }
        if !bytes.starts_with(b"solid") {
            return Err(format!(
                "binary STL of {count} triangles should be {} bytes, found {}",
                expected.map_or_else(|| "more than usize::MAX".to_string(), |b| b.to_string()),
                bytes.len()
            ));
        }
    }
    let text = String::from_utf8_lossy(bytes);
    if text.starts_with("solid")
        && text
            .trim_end()
            .lines()
            .last()
            .is_some_and(|l| l.trim_start().starts_with("endsolid"))
    {
        Ok(())
    } else {
        Err(format!(
            "neither a whole binary STL nor an ASCII STL ending in `endsolid` ({} bytes)",
            bytes.len()
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::stl_shape;

    fn binary(triangles: u32) -> Vec<u8> {
        let mut bytes = vec![0u8; 80];
        bytes.extend(triangles.to_le_bytes());
        bytes.resize(84 + 50 * triangles as usize, 0);
        bytes
    }

    #[test]
    fn whole_stls_pass_and_cut_ones_are_refused() {
        assert!(stl_shape(&binary(3)).is_ok());
        let cut = &binary(3)[..120];
        assert!(
            stl_shape(cut)
                .unwrap_err()
                .contains("should be 234 bytes, found 120")
        );
        assert!(stl_shape(b"solid x\nfacet normal 0 0 1\nendfacet\nendsolid x\n").is_ok());
        assert!(stl_shape(b"solid x\nfacet normal 0 0 1\n").is_err());
        assert!(stl_shape(b"").is_err());
        assert!(stl_shape(&binary(0)).is_err());
    }
}
