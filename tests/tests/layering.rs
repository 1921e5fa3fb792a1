//! The crate graph keeps its layers (ARCHITECTURE.md): proto → libs → node processes → deploy
//! and lab (side by side) → tests.
//!
//! Reads `cargo metadata --no-deps` and proves, for every dependency edge between workspace crates
//! (normal, dev and build alike):
//!
//! - `proto` depends on no workspace crate;
//! - a library in `libs/` depends only on `proto` and other libraries;
//! - a node crate never depends on another node crate, on `deploy`, the lab or the tests;
//! - the Python package (`python/`) sits beside the lab, never on `deploy`; nothing depends
//!   on it;
//! - `deploy` never depends on the lab, nor the lab on `deploy` (the launcher): the command
//!   line, the run summary and the audit both use are libraries (`commands`, `run-eval`);
//! - nothing depends on the tests.
//!
//! Every workspace member must belong to a layer, so a new crate cannot slip past these rules.
//! A failure names each offending edge.
//!
//! A second test keeps `waggle` free of MuJoCo (issue 29): `deploy` reaches no crate that links
//! it (`sim`, `offscreen`, `mujoco-rs`) through its normal dependencies, and the built `waggle`
//! binary, when present, loads no `libmujoco`.
//!
//! A second test keeps the repository self-contained: no tracked file may point at documents
//! outside it, and every design-section citation must name a section `docs/DESIGN.md` has.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;
use waggle_tests::workspace_root;

/// The node crates: one process each, thin shells over the libraries.
const NODE_CRATES: [&str; 5] = [
    "sim-node",
    "performer-node",
    "observer-node",
    "scheduler-node",
    "recorder-node",
];

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Layer {
    Proto,
    Lib,
    Node,
    Deploy,
    Lab,
    /// The Python package (`python/`): beside the lab, above the libraries.
    Python,
    Tests,
}

/// `cargo metadata --format-version 1 ARGS…` of the workspace.
fn cargo_metadata(args: &[&str]) -> Value {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let out = Command::new(&cargo)
        .args(["metadata", "--format-version", "1"])
        .args(args)
        .current_dir(workspace_root())
        .output()
        .unwrap_or_else(|e| panic!("run {}: {e}", cargo.to_string_lossy()));
    assert!(
        out.status.success(),
        "cargo metadata failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("cargo metadata prints JSON")
}

/// The workspace's own packages (`--no-deps`).
fn metadata() -> Value {
    cargo_metadata(&["--no-deps"])
}

/// The layer of the workspace member whose manifest is in `dir`, from where it lives.
fn layer_of(name: &str, dir: &Path, root: &Path) -> Layer {
    let rel = dir.strip_prefix(root).unwrap_or(dir);
    if NODE_CRATES.contains(&name) {
        Layer::Node
    } else if rel == Path::new("proto") {
        Layer::Proto
    } else if rel.parent() == Some(Path::new("libs")) {
        Layer::Lib
    } else if rel == Path::new("deploy") {
        Layer::Deploy
    } else if rel == Path::new("lab") {
        Layer::Lab
    } else if rel == Path::new("python") {
        Layer::Python
    } else if rel == Path::new("tests") {
        Layer::Tests
    } else {
        panic!(
            "workspace member {name} ({}) belongs to no layer: place it (proto, libs/, a node \
             crate, deploy, lab or tests) and classify it in tests/tests/layering.rs",
            rel.display()
        )
    }
}

/// Why the edge `from` → `to` breaks the layering, if it does.
fn violation(from: Layer, to: Layer) -> Option<&'static str> {
    use Layer::{Deploy, Lab, Lib, Node, Proto, Python, Tests};
    match (from, to) {
        (Proto, _) => Some("proto depends on no workspace crate"),
        (Lib, Proto | Lib) => None,
        (Lib, _) => Some("a library depends only on proto and other libraries"),
        (Node, Node) => Some("a node crate never depends on another node crate"),
        (Node, Deploy | Lab) => Some("a node crate never depends on deploy or the lab"),
        (Deploy, Lab) => Some("deploy (the operations, no MuJoCo) never depends on the lab"),
        (Lab, Deploy) => Some(
            "the lab never depends on the launcher: what both need (the command line, the run \
             summary, the audit) lives in a library below both",
        ),
        (_, Tests) => Some("nothing depends on the tests crate"),
        (_, Python) => Some("nothing depends on the Python package"),
        (Python, Deploy) => Some("the Python package never depends on the launcher"),
        _ => None,
    }
}

