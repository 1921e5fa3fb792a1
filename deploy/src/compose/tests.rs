use super::build::{ComposeOptions, compose};
use super::place::HostPlacement;
use super::*;
use crate::case::Case;
use crate::fault::{ExtraFaults, KillSpec};
use proto::{Modality, Role};

fn options(case: &str, placements: &[&str], router: &[&str]) -> (Case, ComposeOptions) {
    let case_value = Case::load(case).unwrap();
    let opts = ComposeOptions {
        case_name: case.to_string(),
        case_text: crate::case::case_source(case).unwrap(),
        session: "s1".into(),
        modality: Modality::Events,
        grace_ms: 10_000,
        extra_faults: ExtraFaults {
            kill: if case_value.observers >= 2 {
                vec!["O2@35".parse::<KillSpec>().unwrap()]
            } else {
                Vec::new()
            },
            ..ExtraFaults::default()
        },
        observer_acl: false,
        auth: true,
        // These tests place routers on private addresses over TCP; the refusal is tested below.
        plain_tcp: true,
        record: true,
        record_all_rgb: false,
        record_events: Default::default(),
        render: proto::RenderPath::Damage,
        sensor: node_args::SensorArgs::default(),
        router_listen: router.iter().map(|s| s.to_string()).collect(),
        router_connect: Vec::new(),
        placements: placements.iter().map(|p| p.parse().unwrap()).collect(),
        ros2_cameras: Default::default(),
        receivers: Default::default(),
        plugin_time_limit_ms: None,
    };
    (case_value, opts)
}

fn composed(case: &str, placements: &[&str], router: &[&str]) -> Compose {
    let (c, o) = options(case, placements, router);
    let mut out = compose(&c, &o).unwrap();
    out.secrets = Some("s1.secrets".into());
    out
}

#[test]
fn a_composed_session_round_trips_through_its_file_and_checks() {
    let c = composed(
        "nominal-3",
        &["camera-*=b", "observer-O3=c", "camera-O3=c"],
        &["tcp/10.1.0.1:7447"],
    );
    c.check().unwrap();
    let text = c.to_toml().unwrap();
    let back: Compose = toml::from_str(&text).unwrap();
    assert_eq!(back, c);
    assert_eq!(c.hosts(), ["b", "c", "local"]);
    assert_eq!(c.supervisor_host(), "local");
    let on_b: Vec<String> = c.nodes_on("b").map(|n| n.role.name()).collect();
    assert_eq!(on_b, ["camera-O1", "camera-O2"]);
    assert_eq!(c.dial_from("b"), ["tcp/10.1.0.1:7447"]);
    assert_eq!(c.faults.kill, ["O2@35".parse().unwrap()]);
    // The camera of the killed observer stops its stream itself at the dropout time.
    let cam2 = c
        .nodes
        .iter()
        .find(|n| n.role.name() == "camera-O2")
        .unwrap();
    assert!(
        cam2.args
            .windows(2)
            .any(|w| w == ["--dropout-ns", "35000000000"])
    );
    assert!(c.users_on("b").contains(&"launcher-b".to_string()));
    assert!(c.users_on("local").contains(&"launcher".to_string()));
    assert_eq!(c.users().len(), 3 + 6 + 1 + 1 + 3);
}

#[test]
fn the_router_host_dials_loopback_and_a_free_port_is_resolved() {
    let mut c = composed("one-observer", &[], &["tcp/0.0.0.0:0"]);
    c.auth = true;
    assert_eq!(c.dial_from("local"), ["tcp/127.0.0.1:0"]);
    let mut one = composed("one-observer", &[], &[]);
    resolve_free_ports(&mut one).unwrap();
    let port = one.router.listen[0].rsplit_once(':').unwrap().1;
    assert_ne!(port.parse::<u16>().unwrap(), 0);
    assert!(resolve_free_ports(&mut c).is_ok());
}

fn check_err(c: &Compose) -> String {
    format!("{:#}", anyhow::Error::from(c.check().unwrap_err()))
}

