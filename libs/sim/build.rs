//! Embeds an rpath to the MuJoCo library unpacked by `deploy/setup.sh`, so every binary, test
//! and bench finds `libmujoco` without `LD_LIBRARY_PATH`. Every package that links MuJoCo
//! (`sim`, `perception` for its fixture example, `sim-node`, `lab`) names this one
//! script (`build = "…/libs/sim/build.rs"`): link arguments reach only the package whose script
//! prints them.
//!
//! It also exports `eglGetProcAddress` from those binaries' dynamic symbol table: MuJoCo's GL
//! loader looks that name up in the process's global scope first, which is how `libs/offscreen`
//! holds a scissor across `mjr_render` (see its crate docs). A binary without the symbol simply
//! gets the real loader.

fn main() {
    // `.cargo/config.toml` sets this to the absolute `third_party/mujoco/lib` of this checkout.
    // Watching it reruns the script when the checkout moves, so the rpath never points at the
    // old place (an edit of this script reruns it anyway: it is recompiled).
    println!("cargo::rerun-if-env-changed=MUJOCO_DYNAMIC_LINK_DIR");
    let lib = match std::env::var_os("MUJOCO_DYNAMIC_LINK_DIR") {
        Some(dir) => std::path::PathBuf::from(dir),
        None => {
            let manifest = std::path::PathBuf::from(
                std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets it"),
            );
            // The workspace root is the nearest ancestor holding Cargo.lock.
            let root = manifest
                .ancestors()
                .find(|d| d.join("Cargo.lock").exists())
                .unwrap_or(&manifest)
                .to_path_buf();
            root.join("third_party/mujoco/lib")
        }
    };
    let lib = lib.canonicalize().unwrap_or(lib);
    println!("cargo::rustc-link-arg=-Wl,-rpath,{}", lib.display());
    println!("cargo::rustc-link-arg=-Wl,--export-dynamic-symbol=eglGetProcAddress");
}
