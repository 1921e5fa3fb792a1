//! A hostile bus: a rogue Zenoh client (the `zenoh` crate itself, not Waggle's `bus` library)
//! joins a run and publishes junk — random, empty, truncated, wrong-version and huge payloads —
//! on every key any node reads, and on keys outside the grammar, for the whole run. The run
//! must pass with the very `observers.json` of an undisturbed run (the golden digest), and
//! every process must count what it dropped in `summary.json`.

use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

use deploy::run_dir::RunSummary;
use proto::{ObserverId, RejectReason, Role};
use waggle_tests::waggle_with_nodes;
use zenoh::Wait;

mod golden_runs;
use golden_runs::{golden_entry, sha256_hex};

/// Every key some Waggle process reads (and a few it must ignore), for `session`.
fn target_keys(session: &str, observers: usize) -> Vec<String> {
    let k = proto::Keys::new(session).unwrap();
    let mut out = vec![
        k.clock(),
        k.sim_state(),
        k.sim_contacts(),
        k.performer_setpoint(),
        k.truth_performer(),
        k.sched_cmd(),
        k.sched_broadcast(),
        k.sched_session(),
        k.sched_report(),
        k.rejects(Role::Sim, "sim").unwrap(),
        format!("{}/bogus/key", k.prefix()),
        format!("{}/observer/O9/status", k.prefix()),
    ];
    for i in 0..observers {
        let o = ObserverId::from_index(i);
        out.extend([
            k.sensor_events(&o),
            k.sensor_rgb(&o),
            k.fault(&o),
            k.observer_status(&o),
            k.observer_tokens(&o),
            k.observer_frames(&o),
            k.observer_decision(&o),
            k.observer_track(&o),
            k.camera_report(&o),
        ]);
    }
    out
}

/// The junk payloads: each is refused by `proto::decode` for every message type.
fn junk(round: u64) -> Vec<Vec<u8>> {
    // A deterministic byte stream (splitmix64): random-looking, reproducible.
    let mut x = round.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03;
    let mut random = vec![0u8; 64];
    for b in &mut random {
        x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = x;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        *b = (z ^ (z >> 31)) as u8;
    }
    // Wire version 19366 (the probe's), never this build's.
    random[..2].copy_from_slice(&19366u16.to_le_bytes());
    let valid = proto::encode(&proto::ClockTick::at(5).unwrap());
    let truncated = valid[..valid.len() - 3].to_vec();
    let mut wrong_version = valid.clone();
    wrong_version[..2].copy_from_slice(&(proto::FORMAT_VERSION + 1).to_le_bytes());
    vec![random, Vec::new(), truncated, wrong_version, vec![0x02]]
}

/// A rogue Zenoh session reaching the run through `endpoint`: a peer without credentials, or
/// a client holding someone's `user:password`. It counts every sample of the session it is
/// sent.
struct Rogue {
    session: zenoh::Session,
    received: std::sync::Arc<std::sync::atomic::AtomicU64>,
    _subscriber: zenoh::pubsub::Subscriber<()>,
}

/// The TLS files a rogue presents on `quic/`: a CA to trust, a certificate and its key.
struct RogueTls {
    ca: std::path::PathBuf,
    cert: std::path::PathBuf,
    key: std::path::PathBuf,
}

impl RogueTls {
    /// Mutual TLS with these files on the rogue's `quic/` links (names not checked, as Waggle).
    fn apply(&self, config: &mut zenoh::Config) {
        let mut settings: Vec<(&str, String)> = [
            ("root_ca_certificate", &self.ca),
            ("connect_certificate", &self.cert),
            ("connect_private_key", &self.key),
        ]
        .map(|(k, v)| (k, format!("\"{}\"", v.display())))
        .to_vec();
        settings.push(("enable_mtls", "true".into()));
        settings.push(("verify_name_on_connect", "false".into()));
        for (k, v) in settings {
            config
                .insert_json5(&format!("transport/link/tls/{k}"), &v)
                .unwrap();
        }
    }
}

impl Rogue {
    fn join(endpoint: &str, run_session: &str, credentials: Option<&str>) -> Self {
        Self::join_with(endpoint, run_session, credentials, None)
    }

