//! The golden runs of `tests/golden/frozen.toml` (shared by `frozen.rs` and `hostile.rs`).

use sha2::{Digest, Sha256};
use waggle_tests::workspace_root;

/// The golden entries: `[[run]]` tables of `tests/golden/frozen.toml`.
pub fn golden() -> Vec<toml::Table> {
    let path = workspace_root().join("tests/golden/frozen.toml");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let table: toml::Table = text
        .parse()
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    table["run"]
        .as_array()
        .expect("[[run]] entries")
        .iter()
        .map(|r| r.as_table().expect("a [[run]] table").clone())
        .collect()
}

pub fn golden_entry(case: &str, modality: &str) -> toml::Table {
    golden()
        .into_iter()
        .find(|r| r["case"].as_str() == Some(case) && r["modality"].as_str() == Some(modality))
        .unwrap_or_else(|| panic!("no [[run]] for {case} ({modality}) in tests/golden/frozen.toml"))
}

pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}
