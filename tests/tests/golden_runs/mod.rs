//! The golden runs of `tests/golden/frozen.toml` (shared by the tests that compare whole runs
//! with them).

use sha2::{Digest, Sha256};
use waggle_tests::workspace_root;

/// The golden entries of `tests/golden/frozen.toml` for the renderer of `render`: `[[run]]`
/// tables for the default (Waggle's renderer), `[[reference]]` for MuJoCo's.
pub fn golden_of(render: proto::RenderPath) -> Vec<toml::Table> {
    let path = workspace_root().join("tests/golden/frozen.toml");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let table: toml::Table = text
        .parse()
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let kind = kind(render);
    table[kind]
        .as_array()
        .unwrap_or_else(|| panic!("[[{kind}]] entries"))
        .iter()
        .map(|r| r.as_table().expect("a table").clone())
        .collect()
}

fn kind(render: proto::RenderPath) -> &'static str {
    if render.is_mujoco() {
        "reference"
    } else {
        "run"
    }
}

/// The golden entry of `case` (`modality`) rendered by `render`'s renderer.
pub fn golden_entry_of(render: proto::RenderPath, case: &str, modality: &str) -> toml::Table {
    golden_of(render)
        .into_iter()
        .find(|r| r["case"].as_str() == Some(case) && r["modality"].as_str() == Some(modality))
        .unwrap_or_else(|| {
            panic!(
                "no [[{}]] for {case} ({modality}) in tests/golden/frozen.toml",
                kind(render)
            )
        })
}

/// The golden entry of `case` (`modality`) with the default renderer.
pub fn golden_entry(case: &str, modality: &str) -> toml::Table {
    golden_entry_of(proto::RenderPath::default(), case, modality)
}

pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}
