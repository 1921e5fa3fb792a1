//! The observer's camera as Python hands it over: its placement, the rectification mode and
//! the airframe's ego-rotation, each checked and turned into `proto`'s types, and the receiving
//! chain they configure (exactly `perception::Perception`'s).
//!
//! A placement is the plain tuple `(home_x_m, home_y_m, home_z_m, yaw_rad, pitch_rad)` of
//! `proto::scene::Placement`; an ego-rotation is the row-major 3×3 matrix of
//! `proto::EgoRotation` (world axes, home attitude to current one).

use perception::Perception;
use proto::scene::Placement;
use proto::{EgoRotation, Modality, Rectification};
use pyo3::prelude::*;

use crate::errors::{WaggleError, bad_arg};

/// How far from orthonormal a rotation may be (rounding of a float32 attitude estimate).
const ROTATION_TOLERANCE: f64 = 1e-6;

/// The placement in `value` (`None` stays `None`).
pub fn placement(value: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Placement>> {
    let Some(value) = value.filter(|v| !v.is_none()) else {
        return Ok(None);
    };
    let expected = "expected (home_x_m, home_y_m, home_z_m, yaw_rad, pitch_rad) or None";
    let v: Vec<f64> = value
        .extract()
        .map_err(|_| bad_arg("placement", format!("{expected}, got {value}")))?;
    let [x, y, z, yaw_rad, pitch_rad] = v[..] else {
        return Err(bad_arg(
            "placement",
            format!("{expected}, got {} numbers", v.len()),
        ));
    };
    if let Some(bad) = v.iter().find(|c| !c.is_finite()) {
        return Err(bad_arg("placement", format!("{bad} is not finite")));
    }
    Ok(Some(Placement {
        home_m: [x, y, z],
        yaw_rad,
        pitch_rad,
    }))
}

/// The placement as Python's tuple.
pub fn placement_tuple(p: &Placement) -> (f64, f64, f64, f64, f64) {
    let [x, y, z] = p.home_m;
    (x, y, z, p.yaw_rad, p.pitch_rad)
}

/// The rectification mode named `name` (`off`, `pitched`, `frontal`: the `--rectification`
/// names of the command line).
pub fn rectification(name: &str) -> PyResult<Rectification> {
    Rectification::ALL
        .into_iter()
        .find(|r| r.as_str() == name)
        .ok_or_else(|| {
            let names: Vec<&str> = Rectification::ALL.iter().map(|r| r.as_str()).collect();
            bad_arg(
                "rectification",
                format!("{name:?} is not one of {}", names.join(", ")),
            )
        })
}

/// The paper's receiving chain for `modality`: on the camera of `placement` with the trajectory
/// rectified by `mode` (`Perception::for_camera`), or on the raw trajectory without one
/// (`Perception::new`). `frontal` needs the camera: it turns the view by the camera's pose.
pub fn chain(
    modality: Modality,
    placement: Option<&Placement>,
    mode: Rectification,
) -> PyResult<Perception> {
    let built = match placement {
        Some(p) => Perception::for_camera(modality, p.camera(), mode),
        None if mode == Rectification::Frontal => {
            return Err(bad_arg(
                "rectification",
                "'frontal' turns the camera's view, so it needs a placement",
            ));
        }
        // Pitched on an unknown (so level) camera is the raw trajectory, as is off.
        None => Perception::new(modality),
    };
    built.map_err(|e| WaggleError::new_err(format!("placement: no receiver for it: {e}")))
}

/// The ego-rotation in `value`: `None`, or a 3×3 rotation matrix (any nested sequence or numpy
/// array of numbers).
pub fn ego_rotation(value: Option<&Bound<'_, PyAny>>) -> PyResult<Option<EgoRotation>> {
    let Some(value) = value.filter(|v| !v.is_none()) else {
        return Ok(None);
    };
    let expected = "expected a 3x3 rotation matrix (row-major, world axes) or None";
    let rows: Vec<Vec<f64>> = value
        .extract()
        .map_err(|_| bad_arg("rotation", format!("{expected}, got {value}")))?;
    if rows.len() != 3 || rows.iter().any(|r| r.len() != 3) {
        let shape: Vec<usize> = rows.iter().map(Vec::len).collect();
        return Err(bad_arg(
            "rotation",
            format!("{expected}, got rows of lengths {shape:?}"),
        ));
    }
    let m: [[f64; 3]; 3] = std::array::from_fn(|r| std::array::from_fn(|c| rows[r][c]));
    if m.iter().flatten().any(|v| !v.is_finite()) {
        return Err(bad_arg("rotation", "has an entry that is not finite"));
    }
    // Any matrix would be applied; one that is not a rotation would bend the track silently.
    let worst = (0..3)
        .flat_map(|a| (0..3).map(move |b| (a, b)))
        .map(|(a, b)| {
            let dot: f64 = (0..3).map(|k| m[k][a] * m[k][b]).sum();
            (dot - f64::from(u8::from(a == b))).abs()
        })
        .fold(0.0, f64::max);
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    if worst > ROTATION_TOLERANCE || det <= 0.0 {
        return Err(bad_arg(
            "rotation",
            format!("is not a rotation (|RᵀR − I| up to {worst:.2e}, det {det:.6})"),
        ));
    }
    Ok(Some(EgoRotation { world_from_home: m }))
}
