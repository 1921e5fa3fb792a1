//! No import cycles inside any crate: a module (one source file) that uses another, directly or
//! through others, is never used back by it. A cycle means two files cannot be understood, tested
//! or moved apart; breaking it usually names a missing concept (an error type, an options
//! struct, a geometry helper).
//!
//! The graph: for every `.rs` file under a workspace crate's `src/`, its module path, and an edge
//! to each module its code names as `crate::a::b…` (the longest prefix that is a module) or
//! `super::x`; comments, `#[cfg(test)]` sections and edges to a module's own ancestors (a child
//! using its parent's items) are left out. Tarjan's strongly connected components find every
//! cycle; the failure lists each with the edges that close it.
//!
//! A second check keeps files small: no source file holds more than 600 lines of non-test code.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use waggle_tests::workspace_root;

type Module = Vec<String>;

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

fn module_of(src: &Path, file: &Path) -> Module {
    let rel = file.strip_prefix(src).expect("under src");
    let mut parts: Module = rel
        .with_extension("")
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts
}

/// The file's code without comments and without what follows its first `#[cfg(test)]`.
fn code_of(text: &str) -> String {
    let text = text.split("#[cfg(test)]").next().unwrap_or("");
    text.lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n")
}

fn idents_after<'a>(code: &'a str, prefix: &str) -> Vec<Vec<&'a str>> {
    let mut out = Vec::new();
    for (i, _) in code.match_indices(prefix) {
        if code[..i]
            .chars()
            .last()
            .is_some_and(|c| c.is_alphanumeric() || c == '_')
        {
            continue;
        }
        let rest = &code[i + prefix.len()..];
        let path: Vec<&str> = rest
            .split("::")
            .map(|s| {
                let end = s
                    .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                    .unwrap_or(s.len());
                &s[..end]
            })
            .take_while(|s| !s.is_empty())
            .collect();
        out.push(path);
    }
    out
}

fn graph(src: &Path) -> BTreeMap<Module, BTreeSet<Module>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let modules: BTreeMap<Module, PathBuf> = files
        .iter()
        .map(|f| (module_of(src, f), f.clone()))
        .collect();
    let mut edges: BTreeMap<Module, BTreeSet<Module>> = BTreeMap::new();
    for (module, file) in &modules {
        let code = code_of(&std::fs::read_to_string(file).expect("read source"));
        let is_dir_module = file.file_name().is_some_and(|n| n == "mod.rs");
        let mut targets = Vec::new();
        for path in idents_after(&code, "crate::") {
            let found = (1..=path.len()).rev().find_map(|k| {
                let m: Module = path[..k].iter().map(|s| (*s).to_owned()).collect();
                modules.contains_key(&m).then_some(m)
            });
            targets.extend(found);
        }
        let parent: Module = if is_dir_module {
            module.clone()
        } else {
            module[..module.len().saturating_sub(1)].to_vec()
        };
        for path in idents_after(&code, "super::") {
            let base: Module = if is_dir_module {
                module[..module.len().saturating_sub(1)].to_vec()
            } else {
                parent[..parent.len().saturating_sub(1)].to_vec()
            };
            if let Some(first) = path.first() {
                let mut m = base.clone();
                m.push((*first).to_owned());
                if modules.contains_key(&m) {
                    targets.push(m);
                }
            }
        }
        let entry = edges.entry(module.clone()).or_default();
        for t in targets {
            // A module using its own ancestor (or itself) is the tree, not a cycle.
            if t != *module && !module.starts_with(&t) {
                entry.insert(t);
            }
        }
    }
    edges
}

