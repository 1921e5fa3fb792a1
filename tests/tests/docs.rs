//! The documentation holds to what it says: the reference pages generated from the code are
//! current, the user guide builds with mdBook, every relative link resolves, and README.md,
//! ARCHITECTURE.md, the guide and the decision records keep the style rules (no dates, commit
//! hashes, issue or stop numbers; no paragraph longer than twelve lines; the length limits).
//!
//! `WAGGLE_BLESS=1 cargo test --release --test docs` rewrites the generated pages instead of
//! comparing them.

use std::path::{Path, PathBuf};
use std::process::Command;

use waggle_tests::{waggle, workspace_root};

const MAX_PARAGRAPH_LINES: usize = 12;

// --- generated pages ------------------------------------------------------------------------

/// `waggle ARGS --help`, as a user sees it.
fn help(args: &[&str]) -> String {
    let out = waggle()
        .args(args)
        .arg("--help")
        .output()
        .expect("run waggle --help");
    assert!(
        out.status.success(),
        "waggle {} --help failed: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("help is UTF-8")
}

/// The subcommands of the command at `path` (the one definition both binaries parse with), in
/// the order the definition declares them, `help` left out.
fn subcommands(path: &[String]) -> Vec<String> {
    let mut command = commands::command();
    command.build();
    let mut at = &command;
    for name in path {
        at = at.find_subcommand(name).expect("a listed subcommand");
    }
    at.get_subcommands()
        .map(|c| c.get_name().to_owned())
        .filter(|n| n != "help")
        .collect()
}

fn cli_page() -> String {
    let mut page = String::from(
        "# Command line\n\n<!-- Generated from `waggle --help` and every command's `--help`; do \
         not edit. Regenerate: WAGGLE_BLESS=1 cargo test --release --test docs. -->\n\n\
         Every command of `waggle`, with the help it prints. `waggle help COMMAND` prints the \
         same.\n",
    );
    let mut stack: Vec<Vec<String>> = vec![Vec::new()];
    while let Some(path) = stack.pop() {
        let args: Vec<&str> = path.iter().map(String::as_str).collect();
        let text = help(&args);
        let title = if path.is_empty() {
            "waggle".to_string()
        } else {
            format!("waggle {}", path.join(" "))
        };
        page.push_str(&format!(
            "\n## `{title}`\n\n```text\n{}\n```\n",
            text.trim_end()
        ));
        // Depth first, in the order the help lists them: the stack takes them reversed.
        for name in subcommands(&path).into_iter().rev() {
            let mut child = path.clone();
            child.push(name);
            stack.push(child);
        }
    }
    page
}

fn check_generated(relative: &str, fresh: &str) {
    let path = workspace_root().join(relative);
    if std::env::var_os("WAGGLE_BLESS").is_some() {
        std::fs::write(&path, fresh).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        committed == fresh,
        "{relative} is stale: regenerate it with `WAGGLE_BLESS=1 cargo test --release --test docs` \
         (first differing line: {:?})",
        committed
            .lines()
            .zip(fresh.lines())
            .find(|(a, b)| a != b)
            .map_or_else(
                || "(one is a prefix of the other)".to_string(),
                |(a, b)| format!("{a} ≠ {b}")
            )
    );
}

#[test]
fn the_command_line_reference_is_generated_from_the_parser() {
    let page = cli_page();
    for command in [
        "payload",
        "trials",
        "study",
        "study merge",
        "decode",
        "export",
    ] {
        assert!(
            page.contains(&format!("## `waggle {command}`")),
            "{command}"
        );
    }
    check_generated("docs/reference/cli.md", &page);
}

#[test]
fn the_perturbation_reference_is_generated_from_the_table() {
    check_generated(
        "docs/reference/perturbations.md",
        &perturb::reference::markdown(),
    );
}

/// One key of a file format, read from its serde struct's source.
#[derive(Debug)]
struct Field {
    key: String,
    ty: String,
    required: bool,
    doc: String,
}

/// The fields of `pub struct NAME` in the Rust file `relative`: each field's serde name
/// (`rename`), type, whether serde defaults it, and its doc comment.
fn struct_fields(relative: &str, name: &str) -> Vec<Field> {
    let source = std::fs::read_to_string(workspace_root().join(relative))
        .unwrap_or_else(|e| panic!("{relative}: {e}"));
    let head = format!("pub struct {name} {{");
    let start = source
        .find(&head)
        .unwrap_or_else(|| panic!("{relative} has no `{head}`"))
        + head.len();
    let body = &source[start..start + source[start..].find("\n}").expect("struct end")];
    let mut fields = Vec::new();
    let (mut doc, mut attrs) = (Vec::<String>::new(), String::new());
    for line in body.lines().map(str::trim) {
        if let Some(text) = line.strip_prefix("///") {
            doc.push(text.trim().to_string());
        } else if line.starts_with("#[") {
            attrs.push_str(line);
        } else if let Some(decl) = line.strip_prefix("pub ") {
            let (field, ty) = decl.split_once(':').expect("a field has a type");
            let key = attrs
                .split_once("rename = \"")
                .and_then(|(_, rest)| rest.split_once('"'))
                .map_or(field.trim(), |(renamed, _)| renamed)
                .to_string();
            fields.push(Field {
                key,
                ty: ty.trim().trim_end_matches(',').to_string(),
                required: !attrs.contains("default") && !ty.trim().starts_with("Option<"),
                doc: doc.join(" "),
            });
            doc.clear();
            attrs.clear();
        }
    }
    assert!(
        !fields.is_empty(),
        "{relative}: `{name}` has no public fields"
    );
    fields
}

/// The file formats' tables: (title, what it is, source file, struct).
const FORMATS: &[(&str, &str, &str, &str)] = &[
    (
        "Case file",
        "A mission: `waggle run`, `waggle mission`, `waggle sweep` (built-in ones in \
      `deploy/cases/`).",
        "libs/run-format/src/case.rs",
        "Case",
    ),
    (
        "Case file: `[expected]`",
        "The outcome the audit checks.",
        "libs/run-format/src/case.rs",
        "Expected",
    ),
    (
        "Case file: `[[faults]]`",
        "Faults the case injects.",
        "libs/run-format/src/case.rs",
        "FaultSpec",
    ),
    (
        "Study file",
        "A link study: `waggle study FILE` (built-in ones in `deploy/studies/`; \
      `waggle study NAME --print` shows one).",
        "libs/run-format/src/study_file.rs",
        "StudyFile",
    ),
    (
        "Study file: `[[vary]]`",
        "One condition and its levels.",
        "libs/run-format/src/study_file.rs",
        "Vary",
    ),
    (
        "Mission study file",
        "Whole missions against baselines (`cases` and `arms` instead of \
      `link`: the built-in `baselines` and `wind`).",
        "lab/src/harness/study/baselines.rs",
        "BaselineStudy",
    ),
    (
        "Compose file",
        "A session placed on hosts: written by `waggle compose`, run by `waggle up`.",
        "libs/compose-file/src/lib.rs",
        "Compose",
    ),
    (
        "Compose file: `[router]`",
        "The session's Zenoh router.",
        "libs/compose-file/src/lib.rs",
        "Router",
    ),
    (
        "Compose file: `[[site]]`",
        "A site's own router.",
        "libs/compose-file/src/lib.rs",
        "SiteRouter",
    ),
    (
        "Compose file: `[faults]`",
        "Faults beyond the case's, written as on the command line.",
        "libs/compose-file/src/fault.rs",
        "ExtraFaults",
    ),
    (
        "Compose file: `[[node]]`",
        "One node process.",
        "libs/compose-file/src/lib.rs",
        "Node",
    ),
];

fn files_page() -> String {
    let mut page = String::from(
        "# Case, study and compose files\n\n<!-- Generated from the serde structs each file is read \
         into; do not edit. Regenerate: WAGGLE_BLESS=1 cargo test --release --test docs. -->\n\n\
         Every file is TOML, and a key not listed here is refused naming it.\n",
    );
    for (title, what, relative, name) in FORMATS {
        page.push_str(&format!(
            "\n## {title}\n\n{what} Read into `{name}` ([{relative}](../../{relative})).\n\n\
             | Key | Type | Required | Meaning |\n|---|---|---|---|\n"
        ));
        for f in struct_fields(relative, name) {
            page.push_str(&format!(
                "| `{}` | `{}` | {} | {} |\n",
                f.key,
                f.ty,
                if f.required { "yes" } else { "no" },
                f.doc.replace('|', "\\|")
            ));
        }
    }
    page
}

#[test]
fn the_file_reference_is_generated_from_the_formats() {
    let page = files_page();
    // Every key a built-in case or study uses is on the page.
    for dir in ["deploy/cases", "deploy/studies"] {
        let mut files: Vec<PathBuf> = std::fs::read_dir(workspace_root().join(dir))
            .expect("built-in files")
            .map(|e| e.expect("entry").path())
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .collect();
        files.sort();
        for file in files {
            let text = std::fs::read_to_string(&file).expect("read");
            let table: toml::Table = toml::from_str(&text).expect("TOML");
            for key in table.keys() {
                assert!(
                    page.contains(&format!("| `{key}` |")),
                    "{}: key {key} is not on the page",
                    file.display()
                );
            }
        }
    }
    check_generated("docs/reference/files.md", &page);
}

// --- the book -------------------------------------------------------------------------------

fn mdbook() -> PathBuf {
    let path = std::env::var_os("WAGGLE_THIRD_PARTY")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("third_party"))
        .join("mdbook/mdbook");
    assert!(
        path.is_file(),
        "{}: missing (run `bash deploy/setup.sh`, which installs mdBook)",
        path.display()
    );
    path
}

