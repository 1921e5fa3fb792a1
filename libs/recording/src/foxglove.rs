//! The view channels in Foxglove's official schemas — the `foxglove` crate's message types,
//! encoded as protobuf with the schema (a `FileDescriptorSet`) the crate ships — so a
//! recording, and the live view, open usefully in Foxglove: images, frame transforms, logs
//! and a 3D scene of the drones, the work sites and the drones' trajectories.

use std::collections::BTreeMap;

use foxglove::Encode;
use foxglove::messages::{
    Color, CubePrimitive, FrameTransform, FrameTransforms, LinePrimitive, Log, Point3, Pose,
    Quaternion, RawImage, SceneEntity, SceneUpdate, SpherePrimitive, TextPrimitive, Timestamp,
    Vector3,
};
use proto::{DronePose, SimState, Site};

/// Parent frame of every pose.
pub const WORLD_FRAME: &str = "world";
/// Schema and message encoding of the view channels.
pub const VIEW_ENCODING: &str = "protobuf";

/// Foxglove log levels (`foxglove.Log.level`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogLevel {
    Info = 2,
    Warning = 3,
    Error = 4,
}

/// One encoded view message: its schema and its bytes.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewMessage {
    pub schema: foxglove::Schema,
    pub data: Vec<u8>,
}

/// The schema of one of the view channels' message types.
pub fn schema_of<T: Encode>() -> foxglove::Schema {
    T::get_schema().expect("every foxglove message type has a schema")
}

/// The view channels' message types, by what they show.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ViewKind {
    /// `foxglove.RawImage`: a camera's RGB frames or its event-frame pictures.
    Image,
    /// `foxglove.FrameTransforms`: the drones' poses.
    Transforms,
    /// `foxglove.SceneUpdate`: the 3D scene.
    Scene,
    /// `foxglove.Log`: the log lines.
    Log,
}

impl ViewKind {
    pub fn schema(self) -> foxglove::Schema {
        match self {
            Self::Image => schema_of::<RawImage>(),
            Self::Transforms => schema_of::<FrameTransforms>(),
            Self::Scene => schema_of::<SceneUpdate>(),
            Self::Log => schema_of::<Log>(),
        }
    }
}

impl ViewMessage {
    fn of<T: Encode>(msg: &T) -> Self {
        let schema = schema_of::<T>();
        let mut data = Vec::with_capacity(msg.encoded_len().unwrap_or(64));
        msg.encode(&mut data)
            .expect("a Vec grows to fit any message");
        Self { schema, data }
    }

    /// The schema's name (`foxglove.RawImage`, …).
    pub fn schema_name(&self) -> &str {
        &self.schema.name
    }
}

fn time(ns: u64) -> Option<Timestamp> {
    // Sim time starts at 0 and stays far below 2^32 s.
    Some(Timestamp::new(
        u32::try_from(ns / 1_000_000_000).unwrap_or(u32::MAX),
        (ns % 1_000_000_000) as u32,
    ))
}

fn vector(v: [f64; 3]) -> Option<Vector3> {
    Some(Vector3 {
        x: v[0],
        y: v[1],
        z: v[2],
    })
}

fn quaternion(wxyz: [f64; 4]) -> Option<Quaternion> {
    let [w, x, y, z] = wxyz;
    Some(Quaternion { x, y, z, w })
}

fn pose(pos_m: [f64; 3], wxyz: [f64; 4]) -> Option<Pose> {
    Some(Pose {
        position: vector(pos_m),
        orientation: quaternion(wxyz),
    })
}

fn color(r: f64, g: f64, b: f64, a: f64) -> Option<Color> {
    Some(Color { r, g, b, a })
}

/// A `foxglove.RawImage` of an 8-bit RGB image.
pub fn raw_image(
    stamp_ns: u64,
    frame_id: &str,
    width: u32,
    height: u32,
    rgb: &[u8],
) -> ViewMessage {
    ViewMessage::of(&RawImage {
        timestamp: time(stamp_ns),
        frame_id: frame_id.to_string(),
        width,
        height,
        encoding: "rgb8".into(),
        step: width * 3,
        data: rgb.to_vec().into(),
    })
}

/// A `foxglove.FrameTransforms` with one `world → drone` transform per drone.
pub fn frame_transforms(state: &SimState) -> ViewMessage {
    ViewMessage::of(&FrameTransforms {
        transforms: state
            .drones
            .iter()
            .map(|d| FrameTransform {
                timestamp: time(state.stamp_ns),
                parent_frame_id: WORLD_FRAME.into(),
                child_frame_id: d.name.clone(),
                translation: vector(d.pos_m),
                rotation: quaternion(d.quat_wxyz),
            })
            .collect(),
    })
}

/// A `foxglove.Log` message from `name`.
pub fn log(stamp_ns: u64, level: LogLevel, name: &str, message: &str) -> ViewMessage {
    ViewMessage::of(&Log {
        timestamp: time(stamp_ns),
        level: level as i32,
        message: message.to_string(),
        name: name.to_string(),
        file: String::new(),
        line: 0,
    })
}

/// How many past positions each drone's trail keeps (at the scene's rate).
pub const TRAIL_POINTS: usize = 600;

/// The 3D scene's state: each drone's recent trajectory.
#[derive(Debug, Clone, Default)]
pub struct Scene {
    trails: BTreeMap<String, Vec<[f64; 3]>>,
}

