//! Every node's arguments survive `to_args` → parse unchanged, for arbitrary values, and bad
//! arguments are refused naming the node.

use node_args::{
    CameraArgs, CameraThrottle, NodeArgsError, NodeCommand, NodeLine, ObserverArgs, PerformerArgs,
    RecorderArgs, RecorderOutput, Ros2Source, SchedulerArgs, SensorArgs,
};
use proptest::prelude::*;
use proto::{FlightMode, FrameCheck, Modality, ObserverId, RenderPath};

fn observer_id() -> impl Strategy<Value = ObserverId> {
    (0usize..8).prop_map(ObserverId::from_index)
}

fn frame_check() -> impl Strategy<Value = FrameCheck> {
    proptest::sample::select(FrameCheck::ALL.to_vec())
}

fn modality() -> impl Strategy<Value = Modality> {
    prop_oneof![Just(Modality::Rgb), Just(Modality::Events)]
}

fn sensor() -> impl Strategy<Value = SensorArgs> {
    prop_oneof![
        Just(SensorArgs::default()),
        (
            proptest::option::of(prop_oneof![
                Just("v2e-clean".to_string()),
                Just("v2e-noisy".to_string())
            ]),
            proptest::collection::vec(
                (0.0f64..5.0).prop_map(|v| format!("events.shot_noise_hz={v}")),
                1..3
            ),
            any::<u64>(),
        )
            .prop_map(|(preset, perturb, seed)| SensorArgs {
                preset,
                perturb,
                seed
            }),
        (any::<u64>()).prop_map(|seed| SensorArgs {
            preset: Some("v2e-default".into()),
            perturb: Vec::new(),
            seed
        }),
    ]
}

/// No ROS 2 source (the default), or a topic with a domain, router and maybe a calibration.
fn ros2_source() -> impl Strategy<Value = Ros2Source> {
    prop_oneof![
        Just(Ros2Source::default()),
        (
            "/[a-z][a-z0-9_]{0,8}(/[a-z][a-z0-9_]{0,8}){0,2}",
            0u32..233,
            "tcp/127\\.0\\.0\\.1:[1-9][0-9]{3}",
            proptest::option::of("/[a-z]{1,8}/[a-z]{1,8}\\.yaml"),
        )
            .prop_map(|(topic, domain, router, calibration)| Ros2Source {
                topic: Some(topic),
                domain,
                router,
                calibration: calibration.map(Into::into),
            }),
    ]
}

/// Any `scheduler-node` command line.
fn scheduler() -> impl Strategy<Value = NodeCommand> {
    (
        modality(),
        "[A-D](,[A-D]){0,3}",
        (
            0u32..10,
            proptest::option::of("[AB]=[0-9]{1,4}(,B=[0-9]{1,4})?"),
        ),
        1u32..9,
        proptest::option::of(1.0f64..1e5),
        prop_oneof![Just(FlightMode::Sequential), Just(FlightMode::Concurrent)],
        frame_check(),
    )
        .prop_map(
            |(
                modality,
                offers,
                (rounds, work),
                max_broadcasts,
                time_limit_s,
                flights,
                frame_check,
            )| {
                NodeCommand::Scheduler(SchedulerArgs {
                    modality,
                    offers,
                    rounds,
                    work,
                    max_broadcasts,
                    time_limit_s,
                    flights,
                    frame_check,
                })
            },
        )
}

fn command() -> impl Strategy<Value = NodeCommand> {
    prop_oneof![
        Just(NodeCommand::Sim),
        frame_check().prop_map(|frame_check| NodeCommand::Performer(PerformerArgs { frame_check })),
        scheduler(),
        (
            observer_id(),
            modality(),
            any::<bool>(),
            proptest::option::of(any::<u64>()),
            prop_oneof![
                Just(RenderPath::Damage),
                Just(RenderPath::Full),
                Just(RenderPath::Raster)
            ],
            (sensor(), any::<bool>(), ros2_source()),
            proptest::collection::vec((any::<u64>(), 0u16..=1000, any::<u32>()), 0..3),
        )
            .prop_map(
                |(
                    observer,
                    modality,
                    black,
                    dropout_ns,
                    render,
                    (sensor, publish_input, ros2_source),
                    throttle,
                )| {
                    NodeCommand::Camera(CameraArgs {
                        observer,
                        modality,
                        black,
                        dropout_ns,
                        throttle: throttle
                            .into_iter()
                            .map(|(from_ns, drop_per_mille, delay_ms)| CameraThrottle {
                                from_ns,
                                drop_per_mille,
                                delay_ms,
                            })
                            .collect(),
                        render,
                        sensor,
                        publish_input,
                        ros2_source,
                    })
                },
            ),
        (
            observer_id(),
            modality(),
            any::<u64>(),
            proptest::option::of((
                "python:[a-z_][a-z0-9_]{0,8}(\\.[a-z_][a-z0-9_]{0,8})?:[A-Z][A-Za-z0-9_]{0,8}",
                proptest::option::of(any::<u64>()),
                proptest::option::of(any::<u64>()),
            )),
            frame_check(),
        )
            .prop_map(|(id, modality, grace_ms, plugin, frame_check)| {
                let (receiver, plugin_time_limit_ms, plugin_seed) = match plugin {
                    Some((spec, limit, seed)) => (Some(spec.parse().unwrap()), limit, seed),
                    None => (None, None, None),
                };
                NodeCommand::Observer(ObserverArgs {
                    id,
                    modality,
                    grace_ms,
                    receiver,
                    plugin_time_limit_ms,
                    plugin_seed,
                    frame_check,
                })
            }),
        (
            proptest::option::of("[a-z][a-z0-9-]{0,12}"),
            proptest::option::of(modality()),
            0.0f64..100.0,
            1u64..100,
            any::<bool>(),
            (1u64..1 << 20, any::<u32>(), any::<u32>()),
            (any::<bool>(), sensor()),
        )
            .prop_map(
                |(
                    case_name,
                    modality,
                    event_view_hz,
                    rgb_every,
                    all_rgb,
                    (chunk, flush, linger),
                    (events_from_input, sensor),
                )| {
                    NodeCommand::Recorder(RecorderArgs {
                        case_name,
                        modality,
                        event_view_hz,
                        rgb_every,
                        all_rgb,
                        chunk_kib: chunk,
                        flush_ms: flush.into(),
                        linger_ms: linger.into(),
                        events_from_input,
                        sensor,
                    })
                }
            ),
    ]
}