#[test]
fn the_user_guide_builds_with_mdbook() {
    let out_dir = std::env::temp_dir().join(format!("waggle-book-{}", std::process::id()));
    let out = Command::new(mdbook())
        .arg("build")
        .arg(workspace_root().join("docs"))
        .arg("--dest-dir")
        .arg(&out_dir)
        .output()
        .expect("run mdbook");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let _ = std::fs::remove_dir_all(&out_dir);
    assert!(out.status.success(), "mdbook build docs failed:\n{stderr}");
    assert!(
        !stderr.contains("WARN") && !stderr.contains("ERROR"),
        "mdbook build docs warned:\n{stderr}"
    );
}

// --- style and links ------------------------------------------------------------------------

/// README.md, ARCHITECTURE.md and every Markdown page under docs/, sorted.
fn held_pages() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .map(|e| e.expect("dir entry").path())
            .collect();
        entries.sort();
        for path in entries {
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "md") {
                out.push(path);
            }
        }
    }
    let root = workspace_root();
    let mut pages = vec![root.join("README.md"), root.join("ARCHITECTURE.md")];
    walk(&root.join("docs"), &mut pages);
    pages
}

/// What a page breaks of the style rules, one line each (empty: none).
fn style_faults(text: &str, max_lines: Option<usize>) -> Vec<String> {
    let mut faults = Vec::new();
    let lines: Vec<&str> = text.lines().collect();
    if let Some(max) = max_lines
        && lines.len() > max
    {
        faults.push(format!("{} lines (at most {max})", lines.len()));
    }
    let mut fenced = false;
    let mut paragraph_start: Option<usize> = None;
    let close = |start: &mut Option<usize>, end: usize, faults: &mut Vec<String>| {
        if let Some(s) = start.take()
            && end - s > MAX_PARAGRAPH_LINES
        {
            faults.push(format!(
                "line {}: a paragraph of {} lines (at most {MAX_PARAGRAPH_LINES})",
                s + 1,
                end - s
            ));
        }
    };
    for (i, line) in lines.iter().enumerate() {
        let trimmed = line.trim_start();
        if trimmed.starts_with("```") {
            close(&mut paragraph_start, i, &mut faults);
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        for fault in line_faults(line) {
            faults.push(format!("line {}: {fault}", i + 1));
        }
        let starts_block = trimmed.is_empty()
            || trimmed.starts_with('|')
            || trimmed.starts_with('#')
            || trimmed.starts_with("<!--")
            || is_list_item(trimmed);
        if starts_block {
            close(&mut paragraph_start, i, &mut faults);
        }
        if !trimmed.is_empty() && !trimmed.starts_with('|') && !trimmed.starts_with('#') {
            paragraph_start.get_or_insert(i);
        }
    }
    close(&mut paragraph_start, lines.len(), &mut faults);
    faults
}

fn is_list_item(trimmed: &str) -> bool {
    if trimmed.starts_with("- ") || trimmed.starts_with("* ") || trimmed.starts_with("+ ") {
        return true;
    }
    let digits = trimmed.bytes().take_while(u8::is_ascii_digit).count();
    digits > 0 && trimmed[digits..].starts_with(". ")
}

/// Dates, commit hashes and issue or stop numbers on one line of prose.
fn line_faults(line: &str) -> Vec<String> {
    let mut faults = Vec::new();
    let words: Vec<&str> = line
        .split(|c: char| !c.is_ascii_alphanumeric() && c != '-')
        .filter(|w| !w.is_empty())
        .collect();
    for word in &words {
        if is_date(word) {
            faults.push(format!("a date ({word})"));
        }
        if is_commit_hash(word) {
            faults.push(format!("a commit hash ({word})"));
        }
    }
    let lower = line.to_ascii_lowercase();
    let tokens: Vec<&str> = lower
        .split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|w| !w.is_empty())
        .collect();
    for pair in tokens.windows(2) {
        if matches!(pair[0], "issue" | "issues" | "stop" | "session")
            && pair[1].bytes().all(|b| b.is_ascii_digit())
        {
            faults.push(format!("a history reference ({} {})", pair[0], pair[1]));
        }
    }
    faults
}