#[test]
fn bad_compose_files_are_refused_naming_what_is_wrong() {
    let good = composed("two-observers", &["observer-*=b"], &["tcp/10.1.0.1:7447"]);
    good.check().unwrap();

    let mut c = good.clone();
    c.nodes.retain(|n| n.role.name() != "camera-O2");
    assert!(check_err(&c).contains("camera-O2"), "{}", check_err(&c));

    let mut c = good.clone();
    c.nodes.push(c.nodes[0].clone());
    assert!(check_err(&c).contains("twice"));

    let mut c = good.clone();
    c.nodes[0].role = "camera-O7".parse().unwrap();
    assert!(check_err(&c).contains("camera-O7"));

    let mut c = good.clone();
    c.nodes[0].binary = "../../bin/sh".into();
    assert!(check_err(&c).contains("binary"));

    let mut c = good.clone();
    c.nodes[0].host = "a b".into();
    assert!(check_err(&c).contains("host"));

    let mut c = good.clone();
    c.router.listen = vec!["tcp/127.0.0.1:7447".into()];
    assert!(check_err(&c).contains("reach"), "{}", check_err(&c));

    let mut c = good.clone();
    c.router.listen = vec!["tcp/10.1.0.1:0".into()];
    assert!(check_err(&c).contains("port 0"));

    let mut c = good.clone();
    c.router.listen = vec!["nonsense".into()];
    assert!(check_err(&c).contains("nonsense"));

    let mut c = composed("two-observers", &[], &["tcp/10.1.0.1:7447"]);
    c.auth = false;
    assert!(check_err(&c).contains("auth = false"));

    let mut c = good.clone();
    c.secrets = None;
    assert!(check_err(&c).contains("secrets"));

    let mut c = good.clone();
    c.faults.kill = vec!["O9@3".parse().unwrap()];
    assert!(check_err(&c).contains("O9"), "{}", check_err(&c));

    let mut c = good.clone();
    c.version = 2;
    assert!(check_err(&c).contains("version"));

    let mut c = good.clone();
    c.case = "name = 3".into();
    assert!(check_err(&c).contains("case"));

    let mut c = good.clone();
    c.session = "a/b".into();
    assert!(check_err(&c).contains("a/b"));
}

#[test]
fn unknown_keys_are_rejected() {
    let good = composed("one-observer", &[], &[]).to_toml().unwrap();
    for (from, to) in [
        ("version = 1", "version = 1\ncolour = \"blue\""),
        ("[router]", "[router]\nport = 1"),
        ("[[node]]", "[[node]]\nrestart = true"),
    ] {
        let bad = good.replacen(from, to, 1);
        let e = toml::from_str::<Compose>(&bad).unwrap_err().to_string();
        assert!(e.contains("unknown field"), "{e}");
    }
}

#[test]
fn a_placement_that_matches_nothing_is_an_error() {
    let (c, mut o) = options("one-observer", &[], &[]);
    o.placements = vec!["camera-O2=b".parse::<HostPlacement>().unwrap()];
    o.extra_faults = ExtraFaults::default();
    let e = compose(&c, &o).unwrap_err().to_string();
    assert!(e.contains("camera-O2") && e.contains("camera-O1"), "{e}");
    o.placements = vec!["router=r".parse::<HostPlacement>().unwrap()];
    let placed = compose(&c, &o).unwrap();
    assert_eq!(placed.router.host, "r");
    assert_eq!(placed.hosts(), ["local", "r"]);
}

fn noisy() -> node_args::SensorArgs {
    node_args::SensorArgs {
        preset: Some("v2e-default".into()),
        perturb: vec![
            "events.leak_hz=0.2".into(),
            "events.shot_noise_hz=0.5".into(),
        ],
        seed: 7,
    }
}

