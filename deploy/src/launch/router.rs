//! The session's Zenoh router: hosted by the launcher of the router's host (`waggle up`,
//! `waggle run`) or on its own (`waggle router`). Authenticated sessions accept only the users
//! of the session's dictionary and enforce each role's access list ([`bus::access`]); an open
//! router (`auth = false`) is refused beyond loopback.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use std::collections::BTreeSet;

use bus::access::RoleAccess;
use bus::{Bus, Credentials, Endpoints, Inbound, SessionSecrets};
use proto::Role;

use crate::compose::{Compose, SiteRouter};

/// Opens the router of `compose`'s session on this machine.
pub fn open(compose: &Compose, secrets: Option<&SessionSecrets>) -> Result<Bus> {
    Bus::open_config(&compose.session, config(compose, secrets)?).with_context(|| {
        format!(
            "opening the session's router on {}",
            compose.router.listen.join(", ")
        )
    })
}

/// The router's Zenoh configuration for `compose`'s session.
pub fn config(compose: &Compose, secrets: Option<&SessionSecrets>) -> Result<zenoh::Config> {
    let endpoints = Endpoints {
        connect: compose.router.connect.clone(),
        listen: compose.router.listen.clone(),
    };
    if !compose.auth {
        return open_config(&compose.session, &endpoints);
    }
    let secrets = secrets.context("an authenticated router needs the session's secrets")?;
    secrets.check_dictionary()?;
    let keys = proto::Keys::new(&compose.session)?;
    Ok(bus::router_config(
        &endpoints,
        secrets.dictionary(),
        &bus::access::router_acl(&keys, &session_access(compose, &keys)?, None),
        &bus::access::session_router_zid(&compose.session),
    )?)
}

/// The Zenoh configuration of `site`'s router: it dials the session's router as its host's
/// launcher and serves its hosts' processes with the session's access list.
pub fn site_config(
    compose: &Compose,
    site: &SiteRouter,
    secrets: Option<&SessionSecrets>,
) -> Result<zenoh::Config> {
    let secrets = secrets.context("a site's router needs the session's secrets")?;
    secrets.check_dictionary()?;
    let user = compose.launcher_of(&site.host);
    let file = secrets
        .file_of(&user)
        .with_context(|| format!("no credentials for {user}, the site router's own"))?;
    let credentials = Credentials::read(file)?;
    let keys = proto::Keys::new(&compose.session)?;
    let zid = bus::access::session_router_zid(&compose.session);
    let endpoints = Endpoints {
        connect: compose.router_dial_from(&site.host),
        listen: site.listen.clone(),
    };
    Ok(bus::site_router_config(
        &endpoints,
        &credentials,
        secrets.dictionary(),
        &bus::access::router_acl(&keys, &session_access(compose, &keys)?, Some(&zid)),
    )?)
}

/// What every process of `compose`'s session may do on the bus: the mission's processes, the
/// recorder, each host's launcher — a site's launcher, which is its site's router, with the
/// union of what the processes of its hosts may do (the session's router sees them only
/// through it).
fn session_access(compose: &Compose, keys: &proto::Keys) -> Result<Vec<RoleAccess>> {
    let case = compose.case()?;
    let hosts: Vec<String> = compose
        .hosts()
        .into_iter()
        .filter(|h| h != compose.supervisor_host())
        .collect();
    let mut access = bus::access::role_access(keys, case.observers, compose.records(), &hosts);
    for site in &compose.sites {
        let users: BTreeSet<String> = site.hosts().flat_map(|h| compose.users_on(h)).collect();
        let parts: Vec<RoleAccess> = access
            .iter()
            .filter(|a| users.contains(&a.user))
            .cloned()
            .collect();
        let launcher = compose.launcher_of(&site.host);
        let union = bus::access::union_of(&launcher, &parts);
        match access.iter_mut().find(|a| a.user == launcher) {
            Some(a) => *a = union,
            None => access.push(union),
        }
    }
    Ok(access)
}

/// An open router (`--no-auth`): refused beyond loopback, with a warning.
pub fn open_config(session: &str, endpoints: &Endpoints) -> Result<zenoh::Config> {
    let exposed = endpoints.non_loopback_listeners();
    if !exposed.is_empty() {
        bail!(
            "an open bus (--no-auth) with a router listening on {} would open the session to \
             the network: authenticate, or listen on 127.0.0.1",
            exposed.join(", ")
        );
    }
    eprintln!(
        "warning: --no-auth: the bus is open — any local process can join session {session}, \
         read every key (ground truth included) and publish on any"
    );
    Ok(bus::open_router_config(endpoints)?)
}

/// How long a stand-alone router stays up once the mission report is in and no process of
/// the session is left, at most (it leaves earlier when every process has gone).
const LINGER_AFTER_REPORT: Duration = Duration::from_secs(30);

/// Serves the session's router until Ctrl-C, or until the mission report has been seen and
/// every process of the session has left (or `LINGER_AFTER_REPORT` has passed).
pub fn serve(
    session: &str,
    config: zenoh::Config,
    listen: &[String],
    stop: &AtomicBool,
) -> Result<()> {
    let mut bus = Bus::open_config(session, config)
        .with_context(|| format!("opening the session's router on {}", listen.join(", ")))?;
    let keys = bus.keys().clone();
    // The router's own session: local, so no access list applies to it.
    bus.subscribe(&keys.sched_report())?;
    bus.watch_liveliness(&keys.alive_any())?;
    let me = bus::Process::new(Role::Launcher, "router");
    bus.declare_token(&me.alive_key(&keys)?)?;
    let mine = me.alive_key(&keys)?;
    let mut report_at: Option<Instant> = None;
    eprintln!(
        "router of session {session} listening on {}",
        listen.join(", ")
    );
    while !stop.load(Ordering::SeqCst) {
        if let Some(Inbound::Data { .. }) = bus.recv(Duration::from_millis(200)) {
            report_at.get_or_insert_with(Instant::now);
        }
        if let Some(at) = report_at {
            let others = bus.alive_keys().iter().filter(|k| **k != mine).count();
            if others == 0 || at.elapsed() > LINGER_AFTER_REPORT {
                break;
            }
        }
    }
    bus.close()?;
    let refused = super::refusals::counted();
    if !refused.is_empty() {
        eprintln!(
            "router of session {session} refused: {}",
            describe_refusals(&refused)
        );
    }
    Ok(())
}

/// `0 TLS handshakes (certificates), 2 Zenoh handshakes (passwords), …`.
pub fn describe_refusals(r: &crate::run_dir::RouterRefusals) -> String {
    format!(
        "{} TLS handshakes (certificates), {} Zenoh handshakes (passwords), {} links with no \
         access rule, {} data messages denied by a rule",
        r.certificate, r.handshake, r.no_access_rule, r.denied_messages
    )
}
