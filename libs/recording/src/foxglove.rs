//! Foxglove's well-known schemas in their JSON encoding (`jsonschema` schemas, `json`
//! messages), so a recording opens usefully in Foxglove: images, frame transforms and logs.
//!
//! Only the fields we fill are described; names and types follow Foxglove's schema reference
//! (`foxglove.RawImage`, `foxglove.FrameTransforms`, `foxglove.Log`). Bytes are base64 in JSON.

use base64::Engine as _;
use base64::engine::general_purpose::STANDARD as BASE64;
use serde_json::{Value, json};

use proto::SimState;

pub const RAW_IMAGE: &str = "foxglove.RawImage";
pub const FRAME_TRANSFORMS: &str = "foxglove.FrameTransforms";
pub const LOG: &str = "foxglove.Log";
/// Schema encoding of the Foxglove channels.
pub const SCHEMA_ENCODING: &str = "jsonschema";
/// Message encoding of the Foxglove channels.
pub const MESSAGE_ENCODING: &str = "json";
/// Parent frame of every pose.
pub const WORLD_FRAME: &str = "world";

/// Foxglove log levels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogLevel {
    Info = 2,
    Warning = 3,
    Error = 4,
}

fn time_schema() -> Value {
    json!({
        "type": "object",
        "title": "time",
        "properties": {
            "sec": {"type": "integer", "minimum": 0},
            "nsec": {"type": "integer", "minimum": 0, "maximum": 999_999_999}
        }
    })
}

fn vector3_schema() -> Value {
    json!({
        "type": "object",
        "title": "foxglove.Vector3",
        "properties": {
            "x": {"type": "number"}, "y": {"type": "number"}, "z": {"type": "number"}
        }
    })
}

/// The JSON schema of a Foxglove schema name (one of the constants above).
pub fn schema(name: &str) -> Option<Vec<u8>> {
    let s = match name {
        RAW_IMAGE => json!({
            "title": RAW_IMAGE,
            "description": "A raw image",
            "type": "object",
            "properties": {
                "timestamp": time_schema(),
                "frame_id": {"type": "string"},
                "width": {"type": "integer", "minimum": 0},
                "height": {"type": "integer", "minimum": 0},
                "encoding": {"type": "string"},
                "step": {"type": "integer", "minimum": 0},
                "data": {"type": "string", "contentEncoding": "base64"}
            }
        }),
        FRAME_TRANSFORMS => json!({
            "title": FRAME_TRANSFORMS,
            "description": "An array of FrameTransform messages",
            "type": "object",
            "properties": {
                "transforms": {
                    "type": "array",
                    "items": {
                        "type": "object",
                        "title": "foxglove.FrameTransform",
                        "properties": {
                            "timestamp": time_schema(),
                            "parent_frame_id": {"type": "string"},
                            "child_frame_id": {"type": "string"},
                            "translation": vector3_schema(),
                            "rotation": {
                                "type": "object",
                                "title": "foxglove.Quaternion",
                                "properties": {
                                    "x": {"type": "number"}, "y": {"type": "number"},
                                    "z": {"type": "number"}, "w": {"type": "number"}
                                }
                            }
                        }
                    }
                }
            }
        }),
        LOG => json!({
            "title": LOG,
            "description": "A log message",
            "type": "object",
            "properties": {
                "timestamp": time_schema(),
                "level": {"type": "integer", "oneOf": [
                    {"title": "UNKNOWN", "const": 0}, {"title": "DEBUG", "const": 1},
                    {"title": "INFO", "const": 2}, {"title": "WARNING", "const": 3},
                    {"title": "ERROR", "const": 4}, {"title": "FATAL", "const": 5}
                ]},
                "message": {"type": "string"},
                "name": {"type": "string"},
                "file": {"type": "string"},
                "line": {"type": "integer", "minimum": 0}
            }
        }),
        _ => return None,
    };
    Some(s.to_string().into_bytes())
}