proptest! {
    #[test]
    fn every_node_line_round_trips(
        command in command(),
        deny in proptest::collection::vec("waggle/[a-z]{1,6}/\\*\\*", 0..3),
    ) {
        let line = NodeLine { command, deny };
        let parsed = NodeLine::parse(line.binary(), &line.to_args()).unwrap();
        prop_assert_eq!(parsed, line);
    }
}

#[test]
fn the_recorders_output_round_trips() {
    #[derive(clap::Parser)]
    struct Cli {
        #[command(flatten)]
        out: RecorderOutput,
    }
    for out in [
        RecorderOutput {
            out: "runs/x/session.mcap".into(),
            case_file: Some("runs/x/case.toml".into()),
            live: Some("127.0.0.1:8765".parse().unwrap()),
            ros2_domain: Some(7),
            ros2_router: Some("tcp/10.0.0.2:7447".into()),
        },
        RecorderOutput {
            out: "y.mcap".into(),
            case_file: None,
            live: None,
            ros2_domain: Some(0),
            ros2_router: None,
        },
        RecorderOutput {
            out: "a b/s.mcap".into(),
            case_file: None,
            live: None,
            ros2_domain: None,
            ros2_router: None,
        },
    ] {
        let argv = std::iter::once("recorder-node".to_string()).chain(out.to_args());
        let back = <Cli as clap::Parser>::try_parse_from(argv).unwrap().out;
        assert_eq!(back, out);
    }
}

#[test]
fn bad_arguments_are_refused_naming_the_node() {
    let args = |a: &[&str]| a.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let err = NodeLine::parse(
        "observer-node",
        &args(&["--id", "O1", "--modality", "rgb", "--grace-ms", "soon"]),
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("observer-node") && err.contains("soon"),
        "{err}"
    );
    for bad in ["0:1001:0", "0:250", "x:250:0", "0:250:-1"] {
        let err = NodeLine::parse(
            "sim-node",
            &args(&[
                "camera",
                "--observer",
                "O1",
                "--modality",
                "events",
                "--throttle",
                bad,
            ]),
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains(bad), "{bad}: {err}");
    }
    let err = NodeLine::parse("sim-node", &args(&["camera", "--observer", "O1"]))
        .unwrap_err()
        .to_string();
    assert!(err.contains("--modality"), "{err}");
    assert!(matches!(
        NodeLine::parse("rogue-node", &[]),
        Err(NodeArgsError::UnknownBinary(_))
    ));
    let err = NodeLine::parse("performer-node", &args(&["--speed", "2"]))
        .unwrap_err()
        .to_string();
    assert!(err.contains("--speed"), "{err}");
    let err = NodeLine::parse("performer-node", &args(&["--frame-check", "crc8"]))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("--frame-check") && err.contains("crc8"),
        "{err}"
    );
}

#[test]
fn the_sensor_model_refuses_other_groups_unknown_presets_and_rgb_cameras() {
    let s = |preset: Option<&str>, terms: &[&str]| SensorArgs {
        preset: preset.map(String::from),
        perturb: terms.iter().map(|t| t.to_string()).collect(),
        seed: 1,
    };
    let msg = |e: NodeArgsError| e.to_string();
    assert!(
        msg(s(Some("v2e-loud"), &[])
            .check(Modality::Events)
            .unwrap_err())
        .contains("v2e-loud")
    );
    assert!(
        msg(s(None, &["rgb.read_noise_grey=4"])
            .check(Modality::Events)
            .unwrap_err())
        .contains("rgb.read_noise_grey")
    );
    assert!(
        msg(s(Some("v2e-default"), &[])
            .check(Modality::Rgb)
            .unwrap_err())
        .contains("rgb")
    );
    assert!(SensorArgs::default().check(Modality::Rgb).is_ok());
    assert_eq!(
        SensorArgs::default().model(Modality::Events, 1).unwrap(),
        None
    );
    let one = s(Some("v2e-default"), &[])
        .model(Modality::Events, 1)
        .unwrap();
    let two = s(Some("v2e-default"), &[])
        .model(Modality::Events, 2)
        .unwrap();
    assert!(
        one.is_some() && one != two,
        "each observer draws from its own stream"
    );
}
