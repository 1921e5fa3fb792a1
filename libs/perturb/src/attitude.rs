//! The error of an observer's attitude estimate (`flight.attitude_sigma_deg`).
//!
//! Receivers undo the airframe's turn from its home attitude ([`proto::stabilise`]) with the
//! attitude an estimator hands them. A real one (a complementary or Kalman filter over gyro and
//! accelerometer) is off by a fraction of a degree that wanders over seconds: gyro bias drift,
//! and tilt corrections that mistake acceleration for gravity. The model: a small world-frame
//! rotation error whose three axes are independent first-order Gauss–Markov processes of σ
//! `flight.attitude_sigma_deg` and correlation time `flight.attitude_tau_s` (default 1 s, of the
//! order of the filters' tilt-correction time constants; long, the error is a bias that holds
//! over a gesture, which the centred template distance forgives; short, it is jitter), started
//! from its stationary distribution and stepped exactly between render instants. The estimate is then
//! `R_err · R_true`, so the turn handed to the receiver is `R_err · (R_true · R_homeᵀ)`.
//! Off (σ = 0) it draws nothing and hands the turn on untouched.

use proto::EgoRotation;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::seed::{Stream, stream_seed};
use crate::spec::Perturbation;

/// One observer's attitude-estimate error over a flight.
#[derive(Debug, Clone)]
pub struct AttitudeError {
    sigma_rad: f64,
    tau_s: f64,
    rng: ChaCha8Rng,
    /// The error's rotation vector (world axes), radians, and when it was drawn.
    state: Option<([f64; 3], u64)>,
}

impl Perturbation {
    /// Observer `observer`'s attitude-estimate error in trial `trial_seed`, or `None` when the
    /// estimate is exact.
    pub fn attitude_error_of(&self, trial_seed: u64, observer: usize) -> Option<AttitudeError> {
        let sigma_deg = self.get("flight.attitude_sigma_deg");
        (sigma_deg > 0.0).then(|| {
            AttitudeError::new(
                sigma_deg.to_radians(),
                self.get("flight.attitude_tau_s"),
                stream_seed(trial_seed, Stream::Attitude, observer),
            )
        })
    }
}

impl AttitudeError {
    /// An error of σ `sigma_rad` per axis and correlation time `tau_s`, drawn from `seed`.
    pub fn new(sigma_rad: f64, tau_s: f64, seed: u64) -> Self {
        Self {
            sigma_rad,
            tau_s,
            rng: ChaCha8Rng::seed_from_u64(seed),
            state: None,
        }
    }

    /// The error's rotation vector at `t_ns` (world axes, radians). Instants must not go back.
    pub fn at(&mut self, t_ns: u64) -> [f64; 3] {
        let mut draw = || -> f64 { StandardNormal.sample(&mut self.rng) };
        let next = match self.state {
            None => [0, 1, 2].map(|_| self.sigma_rad * draw()),
            Some((e, last_ns)) if t_ns > last_ns => {
                let a = (-((t_ns - last_ns) as f64 * 1e-9) / self.tau_s).exp();
                let b = self.sigma_rad * (1.0 - a * a).sqrt();
                [0, 1, 2].map(|k| a * e[k] + b * draw())
            }
            Some((e, _)) => e,
        };
        self.state = Some((next, t_ns));
        next
    }

    /// The turn the receiver is handed at `t_ns` when the airframe has truly turned by `turn`.
    pub fn apply(&mut self, t_ns: u64, turn: Option<EgoRotation>) -> Option<EgoRotation> {
        let error = rotation_matrix(self.at(t_ns));
        let truth = turn.map_or(IDENTITY, |t| t.world_from_home);
        let mut m = [[0.0; 3]; 3];
        for (r, row) in m.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v = (0..3).map(|k| error[r][k] * truth[k][c]).sum();
            }
        }
        Some(EgoRotation { world_from_home: m })
    }
}

