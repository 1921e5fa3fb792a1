//! The built-in study files (`waggle study NAME`): their names and TOML texts, known to the
//! command line (its help names them) and to the lab, which parses and runs them.

/// The built-in studies (`waggle study NAME`), as TOML.
pub const BUILT_IN: &[(&str, &str)] = &[
    (
        "event-noise",
        include_str!("../../../deploy/studies/event-noise.toml"),
    ),
    (
        "rgb-noise",
        include_str!("../../../deploy/studies/rgb-noise.toml"),
    ),
    (
        "viewing-angle",
        include_str!("../../../deploy/studies/viewing-angle.toml"),
    ),
    (
        "distance",
        include_str!("../../../deploy/studies/distance.toml"),
    ),
    (
        "baselines",
        include_str!("../../../deploy/studies/baselines.toml"),
    ),
    ("light", include_str!("../../../deploy/studies/light.toml")),
    (
        "light-bandwidth",
        include_str!("../../../deploy/studies/light-bandwidth.toml"),
    ),
    ("wind", include_str!("../../../deploy/studies/wind.toml")),
    (
        "real-noise",
        include_str!("../../../deploy/studies/real-noise.toml"),
    ),
    (
        "wind-links",
        include_str!("../../../deploy/studies/wind-links.toml"),
    ),
    (
        "event-margin",
        include_str!("../../../deploy/studies/event-margin.toml"),
    ),
];
