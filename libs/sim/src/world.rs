//! The physics world: MuJoCo model + data for one performer and N observers, stepped at 500 Hz
//! on an integer-nanosecond clock, with ideal stabilisation and contact bookkeeping.

use std::rc::Rc;

use mujoco_rs::prelude::*;
use proto::scene::{Formation, PERFORMER_HOVER_M, distance_m, observer_name};

use crate::control::{DroneState, Gains, Reference, wrench};
use crate::mjcf::{
    DRONE_INERTIA_KGM2, DRONE_MASS_KG, PERFORMER_BODY, PHYSICS_STEP_NS, SceneError, formation_xml,
};

/// Why the world could not be built.
#[derive(Debug, thiserror::Error)]
pub enum WorldError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Assets(#[from] crate::assets::AssetError),
    #[error("MuJoCo rejected the generated scene: {0}")]
    Model(String),
    #[error("generated scene lacks {0}")]
    MissingObject(String),
}

/// Index of a drone in the world: 0 is the performer, 1..=N are observers O1..ON.
pub type DroneIndex = usize;

#[derive(Debug, Clone, Copy)]
struct DroneIds {
    body: usize,
    qpos: usize,
    qvel: usize,
}

/// Running contact and separation statistics since the world was built.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactStats {
    /// Physics steps during which at least one drone–drone contact existed.
    pub contact_steps: u64,
    /// Minimum body-centre distance over all drone pairs and steps, m.
    pub min_separation_m: f64,
}

/// The simulated world.
pub struct World {
    data: MjData<Rc<MjModel>>,
    drones: Vec<DroneIds>,
    names: Vec<String>,
    references: Vec<Reference>,
    gains: Gains,
    /// External disturbance force on each drone, world frame, N (gusts; zero by default).
    disturbances_n: Vec<[f64; 3]>,
    step_index: u64,
    stats: ContactStats,
}

impl World {
    /// Builds the default scene with `observers` observers, every drone hovering at its home.
    pub fn new(observers: usize) -> Result<Self, WorldError> {
        let formation = Formation::standard(observers).map_err(SceneError::from)?;
        Self::with_formation(&formation)
    }

    /// Builds a scene with the observers placed by `formation`, every drone hovering at home.
    pub fn with_formation(formation: &Formation) -> Result<Self, WorldError> {
        let observers = formation.len();
        let mesh_dir = crate::assets::crazyflie_mesh_dir()?;
        let xml = formation_xml(formation, &mesh_dir);
        let model = MjModel::from_xml_string(&xml).map_err(|e| WorldError::Model(e.to_string()))?;
        let model = Rc::new(model);
        let mut names = vec![PERFORMER_BODY.to_string()];
        names.extend((0..observers).map(observer_name));
        let mut drones = Vec::with_capacity(names.len());
        for name in &names {
            let body = model
                .name_to_id(MjtObjBase::mjOBJ_BODY, name)
                .ok_or_else(|| WorldError::MissingObject(format!("body {name}")))?;
            let joint = model
                .name_to_id(MjtObjBase::mjOBJ_JOINT, &format!("{name}_joint"))
                .ok_or_else(|| WorldError::MissingObject(format!("joint {name}_joint")))?;
            drones.push(DroneIds {
                body,
                qpos: model.jnt_qposadr()[joint] as usize,
                qvel: model.jnt_dofadr()[joint] as usize,
            });
        }
        let mut references = vec![Reference::hover(PERFORMER_HOVER_M, 0.0)];
        for p in formation.placements() {
            references.push(Reference::hover(p.home_m, p.yaw_rad));
        }
        let mut data = MjData::new(model);
        data.forward();
        let disturbances_n = vec![[0.0; 3]; drones.len()];
        let mut world = Self {
            data,
            drones,
            names,
            references,
            gains: Gains::default(),
            disturbances_n,
            step_index: 0,
            stats: ContactStats {
                contact_steps: 0,
                min_separation_m: f64::INFINITY,
            },
        };
        world.update_separation();
        Ok(world)
    }

    /// Number of observers.
    pub fn observers(&self) -> usize {
        self.drones.len() - 1
    }

    /// Body names, performer first.
    pub fn drone_names(&self) -> &[String] {
        &self.names
    }

    /// Current sim time, ns.
    pub fn time_ns(&self) -> u64 {
        self.step_index * PHYSICS_STEP_NS
    }

    /// Physics steps taken.
    pub fn step_index(&self) -> u64 {
        self.step_index
    }

    /// Sets the reference that drone `i` tracks from the next step on.
    pub fn set_reference(&mut self, i: DroneIndex, reference: Reference) {
        self.references[i] = reference;
    }

    /// The reference drone `i` is tracking.
    pub fn reference(&self, i: DroneIndex) -> Reference {
        self.references[i]
    }

    /// Measured state of drone `i`.
    pub fn state(&self, i: DroneIndex) -> DroneState {
        let ids = self.drones[i];
        let q = &self.data.qpos()[ids.qpos..ids.qpos + 7];
        let v = &self.data.qvel()[ids.qvel..ids.qvel + 6];
        DroneState {
            pos_m: [q[0], q[1], q[2]],
            vel_mps: [v[0], v[1], v[2]],
            world_from_body: [q[3], q[4], q[5], q[6]],
            body_rate_radps: [v[3], v[4], v[5]],
        }
    }

