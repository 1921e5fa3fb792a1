//! Isolation (docs/DESIGN.md §2): an observer process never subscribes to ground truth
//! (`sim/state`, `sim/contacts`, `truth/**`), to the performer's or scheduler's commands, nor
//! to another observer's keys. Proven twice: by the source of the crate (no code path names
//! those keys) and by the running binary (Zenoh reports no subscriber of it on those keys,
//! while it does on its own three).

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use bus::{Bus, Endpoints, handshake};
use proto::{Keys, ObserverId, Role};

/// Key builders an observer must never call (anything carrying truth, commands, faults, or
/// other observers' streams).
const FORBIDDEN_BUILDERS: &[&str] = &[
    "sim_state(",
    "sim_contacts(",
    "truth_performer(",
    "performer_setpoint(",
    "sched_cmd(",
    "sched_broadcast(",
    "sched_report(",
    "observer_status_any(",
    "observer_decision_any(",
    ".fault(",
    "fault_any(",
    "keys.all(",
    "Keys::all",
    "alive_role(Role::Observer",
];

/// Raw key fragments that would bypass the builders.
const FORBIDDEN_TEXT: &[&str] = &[
    "\"waggle/",
    "sim/state",
    "sim/contacts",
    "truth/",
    "performer/setpoint",
    "sched/cmd",
    "sched/broadcast",
    "sched/report",
];

fn non_test_source(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    // Unit tests sit at the end of a file behind `#[cfg(test)]`.
    match text.find("#[cfg(test)]") {
        Some(i) => text[..i].to_string(),
        None => text,
    }
}

