//! The relocatable bundle for compute nodes (`deploy/relocatable.sh`; README, "Compute nodes: a
//! relocatable bundle") must run where nothing of this machine is installed: no checkout, no
//! MuJoCo, no Mesa, no meshes, only a glibc. Running it from another directory of this machine
//! would prove little — the binaries' RUNPATH names this checkout, glvnd would find this host's
//! vendor files and the meshes have a default path — so this test builds a bundle and runs a real
//! lab command from it inside a root directory holding only the bundle, the glibc libraries the
//! bundle's files need and the `/bin/sh` and `readlink` its wrappers use, entered with `chroot` in
//! fresh mount, PID and network namespaces (`unshare`). The command is `waggle trials` with one
//! RGB observer and MuJoCo's renderer (`--render damage`, so the bundled Mesa is what draws):
//! `waggle` execs `waggle-lab` beside it, which flies
//! the MuJoCo scene, renders it through EGL on the bundled llvmpipe and decodes the offer; its
//! `trials.json` must equal, byte for byte, the same command's from `target/release` outside. Every node binary's wrapper is
//! also started once inside (`--version`: each loads its libraries). A bundle built with
//! `--no-mesa` holds no EGL, Mesa or LLVM: from it the same command runs with the default
//! renderer, byte for byte as outside, and MuJoCo's renderer fails naming EGL.
//!
//! Needs root (namespaces, mounts, chroot): skipped, saying why, otherwise. The mounts live only
//! in the namespace, so they vanish with it, pass or fail; the directory is removed at the end.

use std::collections::BTreeSet;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The lab command run inside and outside: one seeded trial, one RGB observer, one offer (each
/// test adds its `--render`).
const TRIALS: [&str; 11] = [
    "trials",
    "--link",
    "011010",
    "--observers",
    "1",
    "--modality",
    "rgb",
    "--trials",
    "1",
    "--jobs",
    "1",
];

/// What the host must provide: glibc's libraries and nothing else.
const GLIBC: [&str; 6] = [
    "ld-linux-x86-64.so.2",
    "libc.so.6",
    "libm.so.6",
    "libpthread.so.0",
    "libdl.so.2",
    "librt.so.1",
];

/// Output files that must be byte-identical (`cost.json`, `run-cost.json` hold wall-clock time).
/// `provenance.json` names the binary, the CPU and the renderer: the bundle says which Mesa it
/// carries (`WAGGLE_MESA_VERSION`), so its shards merge with the checkout's on this host.
const SAME_BYTES: [&str; 4] = ["trials.json", "point.json", "run.json", "provenance.json"];

/// The test's directory. Dropped: anything still mounted below it (nothing should be: the
/// mounts belong to the namespace) is unmounted first, so nothing is deleted through a mount.
struct Scratch(PathBuf);

impl Drop for Scratch {
    fn drop(&mut self) {
        for m in mounts_under(&self.0).iter().rev() {
            let _ = Command::new("umount").arg("-l").arg(m).status();
        }
        if mounts_under(&self.0).is_empty() {
            let _ = std::fs::remove_dir_all(&self.0);
        } else {
            eprintln!("left {} in place: still mounted", self.0.display());
        }
    }
}

fn mounts_under(dir: &Path) -> Vec<PathBuf> {
    let info = std::fs::read_to_string("/proc/self/mountinfo").unwrap_or_default();
    info.lines()
        .filter_map(|l| l.split(' ').nth(4))
        .map(PathBuf::from)
        .filter(|m| m.starts_with(dir))
        .collect()
}

/// `name` on this machine's PATH or in the system directories.
fn which(name: &str) -> Option<PathBuf> {
    let path = std::env::var("PATH").unwrap_or_default();
    path.split(':')
        .chain(["/usr/sbin", "/usr/bin", "/sbin", "/bin"])
        .map(|d| Path::new(d).join(name))
        .find(|p| p.is_file())
}

/// Why the test cannot run here, if it cannot.
fn cannot_run() -> Option<String> {
    let uid = Command::new("id").arg("-u").output().ok()?;
    if String::from_utf8_lossy(&uid.stdout).trim() != "0" {
        return Some("needs root (unshare, mount, chroot)".into());
    }
    for tool in [
        "unshare",
        "chroot",
        "mount",
        "env",
        "ldd",
        "readlink",
        "sha256sum",
    ] {
        if which(tool).is_none() {
            return Some(format!("no {tool} on this machine"));
        }
    }
    None
}

/// Runs `cmd` with its output in `log`, killed after `limit`; panics with the log unless it
/// succeeded.
fn run_bounded(cmd: &mut Command, log: &Path, limit: Duration, what: &str) {
    let file = std::fs::File::create(log).expect("log file");
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(file.try_clone().expect("log file"))
        .stderr(file)
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start {what}: {e}"));
    let started = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait") {
            break s;
        }
        if started.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!(
                "{what} did not finish in {limit:?}:\n{}",
                std::fs::read_to_string(log).unwrap_or_default()
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    assert!(
        status.success(),
        "{what} failed ({status}):\n{}",
        std::fs::read_to_string(log).unwrap_or_default()
    );
}

/// Every ELF file of the bundle the loader maps: the binaries, the libraries, the DRI driver
/// (when bundled).
fn bundle_elves(bundle: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    for dir in ["libexec", "lib", "lib/dri"] {
        if dir == "lib/dri" && !bundle.join(dir).is_dir() {
            continue;
        }
        for e in std::fs::read_dir(bundle.join(dir)).expect("bundle directory") {
            let p = e.expect("entry").path();
            if p.is_file() {
                files.push(p);
            }
        }
    }
    files
}

/// The host libraries `file` resolves to (`ldd`, with the bundle's `lib/` first, as its
/// wrappers set it): each must be glibc's. Returns their paths, the loader's included.
fn host_libraries(file: &Path, bundle_lib: &Path) -> BTreeSet<PathBuf> {
    let out = Command::new("ldd")
        .arg(file)
        .env("LD_LIBRARY_PATH", bundle_lib)
        .output()
        .expect("run ldd");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "ldd {}: {text}", file.display());
    let mut host = BTreeSet::new();
    for line in text.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        let path = match words.as_slice() {
            [name, "=>", "not", "found", ..] => {
                panic!("{} needs {name}, which nothing provides", file.display())
            }
            [_, "=>", path, ..] => Path::new(path),
            [path, _] if path.starts_with('/') => Path::new(path),
            _ => continue,
        };
        if path.starts_with(bundle_lib) {
            continue;
        }
        let name = path.file_name().unwrap().to_string_lossy();
        assert!(
            GLIBC.contains(&name.as_ref()),
            "{} resolves {name} to the host's {} — the bundle must carry every library but \
             glibc's",
            file.display(),
            path.display()
        );
        host.insert(path.to_path_buf());
    }
    host
}