#[test]
fn workspace_crates_depend_only_on_lower_layers() {
    let meta = metadata();
    let root = PathBuf::from(meta["workspace_root"].as_str().expect("workspace_root"));
    let packages = meta["packages"].as_array().expect("packages");
    let layers: BTreeMap<&str, Layer> = packages
        .iter()
        .map(|p| {
            let name = p["name"].as_str().expect("package name");
            let manifest = Path::new(p["manifest_path"].as_str().expect("manifest_path"));
            (name, layer_of(name, manifest.parent().unwrap(), &root))
        })
        .collect();
    for node in NODE_CRATES {
        assert_eq!(
            layers.get(node),
            Some(&Layer::Node),
            "node crate {node} is not a workspace member: update NODE_CRATES"
        );
    }
    assert_eq!(layers.get("proto"), Some(&Layer::Proto), "no proto crate");

    let mut edges = 0;
    let mut broken = Vec::new();
    for p in packages {
        let from = p["name"].as_str().unwrap();
        for d in p["dependencies"].as_array().expect("dependencies") {
            let to = d["name"].as_str().expect("dependency name");
            // Only edges inside the workspace: path dependencies on a member.
            let Some(&to_layer) = layers.get(to).filter(|_| d["path"].is_string()) else {
                continue;
            };
            edges += 1;
            let kind = d["kind"].as_str().unwrap_or("normal");
            if let Some(rule) = violation(layers[from], to_layer) {
                broken.push(format!("{from} → {to} ({kind} dependency): {rule}"));
            }
        }
    }
    assert!(
        edges > 10,
        "only {edges} workspace edges: is cargo metadata's output what this test expects?"
    );
    assert!(
        broken.is_empty(),
        "the crate graph breaks its layering (ARCHITECTURE.md):\n  {}",
        broken.join("\n  ")
    );
}

/// The crates that link libmujoco: none may be in `waggle`'s graph.
const MUJOCO_CRATES: [&str; 3] = ["sim", "offscreen", "mujoco-rs"];

/// `deploy` (the `waggle` binary) reaches no MuJoCo-linking crate through normal dependencies
/// (what is linked into it), read from the resolved graph of `cargo metadata`.
#[test]
fn deploy_does_not_depend_on_mujoco() {
    let meta = cargo_metadata(&["--offline"]);
    let names: BTreeMap<&str, &str> = meta["packages"]
        .as_array()
        .expect("packages")
        .iter()
        .map(|p| (p["id"].as_str().unwrap(), p["name"].as_str().unwrap()))
        .collect();
    // Each package's normal dependencies (a dependency kind of `null`), by package id.
    let normal: BTreeMap<&str, Vec<&str>> = meta["resolve"]["nodes"]
        .as_array()
        .expect("resolve.nodes")
        .iter()
        .map(|n| {
            let deps = n["deps"]
                .as_array()
                .expect("deps")
                .iter()
                .filter(|d| {
                    d["dep_kinds"]
                        .as_array()
                        .is_some_and(|k| k.iter().any(|k| k["kind"].is_null()))
                })
                .map(|d| d["pkg"].as_str().unwrap())
                .collect();
            (n["id"].as_str().unwrap(), deps)
        })
        .collect();
    let deploy = names
        .iter()
        .find(|(_, n)| **n == "deploy")
        .map(|(id, _)| *id)
        .expect("a deploy package");
    // Depth-first from deploy, remembering how each crate was reached.
    let mut via: BTreeMap<&str, &str> = BTreeMap::from([(deploy, deploy)]);
    let mut todo = vec![deploy];
    while let Some(id) = todo.pop() {
        for &d in normal.get(id).into_iter().flatten() {
            if !via.contains_key(d) {
                via.insert(d, id);
                todo.push(d);
            }
        }
    }
    assert!(via.len() > 20, "deploy reaches only {} crates", via.len());
    let path = |start| {
        let mut id = start;
        let mut chain = vec![names[id]];
        while via[id] != id {
            id = via[id];
            chain.push(names[id]);
        }
        chain.reverse();
        chain.join(" → ")
    };
    let linked: Vec<String> = via
        .keys()
        .filter(|id| MUJOCO_CRATES.iter().any(|m| *m == names[*id]))
        .map(|id| path(*id))
        .collect();
    assert!(
        linked.is_empty(),
        "`waggle` (deploy) must not link MuJoCo; what needs the simulator belongs in the lab \
         crate (`waggle-lab`):\n  {}",
        linked.join("\n  ")
    );
}

