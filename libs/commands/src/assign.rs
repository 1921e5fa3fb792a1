//! Host assignments on the command line: `--place ROLE=HOST`, `--site HOST=ENDPOINT` and
//! `--site-serves HOST=SITE`, each `LEFT=RIGHT` with its host side checked as a host name.

use std::str::FromStr;

use anyhow::{Result, bail};

/// A host or role name: it becomes part of a user name and a key, so letters, digits, `-`, `_`.
pub fn check_name(what: &str, name: &str) -> Result<()> {
    if name.is_empty()
        || name.len() > 64
        || !name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
    {
        bail!("{what} {name:?} must be 1–64 letters, digits, '-' or '_'");
    }
    Ok(())
}

/// A `LEFT=RIGHT` option (`--place ROLE=HOST`, `--site HOST=ENDPOINT`, …) that does not parse.
/// clap names the option; this names the input and what is wrong with it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{input:?}: {why}")]
pub struct AssignmentError {
    pub input: String,
    pub why: String,
}

/// `s` as `LEFT=RIGHT`, both sides non-empty, and `RIGHT` (or `LEFT`, when `host_left`) a host
/// name; `shape` is the form the error suggests (`ROLE=HOST (e.g. camera-*=b)`).
pub fn host_assignment<'a>(
    s: &'a str,
    shape: &str,
    host_left: bool,
) -> Result<(&'a str, &'a str), AssignmentError> {
    let err = |why: String| AssignmentError {
        input: s.to_string(),
        why,
    };
    let (left, right) = s
        .split_once('=')
        .ok_or_else(|| err(format!("not {shape}")))?;
    if left.is_empty() || right.is_empty() {
        return Err(err(format!("an empty side: want {shape}")));
    }
    let host = if host_left { left } else { right };
    check_name("host", host).map_err(|e| err(e.to_string()))?;
    Ok((left, right))
}

/// One `PATTERN=HOST` placement.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HostPlacement {
    /// A process name, with `*` (any run of characters) and `?` (one character).
    pub pattern: String,
    pub host: String,
}

impl FromStr for HostPlacement {
    type Err = AssignmentError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let (pattern, host) = host_assignment(s, "ROLE=HOST (e.g. camera-*=b)", false)?;
        Ok(Self {
            pattern: pattern.to_string(),
            host: host.to_string(),
        })
    }
}

/// `HOST=VALUE`, the host checked as a host name.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HostIs {
    pub host: String,
    pub value: String,
}

impl FromStr for HostIs {
    type Err = AssignmentError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let (host, value) = host_assignment(s, "HOST=VALUE (e.g. b=quic/10.0.0.2:7447)", true)?;
        Ok(Self {
            host: host.to_string(),
            value: value.to_string(),
        })
    }
}