    fn join_with(
        endpoint: &str,
        run_session: &str,
        credentials: Option<&str>,
        tls: Option<&RogueTls>,
    ) -> Self {
        let mut config = zenoh::Config::default();
        let set = |c: &mut zenoh::Config, k: &str, v: &str| c.insert_json5(k, v).unwrap();
        set(&mut config, "scouting/multicast/enabled", "false");
        set(
            &mut config,
            "connect/endpoints",
            &format!("[\"{endpoint}\"]"),
        );
        match credentials {
            None => {
                set(&mut config, "mode", "\"peer\"");
                set(&mut config, "listen/endpoints", "[]");
            }
            Some(line) => {
                let (user, password) = line.trim().split_once(':').unwrap();
                set(&mut config, "mode", "\"client\"");
                set(
                    &mut config,
                    "transport/auth/usrpwd/user",
                    &format!("\"{user}\""),
                );
                set(
                    &mut config,
                    "transport/auth/usrpwd/password",
                    &format!("\"{password}\""),
                );
            }
        }
        if let Some(t) = tls {
            t.apply(&mut config);
        }
        let session = zenoh::open(config).wait().expect("rogue session");
        let received = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
        let counter = received.clone();
        let subscriber = session
            .declare_subscriber(format!("waggle/{run_session}/**"))
            // Its own puts come back locally: only what crossed a link counts.
            .allowed_origin(zenoh::sample::Locality::Remote)
            .callback(move |_| {
                counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            })
            .wait()
            .unwrap();
        Self {
            session,
            received,
            _subscriber: subscriber,
        }
    }

    fn received(&self) -> u64 {
        self.received.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Publishes each payload of `payloads(round)` on each of `keys`, every 250 ms, until
    /// `done()` (bounded); returns how many puts Zenoh accepted.
    fn flood(
        &self,
        keys: &[String],
        payloads: impl Fn(u64) -> Vec<Vec<u8>>,
        done: impl Fn() -> bool,
    ) -> u64 {
        let mut sent = 0u64;
        let deadline = Instant::now() + Duration::from_secs(900);
        let mut round = 0u64;
        while !done() && Instant::now() < deadline {
            for key in keys {
                for p in payloads(round) {
                    if self.session.put(key.as_str(), p).wait().is_ok() {
                        sent += 1;
                    }
                }
            }
            round += 1;
            std::thread::sleep(Duration::from_millis(250));
        }
        sent
    }
}

/// What a run with rogues beside it left.
struct Disturbed {
    summary: RunSummary,
    observers_sha256: String,
    /// Per rogue, in the order given: puts it made, and samples it received.
    traffic: Vec<Traffic>,
    /// The launcher's stderr (it names any process whose reject report never came).
    stderr: String,
}

#[derive(Debug, Clone, Copy)]
struct Traffic {
    sent: u64,
    received: u64,
}

/// One rogue of a run: how it joins (`join(endpoint, session)`, once the run is up), the keys
/// it floods (`keys(session)`) and the payloads of each round.
struct RogueSpec<'a> {
    join: Box<JoinFn<'a>>,
    keys: Box<KeysFn<'a>>,
    payloads: Box<PayloadsFn<'a>>,
}

/// `(endpoint, session)` → a rogue joined to the run.
type JoinFn<'a> = dyn FnOnce(&str, &str) -> Rogue + Send + 'a;
/// `session` → the keys a rogue floods.
type KeysFn<'a> = dyn FnOnce(&str) -> Vec<String> + Send + 'a;
/// `round` → the payloads a rogue puts on each key that round.
type PayloadsFn<'a> = dyn Fn(u64) -> Vec<Vec<u8>> + Send + Sync + 'a;

impl<'a> RogueSpec<'a> {
    fn new(
        join: impl FnOnce(&str, &str) -> Rogue + Send + 'a,
        keys: impl FnOnce(&str) -> Vec<String> + Send + 'a,
        payloads: impl Fn(u64) -> Vec<Vec<u8>> + Send + Sync + 'a,
    ) -> Self {
        Self {
            join: Box::new(join),
            keys: Box::new(keys),
            payloads: Box::new(payloads),
        }
    }
}

/// Runs `only-a` with event cameras (`extra` arguments added) while each rogue floods its keys.
fn run_beside_rogues(name: &str, extra: &[&str], rogues: Vec<RogueSpec<'_>>) -> Disturbed {
    let endpoint = format!("tcp/127.0.0.1:{}", waggle_tests::free_port());
    run_beside_rogues_at(&endpoint, name, extra, rogues)
}