#[test]
fn a_sensor_model_rides_on_every_camera_and_round_trips_through_the_file() {
    let (c, mut o) = options("nominal-3", &["camera-O2=b"], &["tcp/10.1.0.1:7447"]);
    o.sensor = noisy();
    let mut composed = compose(&c, &o).unwrap();
    composed.secrets = Some("s1.secrets".into());
    composed.check().unwrap();
    let want = [
        "--sensor-preset",
        "v2e-default",
        "--perturb",
        "events.leak_hz=0.2",
        "--perturb",
        "events.shot_noise_hz=0.5",
        "--seed",
        "7",
    ];
    for n in composed
        .nodes
        .iter()
        .filter(|n| n.role.role == Role::Camera)
    {
        assert!(
            n.args.ends_with(&want.map(String::from)),
            "{}: {:?}",
            n.role,
            n.args
        );
    }
    // Only the cameras carry it, and the recorder, which keeps their input for the replay
    // to regenerate the packets from.
    for n in &composed.nodes {
        let carries = n.args.iter().any(|a| a == "--sensor-preset");
        let keeps_input = match n.role.role {
            Role::Camera => n.args.iter().any(|a| a == "--publish-input"),
            Role::Recorder => n.args.iter().any(|a| a == "--events-from-input"),
            _ => false,
        };
        let camera_or_recorder = matches!(n.role.role, Role::Camera | Role::Recorder);
        assert_eq!(carries, camera_or_recorder, "{}", n.role);
        assert_eq!(keeps_input, camera_or_recorder, "{}", n.role);
    }
    let back: Compose = toml::from_str(&composed.to_toml().unwrap()).unwrap();
    assert_eq!(back, composed);
    assert_eq!(back.sensor().unwrap(), noisy());
    let record = run_eval::sensor::record(&back.sensor().unwrap())
        .unwrap()
        .unwrap();
    assert_eq!(record.preset.as_deref(), Some("v2e-default"));
    assert_eq!(record.seed, 7);
    // The preset's terms with the explicit ones over them, sorted by key.
    let keys: Vec<&str> = record.perturb.keys().map(String::as_str).collect();
    let mut sorted = keys.clone();
    sorted.sort_unstable();
    assert_eq!(keys, sorted);
    assert_eq!(record.perturb["events.leak_hz"], 0.2);
    assert_eq!(record.perturb["events.shot_noise_hz"], 0.5);
    let same = perturb::Perturbation::with_preset(Some("v2e-default"), &noisy().perturb).unwrap();
    assert_eq!(record.perturb, same.recorded());

    // Cameras that disagree are refused.
    let mut c2 = back.clone();
    let cam = c2
        .nodes
        .iter_mut()
        .find(|n| n.role.name() == "camera-O3")
        .unwrap();
    let seed = cam.args.len() - 1;
    cam.args[seed] = "8".into();
    assert!(
        check_err(&c2).contains("different sensor models"),
        "{}",
        check_err(&c2)
    );
}

#[test]
fn without_a_sensor_model_the_cameras_arguments_are_unchanged() {
    let c = composed("one-observer", &[], &[]);
    let cam = c
        .nodes
        .iter()
        .find(|n| n.role.name() == "camera-O1")
        .unwrap();
    assert_eq!(
        cam.args,
        [
            "camera",
            "--observer",
            "O1",
            "--modality",
            "events",
            "--render",
            "damage"
        ]
    );
    assert!(c.sensor().unwrap().is_none());
    assert_eq!(
        run_eval::sensor::record(&c.sensor().unwrap()).unwrap(),
        None
    );
}

#[test]
fn unknown_presets_other_groups_and_rgb_cameras_are_refused_naming_them() {
    let err = |s: node_args::SensorArgs, m: Modality| format!("{:#}", s.check(m).unwrap_err());
    let unknown = node_args::SensorArgs {
        preset: Some("v2e-loud".into()),
        ..Default::default()
    };
    let e = err(unknown.clone(), Modality::Events);
    assert!(e.contains("v2e-loud") && e.contains("v2e-default"), "{e}");
    let rgb_term = node_args::SensorArgs {
        perturb: vec!["rgb.read_noise_grey=4".into()],
        ..Default::default()
    };
    assert!(err(rgb_term, Modality::Events).contains("rgb.read_noise_grey"));
    assert!(err(noisy(), Modality::Rgb).contains("rgb"));
    // compose refuses it before writing anything.
    let (c, mut o) = options("one-observer", &[], &[]);
    o.sensor = unknown;
    let e = format!("{:#}", compose(&c, &o).unwrap_err());
    assert!(e.contains("v2e-loud"), "{e}");
}

#[test]
fn every_composed_node_parses_as_its_binarys_arguments_and_bad_ones_are_refused() {
    let mut c = composed("nominal-3", &["camera-O2=b"], &["tcp/10.1.0.1:7447"]);
    for n in &c.nodes {
        let line = n.line().unwrap();
        assert_eq!(line.binary(), n.binary, "{}", n.role);
        assert_eq!(line.to_args(), n.args, "{}", n.role);
    }
    let obs = c
        .nodes
        .iter_mut()
        .find(|n| n.role.name() == "observer-O2")
        .unwrap();
    obs.args.extend(["--grace".to_string(), "5".to_string()]);
    let e = check_err(&c);
    assert!(e.contains("observer-O2") && e.contains("--grace"), "{e}");
}