impl Scene {
    /// Adds `state`'s positions to the trails and returns the `foxglove.SceneUpdate`: a sphere
    /// and a label per drone (the performer larger, in orange), a cube and a label per work
    /// site, and each drone's trajectory as a line strip.
    pub fn update(&mut self, state: &SimState) -> ViewMessage {
        for d in &state.drones {
            let trail = self.trails.entry(d.name.clone()).or_default();
            if trail.len() == TRAIL_POINTS {
                trail.remove(0);
            }
            trail.push(d.pos_m);
        }
        let t = time(state.stamp_ns);
        let entity = |id: &str| SceneEntity {
            timestamp: t,
            frame_id: WORLD_FRAME.into(),
            id: id.to_string(),
            ..SceneEntity::default()
        };
        let mut drones = entity("drones");
        for d in &state.drones {
            drones.spheres.push(drone_sphere(d));
            drones.texts.push(label(d.pos_m, 0.12, &d.name));
        }
        let mut sites = entity("sites");
        for site in Site::ALL {
            let at = site.position_m();
            sites.cubes.push(CubePrimitive {
                pose: pose(at, [1.0, 0.0, 0.0, 0.0]),
                size: vector([0.3, 0.3, 0.02]),
                color: color(0.2, 0.7, 0.3, 0.6),
            });
            sites.texts.push(label(at, 0.1, &format!("site {site:?}")));
        }
        let mut trails = entity("trajectories");
        for points in self.trails.values() {
            trails.lines.push(LinePrimitive {
                r#type: foxglove::messages::line_primitive::Type::LineStrip as i32,
                pose: pose([0.0; 3], [1.0, 0.0, 0.0, 0.0]),
                thickness: 0.01,
                scale_invariant: false,
                points: points
                    .iter()
                    .map(|p| Point3 {
                        x: p[0],
                        y: p[1],
                        z: p[2],
                    })
                    .collect(),
                color: color(0.3, 0.5, 1.0, 0.8),
                colors: Vec::new(),
                indices: Vec::new(),
            });
        }
        ViewMessage::of(&SceneUpdate {
            deletions: Vec::new(),
            entities: vec![drones, sites, trails],
        })
    }
}

fn drone_sphere(d: &DronePose) -> SpherePrimitive {
    let performer = d.name == "performer";
    let size = if performer { 0.16 } else { 0.1 };
    SpherePrimitive {
        pose: pose(d.pos_m, d.quat_wxyz),
        size: vector([size; 3]),
        color: if performer {
            color(1.0, 0.55, 0.1, 1.0)
        } else {
            color(0.2, 0.6, 1.0, 1.0)
        },
    }
}

fn label(at: [f64; 3], rise_m: f64, text: &str) -> TextPrimitive {
    TextPrimitive {
        pose: pose([at[0], at[1], at[2] + rise_m], [1.0, 0.0, 0.0, 0.0]),
        billboard: true,
        font_size: 14.0,
        scale_invariant: true,
        color: color(1.0, 1.0, 1.0, 1.0),
        text: text.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use foxglove::Decode;

    fn state() -> SimState {
        SimState {
            tick: 1,
            stamp_ns: 1_500_000_000,
            drones: vec![DronePose {
                name: "performer".into(),
                pos_m: [0.0, 0.0, 1.3],
                quat_wxyz: [1.0, 0.0, 0.0, 0.0],
                vel_mps: [0.0; 3],
                ang_vel_radps: [0.0; 3],
            }],
        }
    }

    #[test]
    fn view_messages_are_official_schemas_in_protobuf() {
        let img = raw_image(1_500_000_000, "O1", 2, 1, &[0, 0, 255, 255, 0, 0]);
        assert_eq!(img.schema_name(), "foxglove.RawImage");
        assert_eq!(img.schema.encoding, VIEW_ENCODING);
        let back = RawImage::decode(img.data.as_slice()).unwrap();
        assert_eq!(
            (back.width, back.step, back.encoding.as_str()),
            (2, 6, "rgb8")
        );
        assert_eq!(back.timestamp, Some(Timestamp::new(1, 500_000_000)));
        let tf = FrameTransforms::decode(frame_transforms(&state()).data.as_slice()).unwrap();
        assert_eq!(tf.transforms[0].child_frame_id, "performer");
        assert_eq!(tf.transforms[0].translation.as_ref().unwrap().z, 1.3);
        assert_eq!(tf.transforms[0].rotation.as_ref().unwrap().w, 1.0);
        let l = Log::decode(log(0, LogLevel::Warning, "O2", "hi").data.as_slice()).unwrap();
        assert_eq!((l.level, l.name.as_str()), (3, "O2"));
    }

    #[test]
    fn the_scene_shows_drones_sites_and_bounded_trails() {
        let mut scene = Scene::default();
        let mut s = state();
        for i in 0..(TRAIL_POINTS + 5) {
            s.drones[0].pos_m[0] = i as f64 * 0.01;
            scene.update(&s);
        }
        let msg = scene.update(&s);
        assert_eq!(msg.schema_name(), "foxglove.SceneUpdate");
        let u = SceneUpdate::decode(msg.data.as_slice()).unwrap();
        let ids: Vec<&str> = u.entities.iter().map(|e| e.id.as_str()).collect();
        assert_eq!(ids, ["drones", "sites", "trajectories"]);
        assert_eq!(u.entities[0].spheres.len(), 1);
        assert_eq!(u.entities[1].cubes.len(), Site::ALL.len());
        assert_eq!(u.entities[2].lines[0].points.len(), TRAIL_POINTS);
    }
}
