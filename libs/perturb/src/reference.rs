//! The user guide's reference page of perturbation terms and sensor presets, rendered from
//! [`PARAMETERS`] and [`PRESETS`] themselves, so the page cannot drift from the table the
//! trials read (`tests/tests/docs.rs` fails when `docs/reference/perturbations.md` differs).

use std::fmt::Write as _;

use crate::preset::PRESETS;
use crate::spec::PARAMETERS;

/// The whole page, Markdown.
pub fn markdown() -> String {
    let mut page = String::from(
        "# Perturbations and presets\n\n\
         <!-- Generated from libs/perturb (spec::PARAMETERS, preset::PRESETS); do not edit. \
         Regenerate: WAGGLE_BLESS=1 cargo test --release --test docs. -->\n\n\
         Every term is off at its default. Give terms with `--perturb KEY=VALUE` (`waggle trials`, \
         `waggle link`) or in a study file (`fixed`, `[[vary]]`); a preset (`--sensor-preset NAME`, \
         a study's `sensor_preset`) sets several `events.*` terms at once, and explicit terms \
         override it.\n\n",
    );
    let mut group = "";
    for p in PARAMETERS {
        let this_group = p.key.split('.').next().unwrap_or(p.key);
        if this_group != group {
            group = this_group;
            let _ = write!(
                page,
                "## `{group}.*`\n\n| Key | Unit | Default | Range | Meaning |\n|---|---|---|---|---|\n"
            );
        }
        let range = if p.integer {
            format!("{}–{} (whole)", p.min, p.max)
        } else {
            format!("{}–{}", p.min, p.max)
        };
        let _ = writeln!(
            page,
            "| `{}` | {} | {} | {} | {} |",
            p.key,
            p.unit,
            p.default,
            range,
            p.doc.replace('|', "\\|")
        );
        if PARAMETERS
            .iter()
            .skip_while(|q| q.key != p.key)
            .nth(1)
            .is_none_or(|next| !next.key.starts_with(&format!("{group}.")))
        {
            page.push('\n');
        }
    }
    page.push_str("## Sensor presets\n\n");
    for preset in PRESETS {
        let _ = write!(page, "### `{}`\n\n{}.\n\n", preset.name, preset.source);
        page.push_str("| Term | Value |\n|---|---|\n");
        for (key, value) in preset.terms {
            let _ = writeln!(page, "| `{key}` | {value} |");
        }
        page.push('\n');
        if !preset.unmodelled.is_empty() {
            let _ = write!(page, "Not modelled yet: {}.\n\n", preset.unmodelled);
        }
    }
    page.truncate(page.trim_end().len());
    page.push('\n');
    page
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_term_and_preset_is_on_the_page_once() {
        let page = super::markdown();
        // Presets repeat terms in their own tables; each term's definition row is above them.
        let (terms, presets) = page
            .split_once("## Sensor presets")
            .expect("the page has a presets section");
        for p in crate::spec::PARAMETERS {
            assert_eq!(
                terms.matches(&format!("| `{}` |", p.key)).count(),
                1,
                "{}",
                p.key
            );
        }
        for preset in crate::preset::PRESETS {
            assert!(
                presets.contains(&format!("### `{}`", preset.name)),
                "{}",
                preset.name
            );
        }
    }
}
