//! The `.msg` definitions a bag carries, their `ros2msg` full text and their RIHS01 type hashes.
//!
//! The standard types (`std_msgs`, `builtin_interfaces`, `geometry_msgs`, `sensor_msgs`,
//! `tf2_msgs` and `event_camera_msgs`, as in ROS 2 Jazzy) are our own field-only definitions in
//! `libs/ros2/msg/ros_interfaces/<pkg>/msg/`: the same field types, names and order (and
//! defaults) as the upstream interfaces, hence the same CDR encoding and RIHS01 type hashes, but
//! not their files' text (`README.md` there). Waggle's own types are the `waggle_msgs` package
//! in `libs/ros2/msg/waggle_msgs/`, buildable with colcon.
//!
//! - [`full_text`] concatenates a type's definition with every definition it depends on exactly
//!   as rosbag2's `LocalMessageDefinitionSource` does (Jazzy): the root text, then for each
//!   dependency not yet written — in the sorted order of its `std::set`, depth first — a newline,
//!   80 `=`, `MSG: <name as written in the field>` and its text.
//! - [`type_hash`] is REP 2016's `RIHS01_<sha256>` of the type description (fields only, no
//!   constants or defaults; referenced types sorted by name), as `rosidl` computes it.

use std::collections::{BTreeMap, BTreeSet};

use sha2::{Digest, Sha256};

use crate::error::Ros2Error;

/// One message definition: its package, type and `.msg` text.
#[derive(Debug, Clone, Copy)]
pub struct MsgDefinition {
    pub package: &'static str,
    pub name: &'static str,
    pub text: &'static str,
}

macro_rules! standard {
    ($pkg:literal, $name:literal) => {
        MsgDefinition {
            package: $pkg,
            name: $name,
            text: include_str!(concat!(
                "../msg/ros_interfaces/",
                $pkg,
                "/msg/",
                $name,
                ".msg"
            )),
        }
    };
}

macro_rules! waggle {
    ($name:literal) => {
        MsgDefinition {
            package: "waggle_msgs",
            name: $name,
            text: include_str!(concat!("../msg/waggle_msgs/msg/", $name, ".msg")),
        }
    };
}

/// Every definition a bag may need.
pub const DEFINITIONS: [MsgDefinition; 20] = [
    standard!("builtin_interfaces", "Time"),
    standard!("std_msgs", "Header"),
    standard!("geometry_msgs", "Vector3"),
    standard!("geometry_msgs", "Quaternion"),
    standard!("geometry_msgs", "Transform"),
    standard!("geometry_msgs", "TransformStamped"),
    standard!("tf2_msgs", "TFMessage"),
    standard!("sensor_msgs", "CompressedImage"),
    standard!("sensor_msgs", "Image"),
    standard!("sensor_msgs", "RegionOfInterest"),
    standard!("sensor_msgs", "CameraInfo"),
    standard!("event_camera_msgs", "EventPacket"),
    waggle!("Token"),
    waggle!("Offer"),
    waggle!("Frame"),
    waggle!("SourceFrame"),
    waggle!("Assignment"),
    waggle!("Decision"),
    waggle!("Fault"),
    waggle!("Broadcast"),
];

/// The primitive types of `.msg` files (rosbag2's list).
const PRIMITIVES: [&str; 14] = [
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32",
    "uint32", "int64", "uint64", "string",
];

/// `(package, type)` of a name written `pkg/Type` or `pkg/msg/Type`.
fn split_name(name: &str) -> Option<(&str, &str)> {
    let (package, rest) = name.split_once('/')?;
    let ty = rest.strip_prefix("msg/").unwrap_or(rest);
    let ok = |s: &str| !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    (ok(package) && ok(ty)).then_some((package, ty))
}

/// The definition of `name` (`pkg/Type` or `pkg/msg/Type`).
pub fn definition(name: &str) -> Result<&'static MsgDefinition, Ros2Error> {
    let unknown = || Ros2Error::UnknownType {
        name: name.to_string(),
    };
    let (package, ty) = split_name(name).ok_or_else(unknown)?;
    DEFINITIONS
        .iter()
        .find(|d| d.package == package && d.name == ty)
        .ok_or_else(unknown)
}

/// The non-primitive field types of a `.msg` text as rosbag2 finds them (its regex
/// `(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+`): the first word of each line, if an array
/// suffix or whitespace follows it; a name without a package gets `package`'s.
fn dependencies(text: &str, package: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for line in text.split('\n') {
        let line = line.trim_start();
        let end = line
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '/'))
            .unwrap_or(line.len());
        let (ty, mut rest) = line.split_at(end);
        if ty.is_empty() {
            continue;
        }
        if let Some(array) = rest.strip_prefix('[') {
            let Some(close) = array.find(']') else {
                continue;
            };
            rest = &array[close + 1..];
        }
        if !rest.starts_with(|c: char| c.is_whitespace()) || PRIMITIVES.contains(&ty) {
            continue;
        }
        out.insert(if ty.contains('/') {
            ty.to_string()
        } else {
            format!("{package}/{ty}")
        });
    }
    out
}

