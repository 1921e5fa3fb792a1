//! A chain of two routers on loopback: the session's router and a site's router that dials it
//! as the site host's launcher. Messages cross the chain both ways, and the site's router holds
//! its own clients to their access lists: a process there cannot publish what it does not own,
//! nor read what it may not.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use bus::access::{access_of, router_acl, session_router_zid, union_of};
use bus::handshake::Process;
use bus::{Bus, Credentials, Endpoints, Inbound, SessionSecrets};
use proto::{ClockTick, Keys, ObserverId, Role};

mod common;

struct Chain {
    name: String,
    secrets: SessionSecrets,
    main_endpoint: String,
    site_endpoint: String,
    _routers: (Bus, Bus),
}

/// The simulator and scheduler dial the session's router; camera O1 and observer O1 dial the
/// site's router, which authenticates upstream as `launcher-b` with their union of rights.
fn chain() -> Chain {
    let name = format!("chain-{}", std::process::id());
    let keys = Keys::new(&name).unwrap();
    let site = [
        Process::new(Role::Camera, "O1"),
        Process::new(Role::Observer, "O1"),
        Process::host_launcher("b"),
    ];
    let main = [
        Process::singleton(Role::Sim),
        Process::singleton(Role::Scheduler),
    ];
    let names: Vec<String> = site.iter().chain(&main).map(Process::name).collect();
    let dir: PathBuf = std::env::temp_dir().join(format!("waggle-{name}"));
    let secrets = SessionSecrets::create_kept(&dir, &names).unwrap();
    let mut access: Vec<_> = main.iter().map(|p| access_of(&keys, p)).collect();
    let site_access: Vec<_> = site.iter().map(|p| access_of(&keys, p)).collect();
    access.extend(site_access.iter().cloned());
    let upstream = union_of("launcher-b", &site_access);
    let mut main_access = access.clone();
    main_access.retain(|a| a.user != "launcher-b");
    main_access.push(upstream);

    let zid = session_router_zid(&name);
    let main_endpoint = common::free_endpoint("tcp");
    let main_router = Bus::open_config(
        &name,
        bus::router_config(
            &Endpoints {
                connect: vec![],
                listen: vec![main_endpoint.clone()],
            },
            secrets.dictionary(),
            &router_acl(&keys, &main_access, None),
            &zid,
        )
        .unwrap(),
    )
    .unwrap();
    let site_endpoint = common::free_endpoint("tcp");
    let launcher = Credentials::read(secrets.file_of("launcher-b").unwrap()).unwrap();
    let site_router = Bus::open_config(
        &name,
        bus::site_router_config(
            &Endpoints {
                connect: vec![main_endpoint.clone()],
                listen: vec![site_endpoint.clone()],
            },
            &launcher,
            secrets.dictionary(),
            &router_acl(&keys, &access, Some(&zid)),
        )
        .unwrap(),
    )
    .unwrap();
    Chain {
        name,
        secrets,
        main_endpoint,
        site_endpoint,
        _routers: (main_router, site_router),
    }
}

impl Chain {
    fn client(&self, user: &str, endpoint: &str) -> Bus {
        let creds = Credentials::read(self.secrets.file_of(user).unwrap()).unwrap();
        let endpoints = Endpoints {
            connect: vec![endpoint.to_string()],
            listen: vec![],
        };
        Bus::open_config(&self.name, bus::client_config(&endpoints, &creds).unwrap()).unwrap()
    }
}

impl Drop for Chain {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(self.secrets.dir());
    }
}

/// The first byte of every payload `bus` receives within `wait`.
fn markers(bus: &mut Bus, wait: Duration) -> Vec<u8> {
    let deadline = Instant::now() + wait;
    let mut out = Vec::new();
    while Instant::now() < deadline {
        if let Some(Inbound::Data { payload, .. }) = bus.recv(Duration::from_millis(50)) {
            out.push(payload[0]);
        }
    }
    out
}

#[test]
fn messages_cross_a_chain_of_two_routers_and_the_site_enforces_its_access_list() {
    let c = chain();
    let keys = Keys::new(&c.name).unwrap();
    let o1 = ObserverId::new("O1").unwrap();
    let mut sim = c.client("sim", &c.main_endpoint);
    let mut sched = c.client("scheduler", &c.main_endpoint);
    let mut obs = c.client("observer-O1", &c.site_endpoint);
    let mut cam = c.client("camera-O1", &c.site_endpoint);

    // Down the chain: the simulator's clock reaches the site's observer.
    obs.subscribe(&keys.clock()).unwrap();
    common::await_subscriber(&mut sim, &mut obs, &keys);
    sim.put(&keys.clock(), &ClockTick::at(3).unwrap()).unwrap();
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut tick = None;
    while tick.is_none() && Instant::now() < deadline {
        if let Some(Inbound::Data { payload, .. }) = obs.recv(Duration::from_millis(50)) {
            tick = proto::decode::<ClockTick>(&payload).ok().map(|t| t.tick);
        }
    }
    assert_eq!(tick, Some(3), "the clock did not cross the chain");

    // Up the chain: the observer's status reaches the scheduler; the camera's forged status on
    // the same key does not (the site's router refuses it), nor does its forged clock reach the
    // site's own observer.
    sched.subscribe(&keys.observer_status_any()).unwrap();
    let status = keys.observer_status(&o1);
    std::thread::sleep(Duration::from_millis(1500));
    for _ in 0..5 {
        cam.put_bytes(&status, vec![66; 4]).unwrap();
        cam.put_bytes(&keys.clock(), vec![66; 4]).unwrap();
        obs.put_bytes(&status, vec![9; 4]).unwrap();
    }
    let at_scheduler = markers(&mut sched, Duration::from_secs(3));
    assert!(
        at_scheduler.contains(&9),
        "the observer's status never arrived"
    );
    assert!(!at_scheduler.contains(&66), "the camera published a status");
    assert!(
        !markers(&mut obs, Duration::from_secs(1)).contains(&66),
        "the camera published a clock tick"
    );
}
