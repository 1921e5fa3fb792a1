//! The physics world: MuJoCo model + data for one performer and N observers, stepped at 500 Hz
//! on an integer-nanosecond clock, with ideal stabilisation (or, as an option, the cascade of
//! [`crate::cascade`]), an optional wind ([`crate::wind`]), contact bookkeeping and each drone's
//! tracking error.
//!
//! The default world (ideal controller, no wind, no disturbance) computes exactly what it always
//! did: the options only add terms when they are set, so the frozen digests stay unchanged.

use std::path::Path;
use std::rc::Rc;

use mujoco_rs::prelude::*;
use proto::scene::{Formation, PERFORMER_HOVER_M, distance_m, observer_name};

use crate::cascade::{Cascade, CascadeCommand, CascadeConfig};
use crate::control::{DroneState, Gains, Reference, wrench};
use crate::mjcf::{
    DRONE_INERTIA_KGM2, DRONE_MASS_KG, PERFORMER_BODY, PHYSICS_STEP_NS, SceneError, formation_xml,
};
use crate::wind::{WindConfig, WindError, WindField};

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

/// Which controller flies the drones.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum ControllerKind {
    /// The paper's ideal world-frame force/torque stabilisation ([`crate::control`]).
    #[default]
    Ideal,
    /// The Crazyflie-like cascade with limits and a noisy, delayed estimate.
    Cascade(CascadeConfig),
}

/// A drone's tracking error: distance between its true position and its reference, sampled
/// after every physics step (the reference advanced to that instant with its feed-forward).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TrackingError {
    /// Root mean square of the 3-D error, m.
    pub rms_m: f64,
    /// Largest 3-D error, m.
    pub max_m: f64,
    /// Steps sampled.
    pub steps: u64,
}

