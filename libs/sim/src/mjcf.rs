//! The MuJoCo scene, generated from code for N observers.
//!
//! Geometry comes from [`proto::scene`]; this module only turns it into MJCF. Render settings are
//! deliberately cheap (no multisampling, shadows, reflections or skybox): on Mesa's CPU rasteriser
//! they are the difference between ≈ 24 ms and ≈ 2 ms per 640×480 frame.

use std::fmt::Write as _;
use std::path::Path;

use proto::scene::{
    CAMERA_FOVY_DEG, CAMERA_OFFSET_BODY_M, Formation, FormationError, IMAGE_HEIGHT_PX,
    IMAGE_WIDTH_PX, PERFORMER_HOVER_M, observer_name,
};

/// Crazyflie 2 mass (MuJoCo Menagerie / drone-models), kg.
pub const DRONE_MASS_KG: f64 = 0.027;
/// Crazyflie 2 diagonal inertia, kg·m².
pub const DRONE_INERTIA_KGM2: [f64; 3] = [2.3951e-5, 2.3951e-5, 3.2347e-5];
/// Radius of the collision sphere around each drone (drone-models' estimate), m.
pub const DRONE_COLLISION_RADIUS_M: f64 = 0.07;
/// Physics step, ns (500 Hz).
pub const PHYSICS_STEP_NS: u64 = 2_000_000;

/// Geom group of the observers' visual meshes (hidden from observer cameras by default).
pub const OBSERVER_GEOM_GROUP: usize = 4;

/// Name of the performer body.
pub const PERFORMER_BODY: &str = "performer";

/// Name of observer `i`'s camera.
pub fn camera_name(i: usize) -> String {
    format!("{}_cam", observer_name(i))
}

/// Why a scene could not be generated.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SceneError {
    #[error(transparent)]
    Formation(#[from] FormationError),
}

/// (mesh name, file relative to the mesh dir, material). The connector and pin meshes (12k of the
/// 23k triangles of a Crazyflie) are left out: they are invisible at ~48 px and on Mesa's CPU
/// rasteriser they cost ≈ 40 % of the render time.
const VISUAL_PARTS: &[(&str, &str, &str)] = &[
    ("pcb", "cf2x/cf2x_pcb.stl", "cf_gray"),
    ("motors", "cf2x/cf2xL_motors.stl", "cf_silver"),
    ("motor_holder", "cf2x/cf2x_motor-holder.stl", "cf_white"),
    ("battery", "cf2x/cf2x_battery.stl", "cf_lightgray"),
    ("battery_holder", "cf2x/cf2x_battery-holder.stl", "cf_black"),
];
const PROP_MESHES: [&str; 2] = ["cf2x/cf2xL_PropL.stl", "cf2x/cf2xL_PropR.stl"];

/// Every mesh file the generated scene loads, relative to the mesh dir, sorted.
pub fn mesh_files() -> Vec<&'static str> {
    let mut files: Vec<&'static str> = VISUAL_PARTS.iter().map(|(_, file, _)| *file).collect();
    files.extend(PROP_MESHES);
    files.sort_unstable();
    files
}

/// Generates the MJCF for the built-in formation of `observers` observers, with meshes loaded
/// from `mesh_dir`.
pub fn scene_xml(observers: usize, mesh_dir: &Path) -> Result<String, SceneError> {
    Ok(formation_xml(&Formation::standard(observers)?, mesh_dir))
}

/// The camera's axes in the body frame: image right, image up. MuJoCo cameras look along their
/// −z; the body looks along +x, and the camera is pitched `pitch_rad` below it.
fn camera_xyaxes(pitch_rad: f64) -> String {
    if pitch_rad == 0.0 {
        // The paper's level camera, written as it always was.
        return "0 -1 0 0 0 1".to_owned();
    }
    let (s, c) = pitch_rad.sin_cos();
    format!("0 -1 0 {s} 0 {c}")
}