/// Copies `host` into `root` at the same absolute path (following symlinks).
fn copy_into(root: &Path, host: &Path) {
    let to = root.join(host.strip_prefix("/").expect("absolute path"));
    std::fs::create_dir_all(to.parent().unwrap()).unwrap();
    std::fs::copy(host, &to)
        .unwrap_or_else(|e| panic!("copy {} into the root: {e}", host.display()));
}

/// The root directory: the bundle at /opt/waggle, glibc, /bin/sh and readlink, empty /dev
/// nodes to bind the host's onto, /proc, /tmp, and /bin/waggle a symlink to the wrapper.
fn make_root(root: &Path, bundle: &Path) {
    let lib = bundle.join("lib");
    let mut host = BTreeSet::new();
    let sh = std::fs::canonicalize("/bin/sh").expect("/bin/sh");
    let readlink = std::fs::canonicalize(which("readlink").unwrap()).unwrap();
    for f in bundle_elves(bundle).iter().chain([&sh, &readlink]) {
        host.extend(host_libraries(f, &lib));
    }
    for h in &host {
        copy_into(root, h);
    }
    std::fs::create_dir_all(root.join("bin")).unwrap();
    std::fs::copy(&sh, root.join("bin/sh")).unwrap();
    std::fs::copy(&readlink, root.join("bin/readlink")).unwrap();
    std::os::unix::fs::symlink("/opt/waggle/bin/waggle", root.join("bin/waggle")).unwrap();
    for d in ["proc", "dev", "tmp"] {
        std::fs::create_dir_all(root.join(d)).unwrap();
    }
    std::fs::set_permissions(root.join("tmp"), std::fs::Permissions::from_mode(0o1777)).unwrap();
    for node in ["null", "zero", "urandom"] {
        std::fs::write(root.join("dev").join(node), b"").unwrap();
    }
    let names: Vec<_> = host.iter().map(|h| h.display().to_string()).collect();
    println!(
        "root: the bundle, /bin/sh, /bin/readlink and {}",
        names.join(" ")
    );
}

