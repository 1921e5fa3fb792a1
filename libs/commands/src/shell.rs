//! `waggle completions SHELL` and `waggle man --out DIR`: the shell completion scripts and the
//! manual pages, generated from the one definition ([`crate::command`]) by `clap_complete` and
//! `clap_mangen`, so they cannot disagree with `--help`.

use std::io::Write;
use std::path::{Path, PathBuf};

use clap::Args;

/// `waggle completions SHELL`.
#[derive(Debug, Args)]
pub struct CompletionsArgs {
    /// The shell.
    #[arg(value_enum)]
    pub shell: clap_complete::Shell,
}

/// `waggle man --out DIR`.
#[derive(Debug, Args)]
pub struct ManArgs {
    /// The directory to write the pages into (created if absent).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

/// Writes `shell`'s completion script for `waggle` to `out`.
pub fn completions(shell: clap_complete::Shell, out: &mut dyn Write) {
    clap_complete::generate(shell, &mut crate::command(), "waggle", out);
}

/// Writes waggle.1 and one page per command (waggle-COMMAND.1, waggle-COMMAND-SUB.1) into
/// `dir`, returning the files written, sorted.
///
/// # Errors
///
/// When `dir` cannot be created or a page cannot be written, naming the path.
pub fn man_pages(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let named = |e: std::io::Error, p: &Path| {
        std::io::Error::new(e.kind(), format!("{}: {e}", p.display()))
    };
    std::fs::create_dir_all(dir).map_err(|e| named(e, dir))?;
    let mut command = crate::command();
    command.build();
    let mut written = Vec::new();
    write_pages(&command, "waggle", dir, &mut written).map_err(|(e, p)| named(e, &p))?;
    written.sort();
    Ok(written)
}

fn write_pages(
    command: &clap::Command,
    name: &str,
    dir: &Path,
    written: &mut Vec<PathBuf>,
) -> Result<(), (std::io::Error, PathBuf)> {
    let page = command
        .clone()
        .name(name.to_owned())
        .bin_name(name.replace('-', " "));
    let path = dir.join(format!("{name}.1"));
    let mut bytes = Vec::new();
    clap_mangen::Man::new(page)
        .render(&mut bytes)
        .map_err(|e| (e, path.clone()))?;
    std::fs::write(&path, bytes).map_err(|e| (e, path.clone()))?;
    written.push(path);
    for sub in command.get_subcommands() {
        if sub.get_name() == "help" {
            continue;
        }
        write_pages(sub, &format!("{name}-{}", sub.get_name()), dir, written)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_man_page_per_command_and_subcommand() {
        let dir = std::env::temp_dir().join(format!("waggle-man-{}", std::process::id()));
        let pages = man_pages(&dir).unwrap();
        let names: Vec<String> = pages
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        for name in [
            "waggle.1",
            "waggle-trials.1",
            "waggle-study-merge.1",
            "waggle-run.1",
        ] {
            assert!(names.contains(&name.to_owned()), "{name} not in {names:?}");
        }
        let top = crate::command().get_subcommands().count() - 1; // without `help`
        assert!(
            pages.len() > top,
            "{} pages for {top} commands",
            pages.len()
        );
        let trials = std::fs::read_to_string(dir.join("waggle-trials.1")).unwrap();
        assert!(trials.contains("modality"), "{trials}");
        let _ = std::fs::remove_dir_all(&dir);
        // A path that cannot be a directory is an error naming it.
        let file = std::env::temp_dir().join(format!("waggle-man-file-{}", std::process::id()));
        std::fs::write(&file, b"x").unwrap();
        let e = man_pages(&file.join("sub")).unwrap_err();
        assert!(e.to_string().contains("waggle-man-file"), "{e}");
        let _ = std::fs::remove_file(&file);
    }

    #[test]
    fn completions_know_every_command() {
        for shell in [
            clap_complete::Shell::Bash,
            clap_complete::Shell::Zsh,
            clap_complete::Shell::Fish,
        ] {
            let mut out = Vec::new();
            completions(shell, &mut out);
            let text = String::from_utf8(out).unwrap();
            for sub in crate::command().get_subcommands() {
                assert!(
                    text.contains(sub.get_name()),
                    "{shell:?} lacks {}",
                    sub.get_name()
                );
            }
            assert!(text.contains("--sensor-preset"), "{shell:?}");
        }
    }
}