fn time(ns: u64) -> Value {
    json!({"sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000})
}

/// A `foxglove.RawImage` of an 8-bit RGB image. Written directly rather than through a JSON
/// value: the base64 data needs no escaping and is by far the largest part.
pub fn raw_image(stamp_ns: u64, frame_id: &str, width: u32, height: u32, rgb: &[u8]) -> Vec<u8> {
    let head = json!({
        "timestamp": time(stamp_ns),
        "frame_id": frame_id,
        "width": width,
        "height": height,
        "encoding": "rgb8",
        "step": width * 3,
    })
    .to_string();
    let data = BASE64.encode(rgb);
    let mut out = Vec::with_capacity(head.len() + data.len() + 16);
    out.extend_from_slice(&head.as_bytes()[..head.len() - 1]);
    out.extend_from_slice(b",\"data\":\"");
    out.extend_from_slice(data.as_bytes());
    out.extend_from_slice(b"\"}");
    out
}

/// A `foxglove.FrameTransforms` with one `world → drone` transform per drone.
pub fn frame_transforms(state: &SimState) -> Vec<u8> {
    let transforms: Vec<Value> = state
        .drones
        .iter()
        .map(|d| {
            let [w, x, y, z] = d.quat_wxyz;
            json!({
                "timestamp": time(state.stamp_ns),
                "parent_frame_id": WORLD_FRAME,
                "child_frame_id": d.name,
                "translation": {"x": d.pos_m[0], "y": d.pos_m[1], "z": d.pos_m[2]},
                "rotation": {"x": x, "y": y, "z": z, "w": w},
            })
        })
        .collect();
    json!({ "transforms": transforms }).to_string().into_bytes()
}

/// A `foxglove.Log` message from `name`.
pub fn log(stamp_ns: u64, level: LogLevel, name: &str, message: &str) -> Vec<u8> {
    json!({
        "timestamp": time(stamp_ns),
        "level": level as u8,
        "message": message,
        "name": name,
        "file": "",
        "line": 0,
    })
    .to_string()
    .into_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::DronePose;

    #[test]
    fn messages_follow_the_foxglove_field_names() {
        let img: Value = serde_json::from_slice(&raw_image(
            1_500_000_000,
            "O1",
            2,
            1,
            &[0, 0, 255, 255, 0, 0],
        ))
        .unwrap();
        assert_eq!(img["timestamp"], json!({"sec": 1, "nsec": 500_000_000}));
        assert_eq!(img["encoding"], "rgb8");
        assert_eq!(img["step"], 6);
        assert_eq!(img["data"], "AAD//wAA");
        let state = SimState {
            tick: 1,
            stamp_ns: 40_000_000,
            drones: vec![DronePose {
                name: "performer".into(),
                pos_m: [0.0, 0.0, 1.3],
                quat_wxyz: [1.0, 0.0, 0.0, 0.0],
                vel_mps: [0.0; 3],
                ang_vel_radps: [0.0; 3],
            }],
        };
        let tf: Value = serde_json::from_slice(&frame_transforms(&state)).unwrap();
        let t = &tf["transforms"][0];
        assert_eq!(t["child_frame_id"], "performer");
        assert_eq!(t["parent_frame_id"], WORLD_FRAME);
        assert_eq!(t["translation"]["z"], 1.3);
        assert_eq!(t["rotation"]["w"], 1.0);
        let l: Value = serde_json::from_slice(&log(0, LogLevel::Warning, "O2", "hi")).unwrap();
        assert_eq!(
            (l["level"].as_u64(), l["name"].as_str()),
            (Some(3), Some("O2"))
        );
        for name in [RAW_IMAGE, FRAME_TRANSFORMS, LOG] {
            let s: Value = serde_json::from_slice(&schema(name).unwrap()).unwrap();
            assert_eq!(s["title"], name);
        }
        assert!(schema("foxglove.Nope").is_none());
    }
}