    /// World position of drone `i`'s body frame, m.
    pub fn position_m(&self, i: DroneIndex) -> [f64; 3] {
        self.data.xpos()[self.drones[i].body]
    }

    /// Contact and separation statistics so far.
    pub fn contact_stats(&self) -> ContactStats {
        self.stats
    }

    /// Applies `force_n` (world frame, N) to drone `i` from the next step on, on top of its
    /// controller's wrench: a gust the controller must reject. Zero removes it.
    pub fn set_disturbance_n(&mut self, i: DroneIndex, force_n: [f64; 3]) {
        if let Some(d) = self.disturbances_n.get_mut(i) {
            *d = force_n;
        }
    }

    /// Advances one 2 ms physics step.
    pub fn step(&mut self) {
        let gravity = -self.data.model().opt().gravity[2];
        for (i, ids) in self.drones.iter().enumerate() {
            let state = self.state(i);
            let w = wrench(
                &state,
                &self.references[i],
                DRONE_MASS_KG,
                DRONE_INERTIA_KGM2,
                gravity,
                &self.gains,
            );
            let mut w = w;
            // Only a set disturbance touches the wrench: the undisturbed world stays bit-exact.
            for (k, &f) in self.disturbances_n[i].iter().enumerate() {
                if f != 0.0 {
                    w[k] += f;
                }
            }
            self.data.xfrc_applied_mut()[ids.body] = w;
        }
        self.data.step();
        self.step_index += 1;
        if self.data.ncon() > 0 {
            self.stats.contact_steps += 1;
        }
        self.update_separation();
    }

    /// Steps until sim time reaches `t_ns` (a multiple of the physics step).
    pub fn step_until(&mut self, t_ns: u64) {
        while self.time_ns() < t_ns {
            self.step();
        }
    }

    fn update_separation(&mut self) {
        let xpos = self.data.xpos();
        for a in 0..self.drones.len() {
            for b in a + 1..self.drones.len() {
                let pa = xpos[self.drones[a].body];
                let pb = xpos[self.drones[b].body];
                let d = distance_m(pa, pb);
                if d < self.stats.min_separation_m {
                    self.stats.min_separation_m = d;
                }
            }
        }
    }

    /// Mutable access to the MuJoCo data, for the renderer.
    pub(crate) fn data_mut(&mut self) -> &mut MjData<Rc<MjModel>> {
        &mut self.data
    }

    /// The MuJoCo model.
    pub(crate) fn model(&self) -> &MjModel {
        self.data.model()
    }

    /// Drone `i`'s body pose as the last kinematics pass computed it — what the renderer
    /// draws: position (m) and orientation quaternion (w, x, y, z).
    pub fn body_pose(&self, i: DroneIndex) -> ([f64; 3], [f64; 4]) {
        let body = self.drones[i].body;
        (self.data.xpos()[body], self.data.xquat()[body])
    }

    /// Overwrites drone `i`'s free-joint pose without touching its reference or velocity. A
    /// camera process mirrors the simulator's ground truth this way; call
    /// [`World::forward_at`] once every drone of the instant is set.
    pub fn set_pose(&mut self, i: DroneIndex, pos_m: [f64; 3], world_from_body: [f64; 4]) {
        let ids = self.drones[i];
        let q = &mut self.data.qpos_mut()[ids.qpos..ids.qpos + 7];
        q[..3].copy_from_slice(&pos_m);
        q[3..].copy_from_slice(&world_from_body);
    }

    /// Recomputes kinematics from the current poses and moves the clock to `t_ns` (rounded
    /// down to the physics step) without stepping: the renderer then draws exactly these poses
    /// and sensors stamp their output with `t_ns`.
    pub fn forward_at(&mut self, t_ns: u64) {
        self.step_index = t_ns / PHYSICS_STEP_NS;
        self.data.forward();
    }

    /// Contacts present after the last step: the two bodies' names and the penetration depth (m,
    /// positive when overlapping).
    pub fn contacts(&self) -> Vec<(String, String, f64)> {
        let model = self.data.model();
        let body_of_geom = model.geom_bodyid();
        let name = |geom: i32| {
            usize::try_from(geom)
                .ok()
                .and_then(|g| body_of_geom.get(g))
                .and_then(|&b| usize::try_from(b).ok())
                .and_then(|b| model.id_to_name(MjtObjBase::mjOBJ_BODY, b))
                .unwrap_or("world")
                .to_string()
        };
        self.data
            .contact()
            .iter()
            .map(|c| (name(c.geom[0]), name(c.geom[1]), -c.dist))
            .collect()
    }

    /// Overwrites drone `i`'s pose (teleport, zero velocity) and recomputes kinematics. For tests
    /// and tools that need a given state without flying there.
    pub fn teleport(&mut self, i: DroneIndex, pos_m: [f64; 3], yaw_rad: f64) {
        let ids = self.drones[i];
        let (s, c) = (0.5 * yaw_rad).sin_cos();
        self.data.qpos_mut()[ids.qpos..ids.qpos + 7]
            .copy_from_slice(&[pos_m[0], pos_m[1], pos_m[2], c, 0.0, 0.0, s]);
        self.data.qvel_mut()[ids.qvel..ids.qvel + 6].fill(0.0);
        self.references[i] = Reference::hover(pos_m, yaw_rad);
        self.data.forward();
    }
}