/// `name`'s complete `ros2msg` definition, laid out as rosbag2 (Jazzy) lays out a bag's schema
/// (the standard types' text is our own field-only form, not the installed files' text).
pub fn full_text(name: &str) -> Result<String, Ros2Error> {
    fn append(
        name: &str,
        seen: &mut BTreeSet<String>,
        depth: u32,
        out: &mut String,
    ) -> Result<(), Ros2Error> {
        if depth == 0 {
            return Err(Ros2Error::UnknownType {
                name: format!("{name} (definitions nest too deep)"),
            });
        }
        let def = definition(name)?;
        out.push_str(def.text);
        for dep in dependencies(def.text, def.package) {
            if seen.insert(dep.clone()) {
                out.push('\n');
                out.push_str(&"=".repeat(80));
                out.push_str("\nMSG: ");
                out.push_str(&dep);
                out.push('\n');
                append(&dep, seen, depth - 1, out)?;
            }
        }
        Ok(())
    }
    let mut out = String::new();
    append(name, &mut BTreeSet::new(), 32, &mut out)?;
    Ok(out)
}

/// One field of a type description: name, type id, capacity, nested type.
#[derive(Debug, Clone, PartialEq, Eq)]
struct FieldDescription {
    name: String,
    type_id: u32,
    capacity: u64,
    nested: String,
}

/// `type_description_interfaces/FieldType` ids of the primitives.
fn primitive_type_id(ty: &str) -> Option<u32> {
    Some(match ty {
        "int8" => 2,
        "uint8" => 3,
        "int16" => 4,
        "uint16" => 5,
        "int32" => 6,
        "uint32" => 7,
        "int64" => 8,
        "uint64" => 9,
        "float32" => 10,
        "float64" => 11,
        "char" => 13,
        "bool" => 15,
        "byte" => 16,
        "string" => 17,
        _ => return None,
    })
}

/// The fields of `def` (constants skipped): the type description's fields.
fn fields(def: &MsgDefinition) -> Result<Vec<FieldDescription>, Ros2Error> {
    let bad = |line: &str| Ros2Error::UnknownType {
        name: format!("{}/msg/{}: field `{line}`", def.package, def.name),
    };
    let mut out = Vec::new();
    for raw in def.text.lines() {
        let line = raw.split('#').next().unwrap_or("").trim();
        let mut words = line.split_whitespace();
        let (Some(ty), Some(name)) = (words.next(), words.next()) else {
            continue;
        };
        if name.contains('=') || words.next().is_some_and(|w| w.starts_with('=')) {
            continue; // a constant
        }
        let (base, array) = match ty.split_once('[') {
            Some((base, rest)) => (base, Some(rest.strip_suffix(']').ok_or_else(|| bad(line))?)),
            None => (ty, None),
        };
        let (increment, capacity) = match array {
            None => (0, 0),
            Some("") => (144, 0),
            Some(n) => match n.strip_prefix("<=") {
                Some(b) => (96, b.parse().map_err(|_| bad(line))?),
                None => (48, n.parse().map_err(|_| bad(line))?),
            },
        };
        let (type_id, nested) = match primitive_type_id(base) {
            Some(id) => (id, String::new()),
            None => {
                let full = if base.contains('/') {
                    base.to_string()
                } else {
                    format!("{}/{base}", def.package)
                };
                let (p, t) = split_name(&full).ok_or_else(|| bad(line))?;
                (1, format!("{p}/msg/{t}"))
            }
        };
        out.push(FieldDescription {
            name: name.to_string(),
            type_id: increment + type_id,
            capacity,
            nested,
        });
    }
    Ok(out)
}

/// JSON of one type description, as Python's `json.dumps` writes it.
fn description_json(name: &str, fields: &[FieldDescription]) -> String {
    let fields: Vec<String> = fields
        .iter()
        .map(|f| {
            format!(
                "{{\"name\": \"{}\", \"type\": {{\"type_id\": {}, \"capacity\": {}, \
                 \"string_capacity\": 0, \"nested_type_name\": \"{}\"}}}}",
                f.name, f.type_id, f.capacity, f.nested
            )
        })
        .collect();
    format!(
        "{{\"type_name\": \"{name}\", \"fields\": [{}]}}",
        fields.join(", ")
    )
}