/// Hands on `turn` through `error` if there is one.
pub fn estimated(
    error: Option<&mut AttitudeError>,
    t_ns: u64,
    turn: Option<EgoRotation>,
) -> Option<EgoRotation> {
    match error {
        Some(e) => e.apply(t_ns, turn),
        None => turn,
    }
}

const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// The rotation matrix of rotation vector `v` (Rodrigues).
fn rotation_matrix(v: [f64; 3]) -> [[f64; 3]; 3] {
    let angle = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if angle == 0.0 {
        return IDENTITY;
    }
    let [x, y, z] = v.map(|c| c / angle);
    let (s, c) = angle.sin_cos();
    let t = 1.0 - c;
    [
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn off_hands_the_turn_on_and_on_it_is_a_gauss_markov_error_of_its_sigma() {
        let none = Perturbation::default();
        assert!(none.attitude_error_of(1, 0).is_none());
        assert_eq!(estimated(None, 5, None), None);
        let p = Perturbation::parse(&["flight.attitude_sigma_deg=0.5", "flight.attitude_tau_s=2"])
            .unwrap();
        let (sigma, tau_ns) = (0.5f64.to_radians(), 2_000_000_000);
        // Many independent errors: stationary variance σ², lag-τ correlation e⁻¹.
        let (mut var0, mut var1, mut cov) = (0.0, 0.0, 0.0);
        let n = 4000;
        for trial in 0..n {
            let mut e = p.attitude_error_of(trial, 2).unwrap();
            let a = e.at(10_000_000);
            let b = e.at(10_000_000 + tau_ns);
            assert_eq!(e.at(10_000_000 + tau_ns), b);
            var0 += a[0] * a[0];
            var1 += b[1] * b[1];
            cov += a[2] * b[2];
        }
        let (var0, var1, rho) = (
            var0 / n as f64,
            var1 / n as f64,
            cov / n as f64 / sigma.powi(2),
        );
        for v in [var0, var1] {
            assert!(
                (v / sigma.powi(2) - 1.0).abs() < 0.08,
                "{v} vs {}",
                sigma.powi(2)
            );
        }
        assert!((rho - (-1.0f64).exp()).abs() < 0.05, "ρ(τ) = {rho}");
        // Seeded per observer and trial.
        let first = |t: u64, o: usize| p.attitude_error_of(t, o).unwrap().at(0);
        assert_eq!(first(3, 1), first(3, 1));
        assert_ne!(first(3, 1), first(3, 2));
        assert_ne!(first(3, 1), first(4, 1));
    }

    #[test]
    fn the_error_turns_the_true_turn_by_its_own_angle() {
        let mut e = AttitudeError::new(0.01, 1.0, 9);
        let v = e.at(0);
        let angle = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let mut e = AttitudeError::new(0.01, 1.0, 9);
        // A still airframe is handed the error alone.
        let still = e.apply(0, None).unwrap();
        assert!((still.angle_rad() - angle).abs() < 1e-9);
        // A turn about z composed with the error: R_err · R_turn.
        let h = 0.05f64;
        let turn = EgoRotation::between([1.0, 0.0, 0.0, 0.0], [h.cos(), 0.0, 0.0, h.sin()]);
        let mut e = AttitudeError::new(0.01, 1.0, 9);
        let got = e.apply(0, turn).unwrap().world_from_home;
        let r = rotation_matrix(v);
        let t = turn.unwrap().world_from_home;
        for i in 0..3 {
            for j in 0..3 {
                let want: f64 = (0..3).map(|k| r[i][k] * t[k][j]).sum();
                assert!((got[i][j] - want).abs() < 1e-12);
            }
        }
        // Rodrigues gives a rotation: orthonormal.
        for i in 0..3 {
            for j in 0..3 {
                let dot: f64 = (0..3).map(|k| r[i][k] * r[j][k]).sum();
                assert!((dot - f64::from(u8::from(i == j))).abs() < 1e-12);
            }
        }
    }
}