#[test]
fn a_compose_files_faults_are_typed_and_a_bad_one_is_refused_naming_it() {
    let text = composed("nominal-3", &[], &[]).to_toml().unwrap();
    assert!(text.contains("kill = [\"O2@35\"]"), "{text}");
    let bad = text.replace("\"O2@35\"", "\"O2@soon\"");
    let err = toml::from_str::<Compose>(&bad).unwrap_err().to_string();
    assert!(err.contains("O2@soon") && err.contains("kill"), "{err}");
}

#[test]
fn a_node_role_that_is_no_process_is_refused_when_the_file_is_read() {
    let text = composed("only-a", &[], &[]).to_toml().unwrap();
    assert!(text.contains("role = \"camera-O1\""), "{text}");
    let bad = text.replace("role = \"camera-O1\"", "role = \"robot-O1\"");
    let err = toml::from_str::<Compose>(&bad).unwrap_err().to_string();
    assert!(err.contains("robot-O1"), "{err}");
}

#[test]
fn a_plain_tcp_router_beyond_loopback_needs_the_explicit_flag() {
    let mut c = composed("two-observers", &["camera-O2=b", "observer-O2=b"], &[]);
    c.router.listen = vec!["tcp/10.1.0.1:7447".into()];
    c.plain_tcp = false;
    let e = check_err(&c);
    assert!(
        e.contains("tcp/10.1.0.1:7447") && e.contains("quic/") && e.contains("--plain-tcp"),
        "{e}"
    );
    c.plain_tcp = true;
    c.check().unwrap();
    // QUIC carries the session's certificates: no flag needed. Loopback TCP never needs it.
    c.plain_tcp = false;
    c.router.listen = vec!["quic/10.1.0.1:7447".into()];
    c.check().unwrap();
    let mut one_host = composed("one-observer", &[], &[]);
    one_host.plain_tcp = false;
    one_host.check().unwrap();
    // The flag survives the file.
    c.plain_tcp = true;
    let back: Compose = toml::from_str(&toml::to_string(&c).unwrap()).unwrap();
    assert!(back.plain_tcp);
}

fn site(host: &str, listen: &[&str], serves: &[&str]) -> SiteRouter {
    SiteRouter {
        host: host.into(),
        listen: listen.iter().map(|s| s.to_string()).collect(),
        serves: serves.iter().map(|s| s.to_string()).collect(),
    }
}

#[test]
fn a_sites_hosts_dial_its_router_which_dials_the_sessions() {
    let mut c = composed(
        "nominal-3",
        &["*=a", "*-O1=b", "*-O2=c", "*-O3=d"],
        &["quic/10.1.0.1:7447"],
    );
    c.sites = vec![
        site("b", &["quic/0.0.0.0:7448"], &[]),
        site("e", &["quic/10.2.0.5:7447"], &["c"]),
    ];
    // b's router listens on every address but dials from b as loopback: only b uses it.
    c.sites[0].listen = vec!["quic/10.3.0.2:7448".into()];
    c.check().unwrap();
    let back: Compose = toml::from_str(&c.to_toml().unwrap()).unwrap();
    assert_eq!(back, c);
    assert_eq!(c.hosts(), ["a", "b", "c", "d", "e"]);
    assert_eq!(c.dial_from("a"), ["quic/10.1.0.1:7447"]);
    assert_eq!(c.dial_from("b"), ["quic/10.3.0.2:7448"]);
    assert_eq!(c.dial_from("c"), ["quic/10.2.0.5:7447"]);
    assert_eq!(c.dial_from("d"), ["quic/10.1.0.1:7447"]);
    assert_eq!(c.router_dial_from("e"), ["quic/10.1.0.1:7447"]);
    assert_eq!(c.site_of("c").map(|s| s.host.as_str()), Some("e"));
    assert!(c.site_of("d").is_none() && c.site_on("c").is_none());
    // The site router's host holds its launcher's credentials, its own user upstream.
    assert_eq!(c.users_on("e"), ["launcher-e"]);
    assert_eq!(c.launcher_of("a"), "launcher");
}