/// REP 2016's type hash of `name` (`pkg/msg/Type`): `RIHS01_` and the SHA-256 of the JSON type
/// description with its referenced types, as `rosidl_generator_type_description` computes it.
pub fn type_hash(name: &str) -> Result<String, Ros2Error> {
    let root = definition(name)?;
    let root_name = format!("{}/msg/{}", root.package, root.name);
    let mut described: BTreeMap<String, Vec<FieldDescription>> = BTreeMap::new();
    let mut todo = vec![root_name.clone()];
    while let Some(ty) = todo.pop() {
        if described.contains_key(&ty) {
            continue;
        }
        let f = fields(definition(&ty)?)?;
        todo.extend(
            f.iter()
                .filter(|f| !f.nested.is_empty())
                .map(|f| f.nested.clone()),
        );
        described.insert(ty, f);
    }
    let referenced: Vec<String> = described
        .iter()
        .filter(|(ty, _)| **ty != root_name)
        .map(|(ty, f)| description_json(ty, f))
        .collect();
    let json = format!(
        "{{\"type_description\": {}, \"referenced_type_descriptions\": [{}]}}",
        description_json(&root_name, &described[&root_name]),
        referenced.join(", ")
    );
    let digest = Sha256::digest(json.as_bytes());
    let hex: String = digest.iter().map(|b| format!("{b:02x}")).collect();
    Ok(format!("RIHS01_{hex}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tf_message_concatenates_its_dependencies_depth_first_in_sorted_order() {
        let text = full_text("tf2_msgs/msg/TFMessage").unwrap();
        let sep = |name: &str| format!("\n{}\nMSG: {name}\n", "=".repeat(80));
        let order = [
            "geometry_msgs/TransformStamped",
            "geometry_msgs/Transform",
            "geometry_msgs/Quaternion",
            "geometry_msgs/Vector3",
            "std_msgs/Header",
            "builtin_interfaces/Time",
        ];
        let mut at = 0;
        for name in order {
            let found = text[at..]
                .find(&sep(name))
                .unwrap_or_else(|| panic!("{name}"));
            at += found + 1;
        }
        assert!(text.starts_with("geometry_msgs/TransformStamped[] transforms\n\n===="));
        assert_eq!(text.matches("\nMSG: ").count(), order.len());
    }

    #[test]
    fn every_definition_resolves_with_its_dependencies_and_fields() {
        for d in DEFINITIONS {
            let name = format!("{}/msg/{}", d.package, d.name);
            let text = full_text(&name).unwrap();
            assert!(text.starts_with(d.text), "{name}");
            assert!(type_hash(&name).unwrap().starts_with("RIHS01_"));
            assert!(!fields(&d).unwrap().is_empty(), "{name}");
        }
        assert!(definition("sensor_msgs/msg/PointCloud2").is_err());
    }

    #[test]
    fn rosbag2_dependency_rules_skip_comments_constants_and_primitives() {
        let deps = dependencies(
            "# Header h\nuint8 A=1\nfloat64[9]  k # x\n  Offer offer\nstd_msgs/Header[] hs\n",
            "waggle_msgs",
        );
        assert_eq!(
            deps.into_iter().collect::<Vec<_>>(),
            ["std_msgs/Header", "waggle_msgs/Offer"]
        );
    }

    #[test]
    fn the_type_hashes_of_the_standard_types_are_rosidls() {
        // As generated by rosidl in Jazzy (the hashes a Jazzy install holds in
        // <pkg>/msg/<Type>.json; the same as PyPI rosbags' ROS2_JAZZY type store).
        // event_camera_msgs is not in that store: its hash is rosbags' of the same fields.
        let expected = [
            (
                "builtin_interfaces/msg/Time",
                "b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197",
            ),
            (
                "std_msgs/msg/Header",
                "f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01",
            ),
            (
                "geometry_msgs/msg/Vector3",
                "cc12fe83e4c02719f1ce8070bfd14aecd40f75a96696a67a2a1f37f7dbb0765d",
            ),
            (
                "geometry_msgs/msg/Quaternion",
                "8a765f66778c8ff7c8ab94afcc590a2ed5325a1d9a076ffff38fbce36f458684",
            ),
            (
                "geometry_msgs/msg/Transform",
                "beb83fbe698636351461f6f35d1abb20010c43d55374d81bd041f1ba2581fddc",
            ),
            (
                "geometry_msgs/msg/TransformStamped",
                "0a241f87d04668d94099cbb5ba11691d5ad32c2f29682e4eb5653424bd275206",
            ),
            (
                "tf2_msgs/msg/TFMessage",
                "e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087",
            ),
            (
                "sensor_msgs/msg/CompressedImage",
                "15640771531571185e2efc8a100baf923961a4d15d5569652e6cb6691e8e371a",
            ),
            (
                "sensor_msgs/msg/Image",
                "d31d41a9a4c4bc8eae9be757b0beed306564f7526c88ea6a4588fb9582527d47",
            ),
            (
                "sensor_msgs/msg/RegionOfInterest",
                "ad16bcba5f9131dcdba6fbded19f726f5440e3c513b4fb586dd3027eeed8abb1",
            ),
            (
                "sensor_msgs/msg/CameraInfo",
                "b3dfd68ff46c9d56c80fd3bd4ed22c7a4ddce8c8348f2f59c299e73118e7e275",
            ),
            (
                "event_camera_msgs/msg/EventPacket",
                "d6fa176260b1f37e5a40845305315e150a0f18191241eb64f407442aa29844aa",
            ),
        ];
        for (name, hash) in expected {
            assert_eq!(type_hash(name).unwrap(), format!("RIHS01_{hash}"), "{name}");
        }
    }
}