fn is_date(word: &str) -> bool {
    let b = word.as_bytes();
    b.len() == 10
        && b[4] == b'-'
        && b[7] == b'-'
        && [0, 1, 2, 3, 5, 6, 8, 9]
            .iter()
            .all(|&i| b[i].is_ascii_digit())
        && (word.starts_with("19") || word.starts_with("20"))
}

/// 7 to 40 lowercase hex digits with at least one letter and one digit: git's abbreviated or
/// full object names. Longer digests (SHA-256 checksums) are not commits.
fn is_commit_hash(word: &str) -> bool {
    (7..=40).contains(&word.len())
        && word
            .bytes()
            .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
        && word.bytes().any(|b| b.is_ascii_digit())
        && word.bytes().any(|b| b.is_ascii_lowercase())
}

/// The targets of a page's inline links and images, `[text](target)`, outside code.
fn link_targets(text: &str) -> Vec<(usize, String)> {
    let mut targets = Vec::new();
    let mut fenced = false;
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        // Inline code spans are not links.
        let prose: String = line
            .split('`')
            .enumerate()
            .filter(|(k, _)| k % 2 == 0)
            .map(|(_, s)| s)
            .collect::<Vec<_>>()
            .join(" ");
        let mut rest = prose.as_str();
        while let Some(at) = rest.find("](") {
            let after = &rest[at + 2..];
            let Some(end) = after.find(')') else { break };
            let target = after[..end].split_whitespace().next().unwrap_or("");
            targets.push((i + 1, target.to_string()));
            rest = &after[end..];
        }
    }
    targets
}