#[test]
fn bad_sites_are_refused_naming_what_is_wrong() {
    let base = composed(
        "nominal-3",
        &["*=a", "*-O1=b", "*-O2=c"],
        &["quic/10.1.0.1:7447"],
    );
    let cases: [(Vec<SiteRouter>, &str); 7] = [
        (
            vec![site("a", &["quic/10.1.0.1:7448"], &[])],
            "session's router runs on a",
        ),
        (vec![site("b", &[], &[])], "listens nowhere"),
        (vec![site("b", &["quic/10.1.0.2:0"], &[])], "port 0"),
        (
            vec![site("b", &["quic/10.1.0.2:1"], &["z"])],
            "serves z, which runs no node",
        ),
        (
            vec![site("b", &["quic/127.0.0.1:1"], &["c"])],
            "give it an address they reach",
        ),
        (
            vec![
                site("b", &["quic/10.1.0.2:1"], &["c"]),
                site("x", &["quic/10.1.0.3:1"], &["c"]),
            ],
            "host c is in two sites",
        ),
        (
            vec![site("b", &["quic/10.1.0.2:1"], &["a"])],
            "cannot serve a",
        ),
    ];
    for (sites, want) in cases {
        let mut c = base.clone();
        c.sites = sites;
        let err = check_err(&c);
        assert!(err.contains(want), "{want:?} not in {err}");
    }
    let mut tcp = base.clone();
    tcp.plain_tcp = false;
    tcp.sites = vec![site("b", &["tcp/10.1.0.2:7447"], &[])];
    assert!(check_err(&tcp).contains("plain TCP"), "{}", check_err(&tcp));
    let mut only_loopback = base.clone();
    only_loopback.router.listen = vec!["quic/127.0.0.1:7447".into()];
    only_loopback.sites = vec![site("b", &["quic/10.1.0.2:1"], &[])];
    assert!(check_err(&only_loopback).contains("reach"));
}

#[test]
fn the_recording_keeps_the_event_sensors_input_only_when_asked_or_noisy() {
    use super::build::EventRecording;
    let keeps = |record: bool, how: EventRecording, modality: Modality, noisy_sensor: bool| {
        let (c, mut o) = options("only-a", &[], &[]);
        o.record = record;
        o.record_events = how;
        o.modality = modality;
        if noisy_sensor {
            o.sensor = noisy();
        }
        let composed = compose(&c, &o).unwrap();
        let flags: Vec<(Role, bool)> = composed
            .nodes
            .iter()
            .filter(|n| matches!(n.role.role, Role::Camera | Role::Recorder))
            .map(|n| {
                let flag = n
                    .args
                    .iter()
                    .any(|a| a == "--publish-input" || a == "--events-from-input");
                (n.role.role, flag)
            })
            .collect();
        let all = flags.iter().all(|f| f.1);
        assert!(all || flags.iter().all(|f| !f.1), "{flags:?}");
        all
    };
    use EventRecording::{Auto, Input, Packets};
    assert!(keeps(true, Auto, Modality::Events, true));
    assert!(!keeps(true, Auto, Modality::Events, false));
    assert!(keeps(true, Input, Modality::Events, false));
    assert!(!keeps(true, Packets, Modality::Events, true));
    assert!(!keeps(true, Input, Modality::Rgb, false));
    // Nobody records: nothing to publish it for.
    assert!(!keeps(false, Input, Modality::Events, true));
}

#[test]
fn a_plugin_receiver_rides_only_on_its_observers_line_and_an_unknown_observer_is_refused() {
    let (case, mut opts) = options("only-a", &[], &[]);
    let o2 = proto::ObserverId::new("O2").unwrap();
    opts.receivers
        .insert(o2.clone(), "python:lab.rx:Tracker".parse().unwrap());
    opts.plugin_time_limit_ms = Some(90_000);
    let c = compose(&case, &opts).unwrap();
    let args_of = |role: &str| {
        c.nodes
            .iter()
            .find(|n| n.role.name() == role)
            .unwrap()
            .args
            .clone()
    };
    let o2_args = args_of("observer-O2");
    for pair in [
        ["--receiver", "python:lab.rx:Tracker"],
        ["--plugin-time-limit-ms", "90000"],
        ["--plugin-seed", "0"],
    ] {
        assert!(
            o2_args.windows(2).any(|w| w == pair),
            "{pair:?} in {o2_args:?}"
        );
    }
    for other in ["observer-O1", "observer-O3", "camera-O2"] {
        assert!(
            !args_of(other)
                .iter()
                .any(|a| a.contains("plugin") || a == "--receiver"),
            "{other}"
        );
    }
    let text = c.to_toml().unwrap();
    assert_eq!(toml::from_str::<Compose>(&text).unwrap(), c);
    opts.receivers.clear();
    opts.receivers.insert(
        proto::ObserverId::new("O9").unwrap(),
        "python:lab.rx:Tracker".parse().unwrap(),
    );
    let err = compose(&case, &opts).unwrap_err().to_string();
    assert!(err.contains("O9") && err.contains("3 observers"), "{err}");
}
