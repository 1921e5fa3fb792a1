//! Who may publish and subscribe to what: the information boundaries of docs/DESIGN.md §2 for
//! every role, as data ([`role_access`]) and as the Zenoh access-control list that enforces them
//! on the session's router ([`router_acl`]).
//!
//! Each process authenticates with its own user name (its process name: `sim`, `camera-O1`,
//! …). The router denies by default; a process may publish only the keys it owns and receive
//! only what it subscribes to. Declarations (which keys someone subscribes to, liveliness
//! tokens) flow to every authenticated process: they carry no data, and a publisher must know
//! its subscribers.

use proto::{Keys, ObserverId, Role};

use crate::handshake::{Process, mission_processes};

/// What one process may do on the bus (full key expressions).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RoleAccess {
    /// The user name it authenticates with (its process name).
    pub user: String,
    /// Keys it may publish on.
    pub publish: Vec<String>,
    /// Keys it may subscribe to (and be sent).
    pub subscribe: Vec<String>,
}

/// The access of every process of a mission with `observers` observers, plus the recorder when
/// `recorder`, the supervising launcher (which needs it only when it is not the router itself)
/// and the launcher of each host in `hosts` (multi-host sessions).
pub fn role_access(
    keys: &Keys,
    observers: usize,
    recorder: bool,
    hosts: &[String],
) -> Vec<RoleAccess> {
    let mut everyone = mission_processes(observers, true);
    if recorder {
        everyone.push(Process::singleton(Role::Recorder));
    }
    everyone.extend(hosts.iter().map(|h| Process::host_launcher(h)));
    everyone.iter().map(|p| access_of(keys, p)).collect()
}

/// The access of process `p`.
pub fn access_of(keys: &Keys, p: &Process) -> RoleAccess {
    let report = keys
        .rejects(p.role, &p.id)
        .expect("process ids are validated chunks");
    let (mut publish, subscribe) = match p.role {
        Role::Sim => (
            vec![keys.clock(), keys.sim_state(), keys.sim_contacts()],
            vec![keys.performer_setpoint(), keys.sched_cmd()],
        ),
        Role::Camera => {
            let o = observer(&p.id);
            (
                vec![
                    keys.sensor_events(&o),
                    keys.sensor_rgb(&o),
                    keys.sensor_dropped(&o),
                    keys.camera_input(&o),
                    keys.camera_report(&o),
                ],
                vec![keys.sim_state(), keys.fault(&o)],
            )
        }
        Role::Observer => {
            let o = observer(&p.id);
            (
                vec![keys.observer_all(&o)],
                vec![keys.sensor_any(&o), keys.clock(), keys.sched_session()],
            )
        }
        Role::Performer => (
            vec![keys.performer_setpoint(), keys.truth_performer()],
            vec![keys.sched_broadcast()],
        ),
        Role::Scheduler => (
            vec![
                keys.sched_cmd(),
                keys.sched_broadcast(),
                keys.sched_session(),
                keys.sched_report(),
            ],
            vec![keys.sim_state(), keys.observer_status_any()],
        ),
        Role::Recorder => (Vec::new(), vec![keys.all()]),
        // The supervising launcher (a client when the router runs on another host) injects
        // the faults and gathers everything; a host's own launcher only follows the clock (to
        // stop a camera at its dropout time) and the end of the mission.
        Role::Launcher if p.id == Role::Launcher.as_str() => {
            (vec![keys.fault_any()], vec![keys.all()])
        }
        Role::Launcher => (Vec::new(), vec![keys.clock(), keys.sched_report()]),
    };
    publish.push(report);
    RoleAccess {
        user: p.name(),
        publish,
        subscribe,
    }
}

/// One user allowed what every one of `parts` is allowed: a site's router, which carries the
/// processes of the hosts it serves to the session's router under its own name (its host's
/// launcher's), so the session's router holds it to exactly their union.
pub fn union_of(user: &str, parts: &[RoleAccess]) -> RoleAccess {
    let merged = |f: fn(&RoleAccess) -> &Vec<String>| -> Vec<String> {
        let set: std::collections::BTreeSet<String> =
            parts.iter().flat_map(|p| f(p).iter().cloned()).collect();
        set.into_iter().collect()
    };
    RoleAccess {
        user: user.to_string(),
        publish: merged(|p| &p.publish),
        subscribe: merged(|p| &p.subscribe),
    }
}

/// The Zenoh id of session `session`'s router: fixed, so that a site's router can tell the
/// session's router from its own clients (`zids` in its access list). Derived from the session
/// id (two 64-bit FNV-1a hashes): not a secret, only a name.
pub fn session_router_zid(session: &str) -> String {
    let fnv = |seed: u64| {
        session.bytes().fold(seed, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
        })
    };
    // Zenoh refuses an id written with a leading 0: the top nibble is set.
    format!(
        "{:016x}{:016x}",
        fnv(0xcbf2_9ce4_8422_2325) | 0x1000_0000_0000_0000,
        fnv(0x6c62_272e_07bb_0142)
    )
}