/// [`run_beside_rogues`] with the run's router listening on `endpoint`.
fn run_beside_rogues_at(
    endpoint: &str,
    name: &str,
    extra: &[&str],
    rogues: Vec<RogueSpec<'_>>,
) -> Disturbed {
    let session = format!("{name}-{}", std::process::id());
    let dir = std::env::temp_dir().join(format!("waggle-{session}"));
    let _ = std::fs::remove_dir_all(&dir);
    let endpoint = endpoint.to_string();
    let log = std::env::temp_dir().join(format!("waggle-{session}.log"));
    let mut run = waggle_with_nodes()
        .args(["run", "only-a", "--modality", "events", "--quiet"])
        .args(extra)
        .args(["--session", &session, "--listen", &endpoint, "--out"])
        .arg(&dir)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&log).unwrap())
        .stderr(Stdio::from(
            std::fs::File::create(log.with_extension("err")).unwrap(),
        ))
        .spawn()
        .expect("start waggle run");
    // Until the launcher has written the session's credentials (bounded: a busy machine is
    // slow to start), and its router listens.
    let secrets = std::env::temp_dir().join(format!("waggle-secrets-{session}"));
    let deadline = Instant::now() + Duration::from_secs(60);
    let authenticated = !extra.contains(&"--no-auth");
    while authenticated && !secrets.join("dictionary").exists() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(100));
    }
    std::thread::sleep(Duration::from_millis(1500));
    let finished = std::sync::atomic::AtomicBool::new(false);
    let (traffic, status) = std::thread::scope(|s| {
        let flooding: Vec<_> = rogues
            .into_iter()
            .map(|spec| {
                let (endpoint, session, finished) = (&endpoint, &session, &finished);
                s.spawn(move || {
                    let r = (spec.join)(endpoint, session);
                    let keys = (spec.keys)(session);
                    let sent = r.flood(&keys, &spec.payloads, || {
                        finished.load(std::sync::atomic::Ordering::SeqCst)
                    });
                    let received = r.received();
                    r.session.close().wait().ok();
                    Traffic { sent, received }
                })
            })
            .collect();
        let status = wait_bounded(&mut run, Duration::from_secs(900));
        finished.store(true, std::sync::atomic::Ordering::SeqCst);
        let traffic: Vec<Traffic> = flooding.into_iter().map(|f| f.join().unwrap()).collect();
        (traffic, status)
    });
    let context = format!(
        "outputs in {}\nstdout:\n{}\nstderr:\n{}",
        dir.display(),
        std::fs::read_to_string(&log).unwrap_or_default(),
        std::fs::read_to_string(log.with_extension("err")).unwrap_or_default()
    );
    assert!(status.success(), "{context}");
    let summary = read_summary(&dir);
    assert!(
        summary.mission.pass,
        "{:?}\n{context}",
        summary.mission.reasons
    );
    let observers_sha256 = sha256_hex(&std::fs::read(dir.join("observers.json")).unwrap());
    let stderr = std::fs::read_to_string(log.with_extension("err")).unwrap_or_default();
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_file(&log);
    let _ = std::fs::remove_file(log.with_extension("err"));
    Disturbed {
        summary,
        observers_sha256,
        traffic,
        stderr,
    }
}

/// The `observers.json` digest of an undisturbed `only-a` run with event cameras.
fn undisturbed_sha256() -> String {
    golden_entry("only-a", "events")["observers_sha256"]
        .as_str()
        .unwrap()
        .to_string()
}

/// How many messages `process` dropped on `key` for `reason`.
fn count(summary: &RunSummary, process: &str, key: &str, reason: RejectReason) -> u64 {
    summary
        .rejects
        .get(process)
        .into_iter()
        .flatten()
        .filter(|c| c.key == key && c.reason == reason)
        .map(|c| c.count)
        .sum()
}

/// A well-formed fault that would blind `observer` from the start.
fn forged_blackout(observer: &str) -> Vec<u8> {
    proto::encode(&proto::Fault {
        observer: ObserverId::new(observer).unwrap(),
        kind: proto::FaultKind::BlackInput,
        from_ns: 0,
        until_ns: None,
    })
}

