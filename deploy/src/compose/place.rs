//! `--place ROLE=HOST`: which host runs which node (`camera-*=b`, `observer-O?=c`,
//! `router=a`), applied in order so a later placement overrides an earlier one.

use anyhow::{Result, bail};

use super::Compose;

/// The name that places the router.
pub const ROUTER: &str = "router";

pub use commands::assign::HostPlacement;

/// `name` matches `pattern` (`*` any run of characters, `?` one character).
pub fn glob_matches(pattern: &str, name: &str) -> bool {
    let p: Vec<char> = pattern.chars().collect();
    let n: Vec<char> = name.chars().collect();
    // The classic two-pointer match with backtracking to the last `*`.
    let (mut i, mut j) = (0, 0);
    let mut star: Option<(usize, usize)> = None;
    while j < n.len() {
        if i < p.len() && (p[i] == '?' || p[i] == n[j]) {
            i += 1;
            j += 1;
        } else if i < p.len() && p[i] == '*' {
            star = Some((i, j));
            i += 1;
        } else if let Some((si, sj)) = star {
            i = si + 1;
            j = sj + 1;
            star = Some((si, sj + 1));
        } else {
            return false;
        }
    }
    p[i..].iter().all(|c| *c == '*')
}

/// Applies `placements` in order; a pattern that matches nothing is an error naming it.
pub fn place(compose: &mut Compose, placements: &[HostPlacement]) -> Result<()> {
    for p in placements {
        let mut matched = false;
        for n in compose
            .nodes
            .iter_mut()
            .filter(|n| glob_matches(&p.pattern, &n.role.name()))
        {
            n.host = p.host.clone();
            matched = true;
        }
        if glob_matches(&p.pattern, ROUTER) {
            compose.router.host = p.host.clone();
            matched = true;
        }
        if !matched {
            let mut names: Vec<String> = compose.nodes.iter().map(|n| n.role.name()).collect();
            names.push(ROUTER.to_string());
            bail!(
                "--place {}={}: {:?} matches none of {}",
                p.pattern,
                p.host,
                p.pattern,
                names.join(", ")
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn globs_match_whole_names() {
        for (p, n) in [
            ("camera-*", "camera-O1"),
            ("*", "sim"),
            ("observer-O?", "observer-O3"),
            ("*-O2", "camera-O2"),
            ("c*m*a-*", "camera-O10"),
            ("sim", "sim"),
        ] {
            assert!(glob_matches(p, n), "{p} {n}");
        }
        for (p, n) in [
            ("camera-*", "observer-O1"),
            ("sim", "simulator"),
            ("observer-O?", "observer-O10"),
            ("", "sim"),
            ("*-O2", "camera-O21"),
        ] {
            assert!(!glob_matches(p, n), "{p} {n}");
        }
    }

    #[test]
    fn placements_parse_and_bad_ones_name_the_input() {
        let p: HostPlacement = "camera-*=b".parse().unwrap();
        assert_eq!(p.pattern, "camera-*");
        assert_eq!(p.host, "b");
        for bad in ["camera-*", "=b", "sim=", "sim=a b", "sim=a/b"] {
            let e = bad.parse::<HostPlacement>().unwrap_err();
            assert!(e.to_string().contains(bad), "{e}");
        }
    }
}