#[test]
fn the_layering_rules_reject_the_edges_they_name() {
    use Layer::{Deploy, Lab, Lib, Node, Proto, Tests};
    for (from, to) in [
        (Proto, Lib),
        (Lib, Node),
        (Lib, Deploy),
        (Lib, Lab),
        (Lib, Tests),
        (Node, Node),
        (Node, Deploy),
        (Node, Lab),
        (Deploy, Lab),
        (Deploy, Tests),
        (Lab, Deploy),
        (Lab, Tests),
    ] {
        assert!(violation(from, to).is_some(), "{from:?} → {to:?} accepted");
    }
    for (from, to) in [
        (Lib, Proto),
        (Lib, Lib),
        (Node, Lib),
        (Node, Proto),
        (Deploy, Lib),
        (Lab, Lib),
        (Tests, Deploy),
        (Tests, Lab),
        (Tests, Node),
    ] {
        assert!(violation(from, to).is_none(), "{from:?} → {to:?} rejected");
    }
}

/// The repository stands on its own: no tracked file points at a design brief or a paper kept
/// outside it, and every section of docs/DESIGN.md that a file cites (`§3`, `§8a`, each end of
/// `§2–§3`) exists there. Every offence is reported as `file:line`.
#[test]
fn the_repository_cites_only_itself() {
    let root = workspace_root();
    let listed = Command::new("git")
        .args(["ls-files", "-z"])
        .current_dir(&root)
        .output()
        .expect("run git ls-files");
    assert!(
        listed.status.success(),
        "git ls-files failed: {}",
        String::from_utf8_lossy(&listed.stderr)
    );
    let design = std::fs::read_to_string(root.join("docs/DESIGN.md")).expect("docs/DESIGN.md");
    let sections: Vec<&str> = design
        .lines()
        .filter_map(|l| l.strip_prefix("## "))
        .filter_map(|h| h.split_once(". ").map(|(n, _)| n))
        .collect();
    assert!(
        sections.contains(&"1"),
        "docs/DESIGN.md has no numbered sections (`## 1. …`): {sections:?}"
    );
    // Spelled in pieces so that this file does not match itself.
    let outside = [
        ["..", "/shared"].concat(),
        ["shared", "/DESIGN"].concat(),
        ["shared", "/paper"].concat(),
    ];
    let cite = ["DESIGN.md", " §"].concat();
    let mut bad = Vec::new();
    for path in listed.stdout.split(|&b| b == 0).filter(|p| !p.is_empty()) {
        let path = String::from_utf8_lossy(path);
        // Deleted from the work tree, a submodule, or not text: nothing to check.
        let Ok(bytes) = std::fs::read(root.join(&*path)) else {
            continue;
        };
        let Ok(text) = String::from_utf8(bytes) else {
            continue;
        };
        for (n, line) in text.lines().enumerate() {
            let n = n + 1;
            if let Some(o) = outside.iter().find(|o| line.contains(o.as_str())) {
                bad.push(format!(
                    "{path}:{n}: points outside the repository ({o}): {line}"
                ));
            }
            for (i, _) in line.match_indices(cite.as_str()) {
                if !line[..i].ends_with("docs/") {
                    bad.push(format!(
                        "{path}:{n}: cite docs/DESIGN.md by that path: {line}"
                    ));
                }
                // A section, then more after `–§` or `-§`; a placeholder such as `§n` is skipped.
                let mut rest = &line[i + cite.len()..];
                loop {
                    let section: String = rest
                        .chars()
                        .take_while(char::is_ascii_alphanumeric)
                        .collect();
                    let numbered = section.starts_with(|c: char| c.is_ascii_digit());
                    if numbered && !sections.contains(&section.as_str()) {
                        bad.push(format!(
                            "{path}:{n}: docs/DESIGN.md has no §{section}: {line}"
                        ));
                    }
                    rest = &rest[section.len()..];
                    match rest
                        .strip_prefix(&['–', '-'][..])
                        .and_then(|r| r.strip_prefix('§'))
                    {
                        Some(more) => rest = more,
                        None => break,
                    }
                }
            }
        }
    }
    assert!(
        bad.is_empty(),
        "{} reference(s) to fix:\n{}",
        bad.len(),
        bad.join("\n")
    );
}