/// Strongly connected components with more than one module.
fn cycles(edges: &BTreeMap<Module, BTreeSet<Module>>) -> Vec<Vec<Module>> {
    struct Tarjan<'a> {
        edges: &'a BTreeMap<Module, BTreeSet<Module>>,
        index: BTreeMap<&'a Module, usize>,
        low: BTreeMap<&'a Module, usize>,
        stack: Vec<&'a Module>,
        on: BTreeSet<&'a Module>,
        out: Vec<Vec<Module>>,
    }
    impl<'a> Tarjan<'a> {
        fn visit(&mut self, v: &'a Module) {
            let n = self.index.len();
            self.index.insert(v, n);
            self.low.insert(v, n);
            self.stack.push(v);
            self.on.insert(v);
            for w in self.edges.get(v).into_iter().flatten() {
                if !self.index.contains_key(w) {
                    self.visit(w);
                    let lw = self.low[w];
                    let lv = self.low.get_mut(v).expect("visited");
                    *lv = (*lv).min(lw);
                } else if self.on.contains(w) {
                    let iw = self.index[w];
                    let lv = self.low.get_mut(v).expect("visited");
                    *lv = (*lv).min(iw);
                }
            }
            if self.low[v] == self.index[v] {
                let mut comp = Vec::new();
                while let Some(w) = self.stack.pop() {
                    self.on.remove(w);
                    comp.push(w.clone());
                    if w == v {
                        break;
                    }
                }
                if comp.len() > 1 {
                    comp.sort();
                    self.out.push(comp);
                }
            }
        }
    }
    let mut t = Tarjan {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in edges.keys() {
        if !t.index.contains_key(v) {
            t.visit(v);
        }
    }
    t.out
}

fn name(m: &Module) -> String {
    if m.is_empty() {
        "crate".to_owned()
    } else {
        m.join("::")
    }
}

#[test]
fn no_crate_has_an_import_cycle() {
    let root = workspace_root();
    let mut crates = Vec::new();
    for dir in ["proto", "deploy", "lab", "tests"] {
        crates.push(root.join(dir));
    }
    for parent in ["libs"] {
        for e in std::fs::read_dir(root.join(parent))
            .expect("libs")
            .flatten()
        {
            crates.push(e.path());
        }
    }
    for e in std::fs::read_dir(&root).expect("root").flatten() {
        if e.file_name().to_string_lossy().ends_with("-node") {
            crates.push(e.path());
        }
    }
    let mut found = Vec::new();
    for dir in crates {
        let src = dir.join("src");
        if !src.is_dir() {
            continue;
        }
        let edges = graph(&src);
        for comp in cycles(&edges) {
            let members: BTreeSet<&Module> = comp.iter().collect();
            let closing: Vec<String> = comp
                .iter()
                .flat_map(|a| {
                    edges[a]
                        .iter()
                        .filter(|b| members.contains(b))
                        .map(move |b| format!("{} → {}", name(a), name(b)))
                })
                .collect();
            found.push(format!(
                "{}: {}",
                dir.strip_prefix(&root).unwrap_or(&dir).display(),
                closing.join(", ")
            ));
        }
    }
    assert!(found.is_empty(), "import cycles:\n{}", found.join("\n"));
}

#[test]
fn the_cycle_finder_finds_a_planted_cycle_and_no_other() {
    let m = |s: &str| -> Module { s.split("::").map(str::to_owned).collect() };
    let mut edges: BTreeMap<Module, BTreeSet<Module>> = BTreeMap::new();
    edges.entry(m("a")).or_default().insert(m("b"));
    edges.entry(m("b")).or_default().insert(m("c"));
    edges.entry(m("c")).or_default().insert(m("a"));
    edges.entry(m("d")).or_default().insert(m("a"));
    assert_eq!(cycles(&edges), vec![vec![m("a"), m("b"), m("c")]]);
    edges.get_mut(&m("c")).unwrap().clear();
    assert!(cycles(&edges).is_empty());
    let code = code_of("use crate::x::y; // crate::z\n#[cfg(test)]\nuse crate::w;");
    assert_eq!(idents_after(&code, "crate::"), vec![vec!["x", "y"]]);
}

