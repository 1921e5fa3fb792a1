//! The Dryden process against the model's own formulas: variance, autocorrelation and the
//! one-sided PSD at a few frequencies, from one seeded run (deterministic, ≈ 1 s).

use sim::wind::dryden::{
    Dryden, DrydenParams, autocorrelation_lateral, autocorrelation_longitudinal, psd_lateral,
    psd_longitudinal,
};

/// Sampling step of the statistics run, ns. The discretisation is exact at any step, so a
/// coarser step than physics' 2 ms tests the same process at a fifth of the cost.
const STEP_NS: u64 = 10_000_000;
const SAMPLES: usize = 4_000_000;

fn params() -> DrydenParams {
    DrydenParams {
        sigma_u_mps: 1.0,
        sigma_v_mps: 0.8,
        sigma_w_mps: 0.5,
        length_u_m: 2.0,
        length_v_m: 3.0,
        length_w_m: 1.0,
        advection_mps: 2.0,
    }
}

fn run(seed: u64) -> [Vec<f64>; 3] {
    let mut d = Dryden::new(params(), STEP_NS, seed).expect("params");
    let mut out = [
        Vec::with_capacity(SAMPLES),
        Vec::with_capacity(SAMPLES),
        Vec::with_capacity(SAMPLES),
    ];
    for _ in 0..SAMPLES {
        let s = d.advance();
        for k in 0..3 {
            out[k].push(s[k]);
        }
    }
    out
}

fn autocorrelation(x: &[f64], lag: usize) -> f64 {
    let n = x.len() - lag;
    x[..n]
        .iter()
        .zip(&x[lag..])
        .map(|(a, b)| a * b)
        .sum::<f64>()
        / n as f64
}

/// Welch estimate (Hann, non-overlapping segments of `seg` samples) of the one-sided PSD per
/// rad/s at DFT bin `bin`.
fn welch_psd(x: &[f64], seg: usize, bin: usize, dt_s: f64) -> f64 {
    let w: Vec<f64> = (0..seg)
        .map(|n| 0.5 - 0.5 * (std::f64::consts::TAU * n as f64 / seg as f64).cos())
        .collect();
    let u = w.iter().map(|v| v * v).sum::<f64>() / seg as f64;
    let (c, s): (Vec<f64>, Vec<f64>) = (0..seg)
        .map(|n| (std::f64::consts::TAU * (bin * n) as f64 / seg as f64).sin_cos())
        .map(|(s, c)| (c, s))
        .unzip();
    let mut acc = 0.0;
    let segments = x.len() / seg;
    for chunk in x.chunks_exact(seg) {
        let (mut re, mut im) = (0.0, 0.0);
        for n in 0..seg {
            let v = chunk[n] * w[n];
            re += v * c[n];
            im -= v * s[n];
        }
        acc += re * re + im * im;
    }
    // Two-sided per Hz: Δt/(N·U)·|X|²; one-sided per rad/s: that × 2 / 2π.
    let two_sided_per_hz = acc / segments as f64 * dt_s / (seg as f64 * u);
    two_sided_per_hz / std::f64::consts::PI
}

#[test]
fn variance_autocorrelation_and_spectrum_match_the_dryden_forms() {
    let p = params();
    let dt_s = STEP_NS as f64 * 1e-9;
    let x = run(2026);
    let comps = [
        (p.sigma_u_mps, p.length_u_m, true),
        (p.sigma_v_mps, p.length_v_m, false),
        (p.sigma_w_mps, p.length_w_m, false),
    ];
    let v = p.advection_mps;
    for (k, &(sigma, length, longitudinal)) in comps.iter().enumerate() {
        let mean = x[k].iter().sum::<f64>() / SAMPLES as f64;
        let var = autocorrelation(&x[k], 0);
        println!(
            "axis {k}: mean {mean:+.4} m/s, variance {var:.4} vs σ² {:.4}",
            sigma * sigma
        );
        assert!(mean.abs() < 0.03 * sigma, "axis {k} mean {mean}");
        assert!(
            (var / (sigma * sigma) - 1.0).abs() < 0.03,
            "axis {k} variance {var}"
        );
        let t_s = length / v;
        for lag_t in [0.1, 0.5, 1.0, 2.0] {
            let lag = (lag_t * t_s / dt_s).round() as usize;
            let tau = lag as f64 * dt_s;
            let got = autocorrelation(&x[k], lag);
            let want = if longitudinal {
                autocorrelation_longitudinal(sigma, length, v, tau)
            } else {
                autocorrelation_lateral(sigma, length, v, tau)
            };
            println!("  R({tau:.2} s) = {got:.4} vs {want:.4}");
            assert!(
                (got - want).abs() < 0.03 * sigma * sigma,
                "axis {k} R({tau}) {got} vs {want}"
            );
        }
        let seg = 4096;
        for bin in [2, 6, 20, 61] {
            let omega = std::f64::consts::TAU * bin as f64 / (seg as f64 * dt_s);
            let got = welch_psd(&x[k], seg, bin, dt_s);
            let want = if longitudinal {
                psd_longitudinal(sigma, length, v, omega)
            } else {
                psd_lateral(sigma, length, v, omega)
            };
            println!(
                "  Φ({omega:.3} rad/s) = {got:.5} vs {want:.5} ({:+.1} %)",
                (got / want - 1.0) * 100.0
            );
            assert!(
                (got / want - 1.0).abs() < 0.12,
                "axis {k} Φ({omega}) {got} vs {want}"
            );
        }
    }
}

#[test]
fn same_seed_same_samples_other_seed_other_samples() {
    let mut a = Dryden::new(params(), 2_000_000, 5).unwrap();
    let mut b = Dryden::new(params(), 2_000_000, 5).unwrap();
    let mut c = Dryden::new(params(), 2_000_000, 6).unwrap();
    let mut differ = false;
    for _ in 0..1000 {
        let (x, y, z) = (a.advance(), b.advance(), c.advance());
        assert_eq!(x.map(f64::to_bits), y.map(f64::to_bits));
        differ |= x != z;
    }
    assert!(differ);
}

#[test]
fn bad_parameters_are_refused() {
    let mut p = params();
    p.length_v_m = 0.0;
    assert!(Dryden::new(p, 2_000_000, 1).is_err());
    p = params();
    p.sigma_w_mps = f64::NAN;
    assert!(Dryden::new(p, 2_000_000, 1).is_err());
    assert!(Dryden::new(params(), 0, 1).is_err());
}
