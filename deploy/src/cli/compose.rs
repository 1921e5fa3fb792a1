//! `waggle compose CASE … --out FILE`: writes the session's compose file (which node runs on
//! which host with which arguments) and, for an authenticated session, its credentials
//! directory beside it ([`crate::compose`]).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

use crate::compose::Compose;
use crate::compose::build::compose;
use crate::compose::site::sites;
use commands::compose::ComposeArgs;

/// The credentials directory of compose file `file`: `session.toml` → `session.secrets`.
pub fn secrets_dir_of(file: &Path) -> PathBuf {
    file.with_extension("secrets")
}

pub fn run(args: ComposeArgs) -> Result<()> {
    let (case, modality, opts) = super::run::session_options(args.session)?;
    let mut options = opts.compose_options(&case, modality)?;
    options.placements = args.place;
    options.router_listen = args.router;
    let mut c = compose(&case, &options)?;
    c.sites = sites(&args.site, &args.site_serves)?;
    let secrets = secrets_dir_of(&args.out);
    if secrets == args.out {
        bail!(
            "--out {}: give the compose file an extension (e.g. .toml)",
            args.out.display()
        );
    }
    if c.auth {
        c.secrets = Some(PathBuf::from(
            secrets
                .file_name()
                .context("the compose file has no name")?,
        ));
    }
    c.check().context("checking the composed session")?;
    let ca = match (&args.ca_cert, &args.ca_key) {
        (Some(cert), Some(key)) if c.auth => Some(bus::tls::ExistingCa::read(cert, key)?),
        (Some(_), _) => bail!("--ca-cert: an open session (--no-auth) has no certificates"),
        _ => None,
    };
    if c.auth {
        bus::SessionSecrets::create_kept_signed_by(
            &secrets,
            &c.users(),
            bus::auth::CERTIFICATE_VALIDITY,
            ca.as_ref(),
        )
        .context("writing the session's credentials")?;
    }
    std::fs::write(&args.out, c.to_toml()?)
        .with_context(|| format!("writing {}", args.out.display()))?;
    describe(&c, &args.out, c.auth.then_some(secrets.as_path()));
    Ok(())
}

/// Which host runs what, and the command to run on each.
fn describe(c: &Compose, file: &Path, secrets: Option<&Path>) {
    println!(
        "session {} ({} nodes) written to {}",
        c.session,
        c.nodes.len(),
        file.display()
    );
    if let Some(s) = secrets {
        println!(
            "credentials in {} (private; `waggle bundle {} --host NAME --out DIR` copies the \
             file and only that host's credentials, for that host)",
            s.display(),
            file.display()
        );
    }
    println!(
        "router on {} listening on {}",
        c.router.host,
        c.router.listen.join(", ")
    );
    for site in &c.sites {
        println!(
            "site router on {} listening on {}, serving {}",
            site.host,
            site.listen.join(", "),
            site.hosts().cloned().collect::<Vec<_>>().join(", ")
        );
    }
    for host in c.hosts() {
        let nodes: Vec<String> = c.nodes_on(&host).map(|n| n.role.name()).collect();
        println!(
            "  {host}: {}   →   waggle up {} --host {host}",
            if nodes.is_empty() {
                "(router only)".to_string()
            } else {
                nodes.join(" ")
            },
            file.display()
        );
    }
}