/// Most non-test lines one source file may hold: a file longer than this mixes
/// responsibilities (issue 29); split it by what it owns.
const MAX_CODE_LINES: usize = 600;

#[test]
fn no_source_file_is_over_600_lines_of_code() {
    let root = workspace_root();
    let mut files = Vec::new();
    for dir in ["proto", "deploy", "lab", "tests", "libs", "tools"] {
        rust_files(&root.join(dir), &mut files);
    }
    for e in std::fs::read_dir(&root).expect("root").flatten() {
        if e.file_name().to_string_lossy().ends_with("-node") {
            rust_files(&e.path(), &mut files);
        }
    }
    let mut long = Vec::new();
    for file in files {
        let rel = file.strip_prefix(&root).unwrap_or(&file).to_path_buf();
        // Integration tests and benches are test code throughout.
        let is_test = rel
            .components()
            .any(|c| matches!(c.as_os_str().to_str(), Some("tests" | "benches")));
        if is_test || rel.starts_with("target") {
            continue;
        }
        let text = std::fs::read_to_string(&file).expect("read source");
        let code = text
            .split("#[cfg(test)]")
            .next()
            .unwrap_or("")
            .lines()
            .count();
        if code > MAX_CODE_LINES {
            long.push(format!("{} ({code} lines)", rel.display()));
        }
    }
    assert!(
        long.is_empty(),
        "source files over {MAX_CODE_LINES} lines of non-test code:\n{}",
        long.join("\n")
    );
}

/// Public type names still defined in two places (issue 29: one name per concept). The list may
/// only shrink: a new duplicate fails, and so does an entry that is no longer duplicated.
const KNOWN_DUPLICATE_NAMES: &[&str] = &[];

#[test]
fn public_type_names_are_not_reused_beyond_the_known_list() {
    let root = workspace_root();
    let mut files = Vec::new();
    for dir in ["proto", "deploy", "lab", "libs"] {
        rust_files(&root.join(dir), &mut files);
    }
    for e in std::fs::read_dir(&root).expect("root").flatten() {
        if e.file_name().to_string_lossy().ends_with("-node") {
            rust_files(&e.path(), &mut files);
        }
    }
    let mut defined: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for file in files {
        let rel = file
            .strip_prefix(&root)
            .unwrap_or(&file)
            .display()
            .to_string();
        if rel.contains("/tests/") || rel.contains("/benches/") {
            continue;
        }
        let code = code_of(&std::fs::read_to_string(&file).expect("read source"));
        for line in code.lines() {
            let line = line.trim_start();
            let Some(rest) = line.strip_prefix("pub ").or_else(|| {
                line.strip_prefix("pub(crate) ")
                    .or_else(|| line.strip_prefix("pub(super) "))
            }) else {
                continue;
            };
            for kind in ["struct ", "enum ", "trait ", "type "] {
                if let Some(name) = rest.strip_prefix(kind) {
                    let name: String = name
                        .chars()
                        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                        .collect();
                    defined.entry(name).or_default().insert(rel.clone());
                }
            }
        }
    }
    let duplicated: BTreeMap<&String, &BTreeSet<String>> = defined
        .iter()
        .filter(|(_, files)| files.len() > 1)
        .collect();
    let new: Vec<String> = duplicated
        .iter()
        .filter(|(name, _)| !KNOWN_DUPLICATE_NAMES.contains(&name.as_str()))
        .map(|(name, files)| format!("{name}: {files:?}"))
        .collect();
    let gone: Vec<&&str> = KNOWN_DUPLICATE_NAMES
        .iter()
        .filter(|n| !duplicated.keys().any(|d| d.as_str() == **n))
        .collect();
    assert!(
        new.is_empty(),
        "public type names defined twice (name the concept once):\n{}",
        new.join("\n")
    );
    assert!(
        gone.is_empty(),
        "no longer duplicated, remove from KNOWN_DUPLICATE_NAMES: {gone:?}"
    );
}
