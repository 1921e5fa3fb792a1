//! Which plug-in: `python:MODULE:CLASS`, checked before any worker starts.

use std::fmt;
use std::str::FromStr;

use crate::error::PluginError;

/// A Python receiver plug-in: the class `class` of the importable module `module`.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct PluginSpec {
    pub module: String,
    pub class: String,
}

/// A dotted Python name: identifiers (ASCII letters, digits, `_`, not starting with a digit)
/// joined by dots.
fn is_dotted_name(s: &str) -> bool {
    !s.is_empty() && s.split('.').all(is_identifier)
}

fn is_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

impl FromStr for PluginSpec {
    type Err = PluginError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = |why: &str| PluginError::Spec {
            spec: s.to_owned(),
            why: why.to_owned(),
        };
        let rest = s
            .strip_prefix("python:")
            .ok_or_else(|| bad("a plug-in is named python:MODULE:CLASS"))?;
        let (module, class) = rest
            .rsplit_once(':')
            .ok_or_else(|| bad("a plug-in is named python:MODULE:CLASS"))?;
        if !is_dotted_name(module) {
            return Err(bad("MODULE is not a dotted Python name"));
        }
        if !is_identifier(class) {
            return Err(bad("CLASS is not a Python identifier"));
        }
        Ok(Self {
            module: module.to_owned(),
            class: class.to_owned(),
        })
    }
}

impl fmt::Display for PluginSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "python:{}:{}", self.module, self.class)
    }
}

#[cfg(test)]
mod tests {
    use super::PluginSpec;

    #[test]
    fn names_parse_and_print_back() {
        let spec: PluginSpec = "python:my_lab.receivers:Tracker".parse().unwrap();
        assert_eq!(spec.module, "my_lab.receivers");
        assert_eq!(spec.class, "Tracker");
        assert_eq!(spec.to_string(), "python:my_lab.receivers:Tracker");
    }

    #[test]
    fn bad_names_are_refused_naming_the_part() {
        for (s, why) in [
            ("my_lab:Tracker", "python:MODULE:CLASS"),
            ("python:Tracker", "python:MODULE:CLASS"),
            ("python:my-lab:Tracker", "MODULE"),
            ("python:a..b:Tracker", "MODULE"),
            ("python:lab:1Tracker", "CLASS"),
            ("python:lab:", "CLASS"),
        ] {
            let err = s.parse::<PluginSpec>().unwrap_err().to_string();
            assert!(err.contains(why) && err.contains(s), "{s}: {err}");
        }
    }
}
