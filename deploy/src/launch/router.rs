//! The session's Zenoh router: hosted by the launcher of the router's host (`waggle up`,
//! `waggle run`) or on its own (`waggle router`). Authenticated sessions accept only the users
//! of the session's dictionary and enforce each role's access list ([`bus::access`]); an open
//! router (`auth = false`) is refused beyond loopback.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use bus::{Bus, Endpoints, Inbound, SessionSecrets};
use proto::Role;

use crate::compose::Compose;

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
    let case = compose.case()?;
    let hosts: Vec<String> = compose
        .hosts()
        .into_iter()
        .filter(|h| h != compose.supervisor_host())
        .collect();
    let access = bus::access::role_access(&keys, case.observers, compose.records(), &hosts);
    Ok(bus::router_config(
        &endpoints,
        secrets.dictionary(),
        &bus::access::router_acl(&keys, &access),
    )?)
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
/// every process of the session has left (or [`LINGER_AFTER_REPORT`] has passed).
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
    Ok(())
}