/// Every file of the bundle is in its MANIFEST, and `sha256sum -c` agrees with it.
fn check_manifest(bundle: &Path) {
    let manifest = std::fs::read_to_string(bundle.join("MANIFEST")).expect("MANIFEST");
    let listed: BTreeSet<&str> = manifest
        .lines()
        .map(|l| l.split_once("  ").expect("sha256sum line").1)
        .collect();
    let mut files = BTreeSet::new();
    let mut dirs = vec![bundle.to_path_buf()];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else {
                files.insert(p.strip_prefix(bundle).unwrap().display().to_string());
            }
        }
    }
    files.remove("MANIFEST");
    let files: BTreeSet<&str> = files.iter().map(String::as_str).collect();
    assert_eq!(
        listed, files,
        "MANIFEST does not list exactly the bundle's files"
    );
    waggle_tests::succeed(
        Command::new("sha256sum")
            .args(["-c", "--quiet", "MANIFEST"])
            .current_dir(bundle),
        "sha256sum -c MANIFEST",
    );
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).expect("output file")).expect("JSON")
}

#[test]
fn the_bundle_runs_a_lab_command_in_an_empty_root_with_identical_results() {
    bundle_runs_trials_in_an_empty_root(&[], "damage");
}

/// `--no-mesa`: no EGL, Mesa or LLVM in the bundle; the default renderer runs as from
/// target/release, MuJoCo's is refused with an error naming EGL.
#[test]
fn the_bundle_without_mesa_runs_the_default_renderer_in_an_empty_root() {
    bundle_runs_trials_in_an_empty_root(&["--no-mesa"], "raster");
}