/// Waits for `child`, killing it and failing after `limit` (a hang must not stall CI).
fn wait_bounded(child: &mut std::process::Child, limit: Duration) -> std::process::ExitStatus {
    let deadline = Instant::now() + limit;
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("waggle run did not end within {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}

fn read_summary(dir: &Path) -> RunSummary {
    let text = std::fs::read_to_string(dir.join("summary.json"))
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    serde_json::from_str(&text).unwrap()
}

#[test]
fn junk_on_every_key_leaves_the_run_passing_with_identical_observers_and_counted_rejects() {
    let d = run_beside_rogues(
        "hostile-junk",
        &["--no-auth"],
        vec![RogueSpec::new(
            |endpoint, session| Rogue::join(endpoint, session, None),
            |session| target_keys(session, 3),
            |round| {
                let mut p = junk(round);
                if round == 3 {
                    p.push(vec![0xAB; 2 << 20]);
                }
                p
            },
        )],
    );
    let t = d.traffic[0];
    assert!(t.sent > 1000, "the rogue sent only {}", t.sent);
    // On the open bus the rogue reads everything: what authentication takes away.
    assert!(t.received > 1000, "the rogue received only {}", t.received);
    assert_eq!(
        d.observers_sha256,
        undisturbed_sha256(),
        "observers.json differs from the undisturbed run"
    );
    let s = &d.summary;
    let undecodable = RejectReason::Undecodable;
    for (process, key) in [
        ("sim", "sched/cmd"),
        ("sim", "performer/setpoint"),
        ("scheduler", "sim/state"),
        ("scheduler", "observer/O2/status"),
        ("performer", "sched/broadcast"),
        ("camera-O1", "sim/state"),
        ("camera-O1", "fault/O1"),
        ("observer-O2", "clock"),
        ("observer-O2", "sched/session"),
        ("observer-O2", "sensor/O2/events"),
        ("launcher", "clock"),
        ("launcher", "observer/O2/status"),
        ("launcher", "fault/O3"),
        ("launcher", "rejects/sim/sim"),
        ("launcher", "camera/O2/report"),
    ] {
        assert!(
            count(s, process, key, undecodable) > 0,
            "{process} counted no undecodable message on {key}: {:?}\nlauncher's stderr:\n{}",
            s.rejects.get(process),
            d.stderr
        );
    }
    for (process, key) in [
        ("observer-O1", "sensor/O1/rgb"),
        ("scheduler", "observer/O9/status"),
    ] {
        assert!(
            count(s, process, key, RejectReason::UnexpectedKey) > 0,
            "{process} counted no message on {key} as an unexpected key: {:?}\n\
             launcher's stderr:\n{}",
            s.rejects.get(process),
            d.stderr
        );
    }
    assert!(s.faults_seen.is_empty(), "{:?}", s.faults_seen);
}

/// Two rogues in one authenticated run (one run, not two: each whole run is ≈ 90 core-seconds
/// of the default suite): one without credentials, which neither receives nor delivers
/// anything, and one holding observer O1's credentials, which can publish on O1's own keys and
/// nowhere else.
#[test]
fn rogues_without_credentials_or_with_o1s_reach_nothing_beyond_o1s_own_keys() {
    let d = run_beside_rogues(
        "hostile-auth",
        &[],
        vec![
            RogueSpec::new(
                |endpoint, session| Rogue::join(endpoint, session, None),
                |session| target_keys(session, 3),
                |round| {
                    let mut p = junk(round);
                    p.push(forged_blackout("O1"));
                    p
                },
            ),
            RogueSpec::new(
                |endpoint, session| {
                    let file = std::env::temp_dir()
                        .join(format!("waggle-secrets-{session}"))
                        .join("observer-O1.credentials");
                    let line = std::fs::read_to_string(&file)
                        .unwrap_or_else(|e| panic!("{}: {e}", file.display()));
                    Rogue::join(endpoint, session, Some(&line))
                },
                |session| {
                    let k = proto::Keys::new(session).unwrap();
                    let o = |s: &str| ObserverId::new(s).unwrap();
                    vec![
                        k.sched_cmd(),
                        k.fault(&o("O1")),
                        k.fault(&o("O2")),
                        k.sensor_events(&o("O2")),
                        k.clock(),
                        // Its own key: allowed, so the scheduler counts the junk (the rogue is in).
                        k.observer_status(&o("O1")),
                    ]
                },
                |round| {
                    let mut p = junk(round);
                    p.push(forged_blackout("O1"));
                    p.push(forged_blackout("O2"));
                    p
                },
            ),
        ],
    );
    let (without, with_o1) = (d.traffic[0], d.traffic[1]);
    assert!(without.sent > 1000, "the rogue sent only {}", without.sent);
    assert!(with_o1.sent > 100, "O1's rogue sent only {}", with_o1.sent);
    assert_eq!(
        without.received, 0,
        "a rogue without credentials received samples"
    );
    // O1's subscription to the whole session is not among O1's: the router refuses it.
    assert_eq!(
        with_o1.received, 0,
        "O1's credentials read beyond O1's inputs"
    );
    assert_eq!(d.observers_sha256, undisturbed_sha256());
    let s = &d.summary;
    assert!(s.faults_seen.is_empty(), "{:?}", s.faults_seen);
    // O1's junk on its own key arrived; nothing else from either rogue did (the one without
    // credentials flooded every key the run reads, O1's the keys it does not own).
    assert!(
        count(
            s,
            "scheduler",
            "observer/O1/status",
            RejectReason::Undecodable
        ) > 0,
        "the O1 rogue's junk on its own key never arrived: {:?}",
        s.rejects
    );
    for (process, counts) in &s.rejects {
        for c in counts {
            assert_eq!(
                c.key, "observer/O1/status",
                "{process} got a message from a rogue beyond O1's own keys: {c:?}"
            );
        }
    }
    // The router counted the credential-less rogue's refused handshakes (it keeps dialling)
    // and O1's puts on keys O1 does not own (5 keys, several payloads, every 250 ms) — not its
    // allowed puts on its own key; no certificate was refused (there is no TLS here).
    let r = s.router_refusals;
    assert!(r.handshake >= 1, "{r:?}");
    assert!(r.denied_messages > 100, "{r:?}");
    assert!(
        r.denied_messages < with_o1.sent,
        "{r:?}, {} sent by O1's rogue",
        with_o1.sent
    );
    assert_eq!(r.certificate, 0, "{r:?}");
}

/// Over `quic/`, inside a whole run: observer O1's stolen password presented with camera O1's
/// (valid, same-session) certificate passes TLS and the password check but matches no access
/// rule (a process is its user *and* its certificate's name there), so the rogue receives
/// nothing and delivers nothing, and the run is the golden one.
#[test]
#[ignore = "≈ 1 min (a whole run over quic/): deploy/test.sh --full"]
fn a_password_with_another_processs_certificate_gets_nothing_in_a_quic_run() {
    let port = std::net::UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let d = run_beside_rogues_at(
        &format!("quic/127.0.0.1:{port}"),
        "hostile-swap",
        &[],
        vec![RogueSpec::new(
            |endpoint, session| {
                let dir = std::env::temp_dir().join(format!("waggle-secrets-{session}"));
                let line = std::fs::read_to_string(dir.join("observer-O1.credentials"))
                    .unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
                let tls = RogueTls {
                    ca: dir.join("ca.pem"),
                    cert: dir.join("camera-O1.cert.pem"),
                    key: dir.join("camera-O1.key.pem"),
                };
                // Zenoh's QUIC link wants one stream per link here as everywhere in Waggle.
                let endpoint = bus::single_stream_quic(endpoint);
                // First a certificate of another CA: refused by the TLS handshake.
                let foreign_dir = dir.with_extension("foreign");
                let foreign =
                    bus::SessionSecrets::create_kept(&foreign_dir, &["sim".to_string()]).unwrap();
                let foreign_tls = RogueTls {
                    ca: foreign_dir.join("ca.pem"),
                    cert: foreign_dir.join("sim.cert.pem"),
                    key: foreign_dir.join("sim.key.pem"),
                };
                assert!(
                    !joins_quic(&endpoint, &foreign_tls),
                    "a certificate of another CA was accepted"
                );
                drop(foreign);
                let _ = std::fs::remove_dir_all(&foreign_dir);
                Rogue::join_with(&endpoint, session, Some(&line), Some(&tls))
            },
            |session| {
                let k = proto::Keys::new(session).unwrap();
                let o1 = ObserverId::new("O1").unwrap();
                vec![k.observer_status(&o1), k.sensor_events(&o1), k.clock()]
            },
            |round| {
                let mut p = junk(round);
                p.push(forged_blackout("O1"));
                p
            },
        )],
    );
    let t = d.traffic[0];
    assert!(t.sent > 100, "the rogue sent only {}", t.sent);
    assert_eq!(t.received, 0, "the rogue was sent samples");
    assert_eq!(d.observers_sha256, undisturbed_sha256());
    assert_eq!(d.summary.rejects_total(), 0, "{:?}", d.summary.rejects);
    // The router counted both: the foreign certificate and the link that matched no rule.
    let r = d.summary.router_refusals;
    assert!(r.certificate >= 1 && r.no_access_rule >= 1, "{r:?}");
}

/// True when a client presenting `tls` (no password) opens a session through `endpoint`
/// within 3 s.
fn joins_quic(endpoint: &str, tls: &RogueTls) -> bool {
    let mut config = zenoh::Config::default();
    let set = |c: &mut zenoh::Config, k: &str, v: &str| c.insert_json5(k, v).unwrap();
    set(&mut config, "mode", "\"client\"");
    set(&mut config, "scouting/multicast/enabled", "false");
    set(
        &mut config,
        "connect/endpoints",
        &format!("[\"{endpoint}\"]"),
    );
    set(&mut config, "connect/timeout_ms", "3000");
    tls.apply(&mut config);
    zenoh::open(config).wait().is_ok()
}