fn sources(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let p = entry.unwrap().path();
        if p.is_dir() {
            sources(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

#[test]
fn no_observer_code_path_names_a_forbidden_key() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    // The process shell and the perception library it runs (the observer's whole code).
    let mut files = Vec::new();
    sources(&root.join("src"), &mut files);
    sources(&root.join("../libs/perception/src"), &mut files);
    sources(&root.join("../libs/node-args/src"), &mut files);
    assert!(files.len() > 5, "found only {files:?}");
    for f in &files {
        let text = non_test_source(f);
        for bad in FORBIDDEN_BUILDERS.iter().chain(FORBIDDEN_TEXT) {
            assert!(!text.contains(bad), "{} mentions {bad}", f.display());
        }
    }
    // The process subscribes to exactly three key expressions, all its own or session-wide.
    let main = non_test_source(&root.join("src/main.rs"));
    let subs: Vec<&str> = main
        .lines()
        .map(str::trim)
        .filter(|l| l.contains(".subscribe("))
        .collect();
    assert_eq!(
        subs,
        [
            "bus.subscribe(&keys.sensor_any(&args.own.id))?;",
            "bus.subscribe(&keys.clock())?;",
            "bus.subscribe(&keys.sched_session())?;",
        ]
    );
    // Nor can it link code that knows the truth.
    let manifest = std::fs::read_to_string(root.join("Cargo.toml")).unwrap();
    let deps = &manifest[manifest.find("[dependencies]").unwrap()..];
    let deps = &deps[..deps.find("\n[").unwrap_or(deps.len())];
    for crate_name in [
        "sim-node",
        "performer-node",
        "scheduler-node",
        "recorder-node",
        "deploy",
        "sim",
        "scheduler",
        "recording",
        "evaluation",
    ] {
        assert!(
            !deps
                .lines()
                .any(|l| l.starts_with(&format!("{crate_name}."))
                    || l.starts_with(&format!("{crate_name} "))),
            "observer-node depends on {crate_name}"
        );
    }
    // Nor can the libraries it links beside the bus: perception, and the typed arguments
    // (node-args, whose sensor model links perturb and event-camera only).
    for (lib, forbidden) in [
        (
            "perception",
            &["sim", "scheduler", "recording", "evaluation", "bus"][..],
        ),
        (
            "node-args",
            &["sim", "scheduler", "recording", "evaluation", "bus"][..],
        ),
        (
            "perturb",
            &["sim", "scheduler", "recording", "evaluation", "bus"][..],
        ),
    ] {
        let manifest = std::fs::read_to_string(root.join(format!("../libs/{lib}/Cargo.toml")))
            .unwrap_or_else(|e| panic!("libs/{lib}/Cargo.toml: {e}"));
        let deps = &manifest[manifest.find("[dependencies]").unwrap()..];
        let deps = &deps[..deps.find("\n[").unwrap_or(deps.len())];
        for crate_name in forbidden {
            assert!(
                !deps
                    .lines()
                    .any(|l| l.starts_with(&format!("{crate_name}."))
                        || l.starts_with(&format!("{crate_name} "))),
                "the {lib} library depends on {crate_name}"
            );
        }
    }
}

struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A standalone two-observer session in which this test stands in for every process but the
/// observer O1 (started with `extra` arguments); returns once O1 is ready.
fn observer_in_a_fake_session(tag: &str, extra: &[String]) -> (Bus, Keys, Killed) {
    let session = format!("iso-{tag}-{}", std::process::id());
    // A port free when asked can be taken before Zenoh binds it (another test binary runs
    // beside this one; a clean-clone run saw "Address already in use"): ask again, a few times.
    let (mut bus, endpoint) = (0..5)
        .find_map(|_| {
            let port = std::net::TcpListener::bind("127.0.0.1:0")
                .unwrap()
                .local_addr()
                .unwrap()
                .port();
            let endpoint = format!("tcp/127.0.0.1:{port}");
            let listen = Endpoints {
                connect: vec![],
                listen: vec![endpoint.clone()],
            };
            match Bus::open(&session, &listen) {
                Ok(bus) => Some((bus, endpoint)),
                Err(e) if e.to_string().contains("Address already in use") => None,
                Err(e) => panic!("opening the test's bus on {endpoint}: {e}"),
            }
        })
        .expect("a free loopback port within 5 tries");
    let keys = Keys::new(&session).unwrap();
    let me = handshake::Process::new(Role::Observer, "O1");
    for p in handshake::mission_processes(2, false) {
        if p != me {
            bus.declare_token(&p.alive_key(&keys).unwrap()).unwrap();
        }
    }
    bus.watch_liveliness(&keys.ready_any()).unwrap();
    let child = Command::new(env!("CARGO_BIN_EXE_observer-node"))
        .args([
            "--id",
            "O1",
            "--modality",
            "events",
            "--session",
            &session,
            "--observers",
            "2",
            "--standalone",
            "--connect",
            &endpoint,
        ])
        .args(extra)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let guard = Killed(child);
    let ready = me.ready_key(&keys).unwrap();
    bus.wait_for("the observer to be ready", Duration::from_secs(60), |k| {
        k.contains(&ready)
    })
    .unwrap();
    (bus, keys, guard)
}

/// Waits until every key in `keys` has a subscriber (declarations may lag the ready token on a
/// busy machine).
fn wait_subscribed(bus: &mut Bus, keys: &[String]) {
    let start = Instant::now();
    for key in keys {
        while !bus.has_subscribers(key).unwrap() {
            assert!(
                start.elapsed() < Duration::from_secs(20),
                "the observer never subscribed to {key}"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

#[test]
fn the_running_observer_subscribes_to_its_own_keys_only() {
    let (mut bus, keys, _guard) = observer_in_a_fake_session("keys", &[]);
    let o1 = ObserverId::new("O1").unwrap();
    let o2 = ObserverId::new("O2").unwrap();
    let allowed = [
        keys.sensor_events(&o1),
        keys.sensor_rgb(&o1),
        keys.clock(),
        keys.sched_session(),
    ];
    let forbidden = [
        keys.sim_state(),
        keys.sim_contacts(),
        keys.truth_performer(),
        keys.performer_setpoint(),
        keys.sched_cmd(),
        keys.sched_broadcast(),
        keys.sched_report(),
        keys.sensor_events(&o2),
        keys.sensor_rgb(&o2),
        keys.observer_tokens(&o2),
        keys.observer_frames(&o2),
        keys.observer_decision(&o2),
        keys.observer_status(&o2),
        keys.fault(&o1),
        keys.fault(&o2),
    ];
    wait_subscribed(&mut bus, &allowed);
    for key in &forbidden {
        assert!(
            !bus.has_subscribers(key).unwrap(),
            "the observer subscribes to {key}"
        );
    }
}

#[test]
fn an_access_control_list_closes_a_key_to_the_observer() {
    // The mechanism `waggle run --observer-acl` relies on: a denied key's subscription never
    // leaves the process, while the others do.
    let session_keys = Keys::new(&format!("iso-acl-{}", std::process::id())).unwrap();
    let deny = vec!["--deny".to_string(), session_keys.clock()];
    let (mut bus, keys, _guard) = observer_in_a_fake_session("acl", &deny);
    assert_eq!(keys, session_keys);
    wait_subscribed(&mut bus, &[keys.sched_session()]);
    assert!(!bus.has_subscribers(&keys.clock()).unwrap());
}