/// A `--no-mesa` bundle holds no EGL, Mesa or LLVM, and MuJoCo's renderer run from it in the
/// root failed naming EGL.
fn assert_no_mesa(root: &Path, bundle: &Path) {
    let why = std::fs::read_to_string(root.join("tmp/mujoco.err")).unwrap_or_default();
    assert!(
        why.contains("EGL"),
        "MuJoCo's renderer without Mesa failed without naming EGL: {why}"
    );
    for gone in ["lib/dri", "share/glvnd", "lib/libEGL.so.1"] {
        assert!(!bundle.join(gone).exists(), "--no-mesa bundled {gone}");
    }
    let libs: Vec<String> = std::fs::read_dir(bundle.join("lib"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        !libs.iter().any(|l| l.contains("LLVM") || l.contains("EGL")),
        "--no-mesa bundled {libs:?}"
    );
}

/// What runs in the root: every wrapper's `--version`, job files, then the trials (after, for
/// a `--no-mesa` bundle, MuJoCo's renderer failing).
fn inner_script(flags: &[&str], render: &str) -> String {
    let trials = format!("{} --render {render}", TRIALS.join(" "));
    // Without Mesa, MuJoCo's renderer must fail, saying why, before the default one runs.
    let refused = if flags.contains(&"--no-mesa") {
        format!(
            "if /bin/waggle {} --render damage --out /tmp/mujoco 2>/tmp/mujoco.err; then \
             echo 'MuJoCo rendered without Mesa' >&2; exit 3; fi; ",
            TRIALS.join(" ")
        )
    } else {
        String::new()
    };
    format!(
        "set -e; for b in {}; do /opt/waggle/bin/$b --version; done; \
         /bin/waggle study event-noise --slurm --shard-count 2 --out /tmp/jobs >/dev/null; \
         {refused}exec /bin/waggle {trials} --out /tmp/out",
        ["waggle", "waggle-lab"]
            .iter()
            .chain(&waggle_tests::NODES)
            .copied()
            .collect::<Vec<_>>()
            .join(" "),
    )
}

/// Builds a bundle (`deploy/relocatable.sh FLAGS`) and runs [`TRIALS`] with `--render RENDER`
/// from it in an empty root and from target/release outside; the results must be the same bytes.
fn bundle_runs_trials_in_an_empty_root(flags: &[&str], render: &str) {
    if let Some(why) = cannot_run() {
        eprintln!("skipped: {why}");
        return;
    }
    for b in waggle_tests::NODES.iter().chain(&["waggle", "waggle-lab"]) {
        waggle_tests::bin(b);
    }
    let scratch = Scratch(std::env::temp_dir().join(format!(
        "waggle-relocatable-{render}-{}",
        std::process::id()
    )));
    let _ = std::fs::remove_dir_all(&scratch.0);
    let root = scratch.0.join("root");
    let bundle = root.join("opt/waggle");
    std::fs::create_dir_all(&root).unwrap();

    let t = Instant::now();
    run_bounded(
        Command::new("bash")
            .arg(waggle_tests::workspace_root().join("deploy/relocatable.sh"))
            .arg(&bundle)
            .args(flags)
            .env("WAGGLE_BIN_DIR", waggle_tests::bin_dir()),
        &scratch.0.join("relocatable.log"),
        Duration::from_secs(300),
        "deploy/relocatable.sh",
    );
    let built = t.elapsed();
    check_manifest(&bundle);
    make_root(&root, &bundle);
    let size = Command::new("du").arg("-sh").arg(&bundle).output().unwrap();

    // Inside: fresh namespaces, /proc and three /dev nodes mounted, then chroot with an empty
    // environment. The wrappers are reached through /opt/waggle/bin and the /bin/waggle symlink.
    let t = Instant::now();
    let inner = inner_script(flags, render);
    let outer = "set -e; r=$1; mount -t proc proc \"$r/proc\"; \
                 for d in null zero urandom; do mount --bind /dev/$d \"$r/dev/$d\"; done; \
                 exec env -i PATH=/bin HOME=/tmp \"$2\" \"$r\" /bin/sh -c \"$3\"";
    run_bounded(
        Command::new(which("unshare").unwrap())
            .args(["--mount", "--pid", "--net", "--fork", "--kill-child"])
            .args(["sh", "-c", outer, "sh"])
            .arg(&root)
            .arg(which("chroot").unwrap())
            .arg(&inner),
        &scratch.0.join("inside.log"),
        Duration::from_secs(300),
        "the bundle's waggle trials in the chroot",
    );
    let inside_s = t.elapsed();

    let t = Instant::now();
    let outside = scratch.0.join("outside");
    run_bounded(
        waggle_tests::waggle()
            .args(TRIALS)
            .args(["--render", render])
            .arg("--out")
            .arg(&outside),
        &scratch.0.join("outside.log"),
        Duration::from_secs(300),
        "target/release's waggle trials",
    );
    let outside_s = t.elapsed();

    // Job files written from the bundle run the bundle's wrapper, not the bare binary.
    let array = std::fs::read_to_string(root.join("tmp/jobs/slurm/array.sbatch")).unwrap();
    assert!(
        array.contains("exec /opt/waggle/bin/waggle study"),
        "the job array does not run the bundle's wrapper: {array}"
    );
    let inside = root.join("tmp/out");
    for f in SAME_BYTES {
        let (a, b) = (
            std::fs::read(inside.join(f)),
            std::fs::read(outside.join(f)),
        );
        assert_eq!(
            a.expect(f),
            b.expect(f),
            "{f} differs between the bundle in the chroot and target/release"
        );
    }
    if flags.contains(&"--no-mesa") {
        assert_no_mesa(&root, &bundle);
    }
    let result = json(&inside.join("trials.json"));
    assert_eq!(result["successes"], 1, "the trial failed: {result}");
    let (pin, pout) = (
        json(&inside.join("provenance.json")),
        json(&outside.join("provenance.json")),
    );
    assert_eq!(
        pin["versions"], pout["versions"],
        "the bundle's binaries are not target/release's (rebuilt meanwhile?)"
    );
    println!(
        "bundle {} built in {:.1} s; waggle trials in the chroot {:.1} s (renderer {}), outside \
         {:.1} s (renderer {}); {} byte-identical",
        String::from_utf8_lossy(&size.stdout)
            .split_whitespace()
            .next()
            .unwrap_or("?"),
        built.as_secs_f64(),
        inside_s.as_secs_f64(),
        pin["renderers"][0],
        outside_s.as_secs_f64(),
        pout["renderers"][0],
        SAME_BYTES.join(", ")
    );
}