/// Generates the MJCF for any formation, with meshes loaded from `mesh_dir`.
pub fn formation_xml(formation: &Formation, mesh_dir: &Path) -> String {
    let mut x = String::new();
    let dt_s = PHYSICS_STEP_NS as f64 * 1e-9;
    let [ixx, iyy, izz] = DRONE_INERTIA_KGM2;
    // Writing to a String cannot fail; `let _ =` keeps the generator readable.
    let _ = write!(
        x,
        r#"<mujoco model="waggle">
  <compiler meshdir="{mesh}" inertiafromgeom="false" autolimits="true" angle="radian"/>
  <option timestep="{dt_s}" gravity="0 0 -9.81" integrator="implicitfast"/>
  <visual>
    <global offwidth="{w}" offheight="{h}"/>
    <quality offsamples="0" shadowsize="0"/>
    <headlight ambient="0.45 0.45 0.45" diffuse="0.5 0.5 0.5" specular="0 0 0"/>
    <map znear="0.01" zfar="50"/>
  </visual>
  <asset>
    <material name="cf_black" rgba="0.10 0.10 0.10 1"/>
    <material name="cf_gray" rgba="0.30 0.30 0.30 1"/>
    <material name="cf_lightgray" rgba="0.70 0.70 0.70 1"/>
    <material name="cf_silver" rgba="0.90 0.90 0.90 1"/>
    <material name="cf_white" rgba="0.95 0.95 0.95 1"/>
    <material name="floor" rgba="0.35 0.36 0.38 1" reflectance="0"/>
    <material name="wall" rgba="0.45 0.53 0.62 1" reflectance="0"/>
"#,
        mesh = mesh_dir.display(),
        w = IMAGE_WIDTH_PX,
        h = IMAGE_HEIGHT_PX,
    );
    for (name, file, _) in VISUAL_PARTS {
        let _ = writeln!(
            x,
            r#"    <mesh name="{name}" file="{file}" scale="0.001 0.001 0.001"/>"#
        );
    }
    let _ = writeln!(
        x,
        r#"    <mesh name="prop_l" file="{}" scale="0.001 0.001 0.001"/>
    <mesh name="prop_r" file="{}" scale="0.001 0.001 0.001"/>
  </asset>
  <default>
    <default class="visual">
      <geom type="mesh" contype="0" conaffinity="0" group="2" mass="0"/>
    </default>
    <default class="collision">
      <geom type="sphere" size="{r}" contype="1" conaffinity="1" group="3" rgba="0 0 0 0" condim="1"/>
    </default>
  </default>
  <worldbody>
    <light name="sun" directional="true" castshadow="false" pos="0 0 6" dir="0.2 0.3 -1" diffuse="0.35 0.35 0.35" specular="0 0 0"/>
    <geom name="floor" type="plane" size="7 7 7" material="floor" contype="0" conaffinity="0"/>
    <geom name="wall_north" type="box" pos="0 7 3" size="7 0.05 3" material="wall" contype="0" conaffinity="0"/>
    <geom name="wall_south" type="box" pos="0 -7 3" size="7 0.05 3" material="wall" contype="0" conaffinity="0"/>
    <geom name="wall_east" type="box" pos="7 0 3" size="0.05 7 3" material="wall" contype="0" conaffinity="0"/>
    <geom name="wall_west" type="box" pos="-7 0 3" size="0.05 7 3" material="wall" contype="0" conaffinity="0"/>"#,
        PROP_MESHES[0],
        PROP_MESHES[1],
        r = DRONE_COLLISION_RADIUS_M,
    );
    let mut drone = |name: &str, pos: [f64; 3], yaw: f64, camera: Option<(&str, f64)>| {
        // Observers' airframes go to their own geom group: no observer has another in its
        // field of view at home (`Formation::check`), flights never overlap a broadcast (a round
        // starts only once every trip is home), and skipping their meshes saves a quarter of
        // the CPU render time. `CameraRenderer::show_observers` puts
        // them back; a test checks the images are identical at the homes.
        let group = if camera.is_some() {
            OBSERVER_GEOM_GROUP
        } else {
            2
        };
        let _ = writeln!(
            x,
            r#"    <body name="{name}" pos="{} {} {}" euler="0 0 {yaw}">
      <freejoint name="{name}_joint"/>
      <inertial pos="0 0 0" mass="{DRONE_MASS_KG}" diaginertia="{ixx} {iyy} {izz}"/>"#,
            pos[0], pos[1], pos[2]
        );
        for (mesh, _, material) in VISUAL_PARTS {
            let _ = writeln!(
                x,
                r#"      <geom class="visual" group="{group}" mesh="{mesh}" material="{material}"/>"#
            );
        }
        for (k, (sx, sy)) in [(1.0, -1.0), (-1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)]
            .iter()
            .enumerate()
        {
            let mesh = if k % 2 == 0 { "prop_l" } else { "prop_r" };
            let angle = std::f64::consts::FRAC_PI_4 * (1 + 2 * k) as f64;
            let _ = writeln!(
                x,
                r#"      <geom class="visual" group="{group}" mesh="{mesh}" material="cf_black" pos="{} {} 0.012" euler="0 0 {angle}"/>"#,
                0.0325 * sx,
                0.0325 * sy
            );
        }
        let _ = writeln!(
            x,
            r#"      <geom name="{name}_collision" class="collision" pos="0 0 0.005"/>"#
        );
        if let Some((cam, pitch_rad)) = camera {
            let axes = camera_xyaxes(pitch_rad);
            let _ = writeln!(
                x,
                r#"      <camera name="{cam}" pos="{CAMERA_OFFSET_BODY_M} 0 0" xyaxes="{axes}" fovy="{CAMERA_FOVY_DEG}" resolution="{IMAGE_WIDTH_PX} {IMAGE_HEIGHT_PX}"/>"#
            );
        }
        let _ = writeln!(x, "    </body>");
    };
    drone(PERFORMER_BODY, PERFORMER_HOVER_M, 0.0, None);
    for (i, p) in formation.placements().iter().enumerate() {
        drone(
            &observer_name(i),
            p.home_m,
            p.yaw_rad,
            Some((&camera_name(i), p.pitch_rad)),
        );
    }
    let _ = writeln!(x, "  </worldbody>\n</mujoco>");
    x
}
