//! Writes the seed corpora (`fuzz_targets::seeds`) to `fuzz/corpus/<target>/seed-<name>`:
//! `cargo run --release -p fuzz-targets --example write_seeds`.

use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let scratch = std::env::temp_dir().join(format!("waggle-seeds-{}", std::process::id()));
    std::fs::create_dir_all(&scratch)?;
    let seeds = fuzz_targets::seeds::seeds(&root, &scratch)?;
    for (target, name, bytes) in &seeds {
        let dir = root.join("fuzz/corpus").join(target);
        std::fs::create_dir_all(&dir)?;
        std::fs::write(dir.join(format!("seed-{name}")), bytes)?;
        println!("{target}/seed-{name}: {} bytes", bytes.len());
    }
    std::fs::remove_dir_all(&scratch)?;
    Ok(())
}