#[derive(Debug, Clone, Copy, Default)]
struct TrackingSums {
    sum_sq_m2: f64,
    max_m: f64,
    steps: u64,
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
    /// Drone `i`'s cascade when it flies [`ControllerKind::Cascade`]; `None` (or an empty
    /// vector, the default) flies the ideal controller.
    cascades: Vec<Option<Cascade>>,
    wind: Option<WindField>,
    tracking: Vec<TrackingSums>,
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
        Self::with_formation_in(formation, &crate::assets::crazyflie_mesh_dir()?)
    }

    /// [`World::with_formation`] with the Crazyflie meshes read from `mesh_dir` (a missing or
    /// unreadable mesh is refused, naming its file).
    pub fn with_formation_in(formation: &Formation, mesh_dir: &Path) -> Result<Self, WorldError> {
        let observers = formation.len();
        crate::assets::check_meshes(mesh_dir, &crate::mjcf::mesh_files())?;
        let xml = formation_xml(formation, mesh_dir);
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
            cascades: Vec::new(),
            wind: None,
            tracking: vec![TrackingSums::default(); observers + 1],
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

    /// Chooses the controller of every drone from the next step on. A cascade starts with empty
    /// integrators and estimate history; drone `i`'s estimate noise is its own stream of the
    /// configured seed.
    pub fn set_controller(&mut self, kind: ControllerKind) {
        self.cascades = match kind {
            ControllerKind::Ideal => Vec::new(),
            ControllerKind::Cascade(config) => (0..self.drones.len())
                .map(|i| Some(Cascade::new(config, PHYSICS_STEP_NS, i)))
                .collect(),
        };
    }

    /// Chooses drone `i`'s controller alone from the next step on (e.g. only the performer
    /// flies the cascade); its estimate noise is the same stream [`World::set_controller`] gives it.
    pub fn set_controller_of(&mut self, i: DroneIndex, kind: ControllerKind) {
        if i >= self.drones.len() {
            return;
        }
        self.cascades.resize_with(self.drones.len(), || None);
        self.cascades[i] = match kind {
            ControllerKind::Ideal => None,
            ControllerKind::Cascade(config) => Some(Cascade::new(config, PHYSICS_STEP_NS, i)),
        };
    }

    /// What drone `i`'s cascade commanded on the last step (`None` under the ideal controller).
    pub fn cascade_command(&self, i: DroneIndex) -> Option<CascadeCommand> {
        self.cascades
            .get(i)
            .and_then(Option::as_ref)
            .map(Cascade::last_command)
    }

    /// Sets (or, with `None`, removes) the wind over every drone from the next step on. Its
    /// turbulence starts at its seed's first sample.
    pub fn set_wind(&mut self, config: Option<WindConfig>) -> Result<(), WindError> {
        self.wind = config
            .map(|c| WindField::new(c, PHYSICS_STEP_NS))
            .transpose()?;
        Ok(())
    }

    /// The wind velocity the next step applies, world frame, m/s (`None`: no wind).
    pub fn wind_mps(&self) -> Option<[f64; 3]> {
        self.wind.as_ref().map(WindField::velocity_mps)
    }

    /// The wind's drag on drone `i` in its current state, world frame, N (`None`: no wind).
    pub fn wind_drag_n(&self, i: DroneIndex) -> Option<[f64; 3]> {
        let s = self.state(i);
        self.wind
            .as_ref()
            .map(|w| w.drag_n(s.world_from_body, s.vel_mps))
    }

    /// Drone `i`'s tracking error since the world was built or [`World::reset_tracking`].
    pub fn tracking_error(&self, i: DroneIndex) -> TrackingError {
        let t = self.tracking[i];
        TrackingError {
            rms_m: if t.steps > 0 {
                (t.sum_sq_m2 / t.steps as f64).sqrt()
            } else {
                0.0
            },
            max_m: t.max_m,
            steps: t.steps,
        }
    }

    /// Restarts every drone's tracking statistics (e.g. when a broadcast starts).
    pub fn reset_tracking(&mut self) {
        self.tracking.fill(TrackingSums::default());
    }

    /// Advances one 2 ms physics step.
    pub fn step(&mut self) {
        let gravity = -self.data.model().opt().gravity[2];
        for i in 0..self.drones.len() {
            let state = self.state(i);
            let mut w = match self.cascades.get_mut(i).and_then(Option::as_mut) {
                Some(c) => c.update(
                    &state,
                    &self.references[i],
                    DRONE_MASS_KG,
                    DRONE_INERTIA_KGM2,
                    gravity,
                ),
                None => wrench(
                    &state,
                    &self.references[i],
                    DRONE_MASS_KG,
                    DRONE_INERTIA_KGM2,
                    gravity,
                    &self.gains,
                ),
            };
            // Only a set disturbance touches the wrench: the undisturbed world stays bit-exact.
            for (k, &f) in self.disturbances_n[i].iter().enumerate() {
                if f != 0.0 {
                    w[k] += f;
                }
            }
            if let Some(wind) = &self.wind {
                let drag = wind.drag_n(state.world_from_body, state.vel_mps);
                for k in 0..3 {
                    w[k] += drag[k];
                }
            }
            self.data.xfrc_applied_mut()[self.drones[i].body] = w;
        }
        self.data.step();
        self.step_index += 1;
        if let Some(wind) = self.wind.as_mut() {
            wind.advance();
        }
        if self.data.ncon() > 0 {
            self.stats.contact_steps += 1;
        }
        self.update_separation();
        self.update_tracking();
    }

    /// Samples each drone's distance from its reference at the new instant (qpos is the state
    /// after the step; the reference is advanced by one step with its feed-forward).
    fn update_tracking(&mut self) {
        let dt_s = PHYSICS_STEP_NS as f64 * 1e-9;
        for i in 0..self.drones.len() {
            let want = self.references[i].kin.extrapolated(dt_s).pos_m;
            let err = distance_m(self.state(i).pos_m, want);
            let t = &mut self.tracking[i];
            t.sum_sq_m2 += err * err;
            t.max_m = t.max_m.max(err);
            t.steps += 1;
        }
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
        // A teleported drone's cascade forgets the integrators and the estimate history of the
        // place it left.
        if let Some(c) = self.cascades.get_mut(i).and_then(Option::as_mut) {
            c.reset();
        }
        self.data.forward();
    }
}
