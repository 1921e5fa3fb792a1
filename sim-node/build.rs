//! Embeds an rpath to the MuJoCo library unpacked by `deploy/setup.sh`, so every binary, test
//! and bench of this crate finds `libmujoco` without `LD_LIBRARY_PATH`. `deploy` uses this same
//! script (`build = "../sim-node/build.rs"`): link arguments reach only the crate whose script
//! prints them, so every crate that links MuJoCo needs to run it.

fn main() {
    // `.cargo/config.toml` sets this to the absolute `third_party/mujoco/lib` of this checkout.
    // Watching it reruns the script when the checkout moves, so the rpath never points at the
    // old place (an edit of this script reruns it anyway: it is recompiled).
    println!("cargo::rerun-if-env-changed=MUJOCO_DYNAMIC_LINK_DIR");
    let lib = match std::env::var_os("MUJOCO_DYNAMIC_LINK_DIR") {
        Some(dir) => std::path::PathBuf::from(dir),
        None => {
            std::path::PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets it"))
                .join("../third_party/mujoco/lib")
        }
    };
    let lib = lib.canonicalize().unwrap_or(lib);
    println!("cargo::rustc-link-arg=-Wl,-rpath,{}", lib.display());
}
