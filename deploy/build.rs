//! Embeds an rpath to the MuJoCo library unpacked by `deploy/setup.sh`, so every binary, test
//! and bench of this crate finds `libmujoco` without `LD_LIBRARY_PATH`.

fn main() {
    let manifest =
        std::path::PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let lib = manifest.join("../third_party/mujoco/lib");
    let lib = lib.canonicalize().unwrap_or(lib);
    println!("cargo::rustc-link-arg=-Wl,-rpath,{}", lib.display());
    println!("cargo::rerun-if-changed=build.rs");
}