/// GitHub's and mdBook's heading anchors: lowercase, spaces to `-`, punctuation dropped.
fn anchors(text: &str) -> Vec<String> {
    let mut fenced = false;
    let mut out = Vec::new();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        }
        if fenced || !line.starts_with('#') {
            continue;
        }
        let heading = line.trim_start_matches('#').trim();
        out.push(
            heading
                .chars()
                .filter_map(|c| match c {
                    ' ' => Some('-'),
                    c if c.is_alphanumeric() || c == '-' || c == '_' => {
                        Some(c.to_lowercase().next().unwrap_or(c))
                    }
                    _ => None,
                })
                .collect(),
        );
    }
    out
}

#[test]
fn readme_architecture_and_the_guide_keep_the_style_rules() {
    let root = workspace_root();
    let mut faults = Vec::new();
    for page in held_pages() {
        let relative = page.strip_prefix(&root).unwrap_or(&page);
        let limit = match relative.to_str().unwrap_or_default() {
            "README.md" => Some(200),
            "ARCHITECTURE.md" => Some(400),
            r if r.starts_with("docs/decisions/") => Some(90),
            _ => None,
        };
        // The command-line page is clap's help, held by the parser's own tests.
        if relative == Path::new("docs/reference/cli.md") {
            continue;
        }
        let text = std::fs::read_to_string(&page).expect("read page");
        for fault in style_faults(&text, limit) {
            faults.push(format!("{}: {fault}", relative.display()));
        }
    }
    assert!(faults.is_empty(), "style faults:\n{}", faults.join("\n"));
}