fn observer(id: &str) -> ObserverId {
    ObserverId::new(id).expect("camera and observer ids are observer ids")
}

/// The `access_control` section of the router's Zenoh configuration (JSON5) for `access`. A
/// site's router also names the session's router (`upstream`: its Zenoh id, see
/// [`session_router_zid`]): everything of the session flows both ways on that link, since the
/// session's router enforces the access list of every process behind it.
pub fn router_acl(keys: &Keys, access: &[RoleAccess], upstream: Option<&str>) -> String {
    let list = |items: &[String]| crate::endpoints::json_list(items);
    let session = vec![keys.all()];
    let handshake = vec![keys.alive_any(), keys.ready_any()];
    let mut rules = vec![
        // Declarations flow to everyone authenticated; data does not.
        format!(
            r#"{{ id: "declarations", permission: "allow", flows: ["egress"],
                 messages: ["declare_subscriber"], key_exprs: {} }}"#,
            list(&session)
        ),
        format!(
            r#"{{ id: "handshake", permission: "allow", flows: ["ingress", "egress"],
                 messages: ["liveliness_token", "declare_liveliness_subscriber", "liveliness_query"],
                 key_exprs: {} }}"#,
            list(&handshake)
        ),
    ];
    let mut subjects = Vec::new();
    let mut policies = Vec::new();
    for (i, a) in access.iter().enumerate() {
        let subject = format!("s{i}");
        let user = list(std::slice::from_ref(&a.user));
        // On TCP a process is its user name; on QUIC (mutual TLS) its user name *and* its
        // certificate's common name, so a stolen password needs the matching certificate too.
        subjects.push(format!(
            r#"{{ id: "{subject}-tcp", usernames: {user}, link_protocols: ["tcp"] }}"#
        ));
        subjects.push(format!(
            r#"{{ id: "{subject}-quic", usernames: {user}, cert_common_names: {user},
                 link_protocols: ["quic"] }}"#
        ));
        let mut mine = vec!["declarations".to_string(), "handshake".to_string()];
        if !a.publish.is_empty() {
            rules.push(format!(
                r#"{{ id: "{subject}-publish", permission: "allow", flows: ["ingress"],
                     messages: ["put", "delete"], key_exprs: {} }}"#,
                list(&a.publish)
            ));
            mine.push(format!("{subject}-publish"));
        }
        if !a.subscribe.is_empty() {
            rules.push(format!(
                r#"{{ id: "{subject}-subscribe", permission: "allow", flows: ["ingress"],
                     messages: ["declare_subscriber"], key_exprs: {} }}"#,
                list(&a.subscribe)
            ));
            rules.push(format!(
                r#"{{ id: "{subject}-receive", permission: "allow", flows: ["egress"],
                     messages: ["put", "delete"], key_exprs: {} }}"#,
                list(&a.subscribe)
            ));
            mine.push(format!("{subject}-subscribe"));
            mine.push(format!("{subject}-receive"));
        }
        policies.push(format!(
            r#"{{ rules: {}, subjects: ["{subject}-tcp", "{subject}-quic"] }}"#,
            list(&mine)
        ));
    }
    if let Some(zid) = upstream {
        rules.push(format!(
            r#"{{ id: "upstream", permission: "allow", flows: ["ingress", "egress"],
                 messages: ["put", "delete", "declare_subscriber", "query", "declare_queryable",
                            "reply", "liveliness_token", "declare_liveliness_subscriber",
                            "liveliness_query"],
                 key_exprs: {} }}"#,
            list(&session)
        ));
        let zid = list(&[zid.to_string()]);
        let router = list(&[crate::tls::ROUTER_CERT_NAME.to_string()]);
        // The session's router opens no password to a site's router (the one that dials
        // authenticates); on QUIC its certificate names it too.
        subjects.push(format!(
            r#"{{ id: "upstream-tcp", zids: {zid}, link_protocols: ["tcp"] }}"#
        ));
        subjects.push(format!(
            r#"{{ id: "upstream-quic", zids: {zid}, cert_common_names: {router},
                 link_protocols: ["quic"] }}"#
        ));
        policies.push(
            r#"{ rules: ["upstream"], subjects: ["upstream-tcp", "upstream-quic"] }"#.to_string(),
        );
    }
    format!(
        r#"{{ enabled: true, default_permission: "deny", rules: [{}], subjects: [{}], policies: [{}] }}"#,
        rules.join(", "),
        subjects.join(", "),
        policies.join(", ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn includes(pattern: &str, key: &str) -> bool {
        let p = zenoh::key_expr::KeyExpr::try_from(pattern).unwrap();
        let k = zenoh::key_expr::KeyExpr::try_from(key).unwrap();
        p.includes(&k)
    }

    fn may(list: &[String], key: &str) -> bool {
        list.iter().any(|p| includes(p, key))
    }

    #[test]
    fn every_role_publishes_only_its_own_keys_and_reads_only_what_it_needs() {
        let keys = Keys::new("s").unwrap();
        let all = role_access(&keys, 3, true, &["b".to_string()]);
        let get = |u: &str| all.iter().find(|a| a.user == u).unwrap().clone();
        let o1 = get("observer-O1");
        assert!(may(&o1.publish, &keys.observer_status(&observer("O1"))));
        for forbidden in [
            keys.sched_cmd(),
            keys.fault(&observer("O1")),
            keys.sensor_events(&observer("O2")),
            keys.sensor_events(&observer("O1")),
            keys.observer_status(&observer("O2")),
            keys.clock(),
        ] {
            assert!(!may(&o1.publish, &forbidden), "O1 may publish {forbidden}");
        }
        for truth in [keys.sim_state(), keys.truth_performer(), keys.sched_cmd()] {
            assert!(!may(&o1.subscribe, &truth), "O1 may read {truth}");
        }
        assert!(may(&o1.subscribe, &keys.sensor_events(&observer("O1"))));
        assert!(!may(&o1.subscribe, &keys.sensor_events(&observer("O2"))));
        // Nobody but the supervising launcher publishes faults.
        for a in all.iter().filter(|a| a.user != "launcher") {
            assert!(!may(&a.publish, &keys.fault(&observer("O1"))), "{}", a.user);
        }
        assert!(may(&get("launcher").publish, &keys.fault(&observer("O1"))));
        let camera = get("camera-O1");
        assert!(may(&camera.publish, &keys.camera_input(&observer("O1"))));
        assert!(!may(&camera.publish, &keys.camera_input(&observer("O2"))));
        let host = get("launcher-b");
        assert!(host.publish.iter().all(|k| k.contains("rejects")));
        assert!(may(&host.subscribe, &keys.clock()));
        assert!(!may(&host.subscribe, &keys.sim_state()));
        assert!(may(&get("recorder").subscribe, &keys.sim_state()));
        assert!(may(
            &get("camera-O2").publish,
            &keys.sensor_rgb(&observer("O2"))
        ));
        assert!(!may(
            &get("camera-O2").publish,
            &keys.sensor_rgb(&observer("O1"))
        ));
        let users: Vec<String> = all.iter().map(|a| a.user.clone()).collect();
        assert_eq!(users.len(), 3 + 6 + 1 + 2);
    }

    #[test]
    fn the_acl_is_a_valid_zenoh_configuration() {
        let keys = Keys::new("s").unwrap();
        let access = role_access(&keys, 2, true, &[]);
        for upstream in [None, Some(session_router_zid("s").as_str())] {
            let acl = router_acl(&keys, &access, upstream);
            let mut c = zenoh::Config::default();
            c.insert_json5("access_control", &acl).unwrap();
            assert_eq!(
                c.get_json("access_control/default_permission").unwrap(),
                "\"deny\""
            );
            assert!(acl.contains("camera-O2"));
            assert_eq!(acl.contains("upstream"), upstream.is_some());
        }
    }

    #[test]
    fn a_session_routers_id_is_fixed_per_session_and_a_valid_zenoh_id() {
        let (a, b) = (session_router_zid("s1"), session_router_zid("s2"));
        assert_ne!(a, b);
        assert_eq!(a, session_router_zid("s1"));
        // Sessions whose plain hash starts with a 0 digit among them.
        let many: Vec<String> = (0..64)
            .map(|i| session_router_zid(&format!("s{i}")))
            .collect();
        for zid in [a, b, session_router_zid("")].into_iter().chain(many) {
            let mut c = zenoh::Config::default();
            c.insert_json5("id", &format!("\"{zid}\"")).unwrap();
        }
    }

    #[test]
    fn a_site_router_may_do_what_its_processes_may_and_no_more() {
        let keys = Keys::new("s").unwrap();
        let all = role_access(&keys, 3, false, &["b".to_string()]);
        let parts: Vec<RoleAccess> = all
            .iter()
            .filter(|a| a.user.ends_with("-O1") || a.user == "launcher-b")
            .cloned()
            .collect();
        let site = union_of("launcher-b", &parts);
        assert_eq!(site.user, "launcher-b");
        assert!(may(&site.publish, &keys.sensor_events(&observer("O1"))));
        assert!(may(&site.publish, &keys.observer_status(&observer("O1"))));
        assert!(!may(&site.publish, &keys.sensor_events(&observer("O2"))));
        assert!(!may(&site.publish, &keys.clock()));
        assert!(may(&site.subscribe, &keys.sim_state()));
        assert!(!may(&site.subscribe, &keys.sensor_events(&observer("O2"))));
        let mut sorted = site.publish.clone();
        sorted.sort();
        sorted.dedup();
        assert_eq!(site.publish, sorted);
    }
}
