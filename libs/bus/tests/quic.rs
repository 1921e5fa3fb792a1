//! The encrypted bus: a router and its clients over `quic/` on loopback, each presenting its own
//! certificate from the session's CA (mutual TLS), with per-process passwords and the session's
//! access lists as well. A client holding another session's certificate is refused.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use bus::handshake::Process;
use bus::tls::ExistingCa;
use bus::{Bus, Credentials, Endpoints, Inbound, SessionSecrets, client_config, router_config};
use proto::{ClockTick, Keys, Role};

mod common;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("waggle-quic-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// A session's router on a free `quic/` port, with the access lists of the simulator, observer
/// O1 and the scheduler, and the session's secrets.
struct Session {
    name: String,
    keys: Keys,
    endpoint: String,
    secrets: SessionSecrets,
    _router: Bus,
}

fn session(label: &str) -> Session {
    session_valid_for(label, bus::auth::CERTIFICATE_VALIDITY)
}

/// [`session`] with certificates valid for `validity` from now.
fn session_valid_for(label: &str, validity: Duration) -> Session {
    session_signed_by(label, validity, None)
}

/// [`session_valid_for`] with certificates issued by `ca` instead of a session CA.
fn session_signed_by(label: &str, validity: Duration, ca: Option<&ExistingCa>) -> Session {
    let name = format!("quic-{label}-{}", std::process::id());
    let keys = Keys::new(&name).unwrap();
    let sim = Process::singleton(Role::Sim);
    let obs = Process::new(Role::Observer, "O1");
    let sched = Process::singleton(Role::Scheduler);
    let everyone = [sim, obs, sched];
    let names: Vec<String> = everyone.iter().map(Process::name).collect();
    let secrets =
        SessionSecrets::create_kept_signed_by(&scratch(label), &names, validity, ca).unwrap();
    let access: Vec<_> = everyone
        .iter()
        .map(|p| bus::access::access_of(&keys, p))
        .collect();
    let acl = bus::access::router_acl(&keys, &access, None);
    let endpoint = common::free_endpoint("quic");
    let listen = Endpoints {
        connect: vec![],
        listen: vec![endpoint.clone()],
    };
    let router = Bus::open_config(
        &name,
        router_config(
            &listen,
            secrets.dictionary(),
            &acl,
            &bus::access::session_router_zid(&name),
        )
        .unwrap(),
    )
    .unwrap();
    Session {
        name,
        keys,
        endpoint,
        secrets,
        _router: router,
    }
}

/// A client of `s`'s router with `creds`, giving up dialling after `timeout_ms`.
fn client(s: &Session, creds: &Credentials, timeout_ms: u64) -> Result<Bus, bus::BusError> {
    let endpoints = Endpoints {
        connect: vec![s.endpoint.clone()],
        listen: vec![],
    };
    let mut config = client_config(&endpoints, creds).unwrap();
    config
        .insert_json5("connect/timeout_ms", &timeout_ms.to_string())
        .unwrap();
    Bus::open_config(&s.name, config)
}

fn creds(s: &Session, user: &str) -> Credentials {
    let c = Credentials::read(s.secrets.file_of(user).unwrap()).unwrap();
    assert!(c.tls.is_some(), "{user} has no certificate files");
    c
}

#[test]
fn messages_cross_a_quic_router_between_clients_with_session_certificates() {
    let s = session("ok");
    let mut sim = client(&s, &creds(&s, "sim"), 20_000).unwrap();
    let mut obs = client(&s, &creds(&s, "observer-O1"), 20_000).unwrap();
    let keys = &s.keys;
    obs.subscribe(&keys.clock()).unwrap();
    common::await_subscriber(&mut sim, &mut obs, keys);
    for tick in 0..100 {
        sim.put(&keys.clock(), &ClockTick::at(tick).unwrap())
            .unwrap();
    }
    // Large messages too (an RGB key frame is 0.9 MB): raw bytes on the same key.
    for i in 0..3u8 {
        sim.put_bytes(&keys.clock(), vec![i; 921_600]).unwrap();
    }
    let deadline = Instant::now() + Duration::from_secs(20);
    let (mut ticks, mut big) = (Vec::new(), Vec::new());
    while big.len() < 3 && Instant::now() < deadline {
        if let Some(Inbound::Data { payload, .. }) = obs.recv(Duration::from_millis(50)) {
            match proto::decode::<ClockTick>(&payload) {
                Ok(c) => ticks.push(c.tick),
                Err(_) => big.push((payload.len(), payload[0])),
            }
        }
    }
    assert_eq!(ticks, (0..100).collect::<Vec<_>>());
    assert_eq!(big, [(921_600, 0), (921_600, 1), (921_600, 2)]);
}

#[test]
fn a_client_with_another_sessions_certificate_is_refused() {
    let ours = session("ours");
    let theirs = session("theirs");
    // Our password, their certificate (their CA): the TLS handshake fails before any password.
    let mut forged = creds(&ours, "sim");
    forged.tls = creds(&theirs, "sim").tls;
    let refused = client(&ours, &forged, 3_000);
    assert!(refused.is_err(), "a foreign certificate was accepted");
    // Without any certificate, a quic/ client is refused before it dials.
    let mut bare = creds(&ours, "sim");
    bare.tls = None;
    let endpoints = Endpoints {
        connect: vec![ours.endpoint.clone()],
        listen: vec![],
    };
    let e = client_config(&endpoints, &bare).unwrap_err().to_string();
    assert!(e.contains("certificates") && e.contains("sim"), "{e}");
    // Our own certificate still works.
    assert!(client(&ours, &creds(&ours, "sim"), 20_000).is_ok());
}

/// The router's access list names a process by user *and* certificate on `quic/`: the observer's
/// password presented with the simulator's (valid, same-session) certificate passes the TLS and
/// password checks but matches no access rule, so nothing it publishes is delivered, while the
/// genuine observer's messages are.
#[test]
fn a_password_with_another_processs_certificate_gets_no_access() {
    let s = session("swap");
    let keys = &s.keys;
    // The scheduler reads every observer's status.
    let mut sched = client(&s, &creds(&s, "scheduler"), 20_000).unwrap();
    sched.subscribe(&keys.observer_status_any()).unwrap();
    let status_key = keys.observer_status(&proto::ObserverId::new("O1").unwrap());
    let mut attempt = |creds: &Credentials, marker: u8| -> bool {
        let mut obs = client(&s, creds, 20_000).unwrap();
        // The declarations rule lets it know the simulator's subscriptions; give them a moment.
        std::thread::sleep(Duration::from_millis(500));
        for _ in 0..5 {
            obs.put_bytes(&status_key, vec![marker; 8]).unwrap();
        }
        let deadline = Instant::now() + Duration::from_secs(3);
        while Instant::now() < deadline {
            if let Some(Inbound::Data { payload, .. }) = sched.recv(Duration::from_millis(50))
                && payload.first() == Some(&marker)
            {
                return true;
            }
        }
        false
    };
    let mut swapped = creds(&s, "observer-O1");
    swapped.tls = creds(&s, "sim").tls;
    assert!(
        !attempt(&swapped, 7),
        "a swapped certificate was given the observer's access"
    );
    assert!(
        attempt(&creds(&s, "observer-O1"), 9),
        "the genuine observer was refused"
    );
}

/// Certificates that must never open a link: the session's own once they have expired (the
/// same files that opened a link a moment before), and a self-signed one bearing a session
/// process's name.
#[test]
fn expired_and_self_signed_certificates_are_refused() {
    // Valid for 5 s from issuance: a loaded machine still connects well within it.
    let issued = Instant::now();
    let short = session_valid_for("expiry", Duration::from_secs(5));
    let sim = creds(&short, "sim");
    assert!(
        client(&short, &sim, 2_000).is_ok(),
        "fresh certificates were refused"
    );
    std::thread::sleep(Duration::from_secs(6).saturating_sub(issued.elapsed()));
    assert!(
        client(&short, &sim, 3_000).is_err(),
        "an expired certificate was accepted"
    );

    let s = session("self-signed");

    // Self-signed, named `sim`, with our own password.
    let key = rcgen::KeyPair::generate().unwrap();
    let mut params = rcgen::CertificateParams::new(vec!["localhost".to_string()]).unwrap();
    params
        .distinguished_name
        .push(rcgen::DnType::CommonName, "sim");
    let cert = params.self_signed(&key).unwrap();
    let dir = scratch("forged-cert");
    std::fs::create_dir_all(&dir).unwrap();
    let (cert_file, key_file) = (dir.join("sim.cert.pem"), dir.join("sim.key.pem"));
    std::fs::write(&cert_file, cert.pem()).unwrap();
    std::fs::write(&key_file, key.serialize_pem()).unwrap();
    let mut forged = creds(&s, "sim");
    let mut tls = forged.tls.clone().unwrap();
    tls.cert = cert_file;
    tls.key = key_file;
    forged.tls = Some(tls);
    assert!(
        client(&s, &forged, 3_000).is_err(),
        "a self-signed certificate was accepted"
    );
    assert!(client(&s, &creds(&s, "sim"), 20_000).is_ok());
}

/// An institution's CA (made here as an institution would: a self-signed CA certificate and
/// its key in two PEM files) issues the session's certificates: the session's `ca.pem` is the
/// institution's certificate, messages cross, and a certificate of a session CA is refused.
#[test]
fn an_institutions_ca_issues_a_sessions_certificates() {
    let dir = scratch("institution");
    std::fs::create_dir_all(&dir).unwrap();
    let key = rcgen::KeyPair::generate().unwrap();
    let mut params = rcgen::CertificateParams::new(Vec::<String>::new()).unwrap();
    params.is_ca = rcgen::IsCa::Ca(rcgen::BasicConstraints::Unconstrained);
    params
        .distinguished_name
        .push(rcgen::DnType::CommonName, "Example University robotics CA");
    let cert = params.self_signed(&key).unwrap();
    let (cert_file, key_file) = (dir.join("ca.crt"), dir.join("ca.key"));
    std::fs::write(&cert_file, cert.pem()).unwrap();
    std::fs::write(&key_file, key.serialize_pem()).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&key_file, std::fs::Permissions::from_mode(0o600)).unwrap();
    let ca = ExistingCa::read(&cert_file, &key_file).unwrap();

    let s = session_signed_by("inst", bus::auth::CERTIFICATE_VALIDITY, Some(&ca));
    let ca_pem = std::fs::read_to_string(s.secrets.dir().join(bus::tls::CA_FILE)).unwrap();
    assert_eq!(ca_pem, cert.pem());
    let mut sim = client(&s, &creds(&s, "sim"), 20_000).unwrap();
    let mut obs = client(&s, &creds(&s, "observer-O1"), 20_000).unwrap();
    obs.subscribe(&s.keys.clock()).unwrap();
    common::await_subscriber(&mut sim, &mut obs, &s.keys);
    sim.put(&s.keys.clock(), &ClockTick::at(7).unwrap())
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut got = None;
    while got.is_none() && Instant::now() < deadline {
        if let Some(Inbound::Data { payload, .. }) = obs.recv(Duration::from_millis(50)) {
            got = proto::decode::<ClockTick>(&payload).ok().map(|c| c.tick);
        }
    }
    assert_eq!(got, Some(7));
    // A certificate from a session's own CA is not the institution's.
    let other = session("not-inst");
    let mut forged = creds(&s, "sim");
    forged.tls = creds(&other, "sim").tls;
    assert!(client(&s, &forged, 3_000).is_err());

    // Refused, naming the file: a key others may read, a key of another certificate, a leaf
    // certificate that is no CA.
    std::fs::set_permissions(&key_file, std::fs::Permissions::from_mode(0o644)).unwrap();
    let e = ExistingCa::read(&cert_file, &key_file)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("readable by other users") && e.contains("ca.key"),
        "{e}"
    );
    std::fs::set_permissions(&key_file, std::fs::Permissions::from_mode(0o600)).unwrap();
    let sim_files = creds(&s, "sim").tls.unwrap();
    let e = ExistingCa::read(&cert_file, &sim_files.key)
        .unwrap_err()
        .to_string();
    assert!(e.contains("not the key of the CA certificate"), "{e}");
    let e = ExistingCa::read(&sim_files.cert, &sim_files.key)
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a CA certificate"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `ExistingCa`'s refusal of the CA in a `tls_pem` fuzzing regression (certificate, NUL, key),
/// read as if from `inst.crt` and `inst.key`.
fn refusal_of_regression(name: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fuzz/regressions/tls_pem")
        .join(name);
    let bytes = std::fs::read(&path).unwrap();
    let nul = bytes.iter().position(|&b| b == 0).unwrap();
    let cert = String::from_utf8(bytes[..nul].to_vec()).unwrap();
    let key = String::from_utf8(bytes[nul + 1..].to_vec()).unwrap();
    let paths = (Path::new("inst.crt"), Path::new("inst.key"));
    let e = ExistingCa::from_pem(cert, key, paths, 1_767_225_600).unwrap_err();
    e.to_string()
}

#[test]
fn a_ca_whose_subject_cannot_be_rebuilt_as_read_is_refused_naming_it() {
    // The fuzzer's finding: a CA certificate whose subject name holds a byte outside its one
    // attribute (its lengths one longer than the attribute). Parsers accept it; every
    // certificate issued under it named another issuer.
    let e =
        refusal_of_regression("ca-subject-not-rebuilt-86c8a7c2cbebc3a39e72f83db47856147b358859");
    assert!(
        e.contains("inst.crt") && e.contains("subject name does not encode as read"),
        "{e}"
    );
}

#[test]
fn a_ca_whose_subject_has_an_attribute_type_der_cannot_encode_is_refused() {
    // The fuzzer's second finding: a subject attribute type read as 5.5 (a first byte of 205
    // split naively). rcgen's encoder panicked writing it into an issued certificate.
    let e = refusal_of_regression(
        "ca-subject-oid-not-encodable-d8e4b2893c320674557969dee4bc8d3a0b522ca1",
    );
    assert!(
        e.contains("inst.crt") && e.contains("cannot be encoded again"),
        "{e}"
    );
}