#[test]
fn every_relative_link_resolves() {
    let root = workspace_root();
    let mut broken = Vec::new();
    for page in held_pages() {
        let text = std::fs::read_to_string(&page).expect("read page");
        let dir = page.parent().expect("a page has a directory");
        for (line, target) in link_targets(&text) {
            if target.is_empty() || target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (file, anchor) = target.split_once('#').unwrap_or((&target, ""));
            let resolved = if file.is_empty() {
                page.clone()
            } else {
                dir.join(file)
            };
            let relative = page
                .strip_prefix(&root)
                .unwrap_or(&page)
                .display()
                .to_string();
            if !resolved.exists() {
                broken.push(format!("{relative}:{line}: {target} (no such file)"));
                continue;
            }
            if !anchor.is_empty()
                && resolved.extension().is_some_and(|e| e == "md")
                && !anchors(&std::fs::read_to_string(&resolved).unwrap_or_default())
                    .iter()
                    .any(|a| a == anchor)
            {
                broken.push(format!("{relative}:{line}: {target} (no such heading)"));
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn the_style_check_finds_what_it_forbids() {
    assert_eq!(style_faults("Fixed on 2026-11-30.\n", None).len(), 1);
    assert_eq!(style_faults("See commit 4d015e9 for it.\n", None).len(), 1);
    assert_eq!(style_faults("As issue 27 asked.\n", None).len(), 1);
    assert_eq!(style_faults("Since stop 57.\n", None).len(), 1);
    assert!(
        style_faults(
            "A sha256 of 15ddf16d927d6b7c88c1e8b9adb72fe17dc17d08f6ac81f7404ec4d5e9528e56.\n",
            None
        )
        .is_empty()
    );
    assert!(style_faults("```\n2026-11-30 in code\n```\n", None).is_empty());
    let long: String = (0..13)
        .map(|i| format!("line {i} of one paragraph\n"))
        .collect();
    assert_eq!(style_faults(&long, None).len(), 1);
    let list: String = (0..13).map(|i| format!("- item {i}\n")).collect();
    assert!(style_faults(&list, None).is_empty());
    let table: String = (0..20).map(|i| format!("| {i} | x |\n")).collect();
    assert!(style_faults(&table, None).is_empty());
    assert_eq!(style_faults("a\nb\nc\n", Some(2)).len(), 1);
    assert_eq!(
        link_targets("See [a](a.md#b), `[not](x)` and ![p](p.png).\n"),
        vec![(1, "a.md#b".to_string()), (1, "p.png".to_string())]
    );
    assert_eq!(
        anchors("# Real cameras' recordings\n"),
        vec!["real-cameras-recordings"]
    );
}
