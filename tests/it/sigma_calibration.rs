//! Whether the reported σ is honest, on data legwise did not make: 400 data sets of the 5R at
//! fixed poses drawn uniformly over the usable workspace, generated here in closed form (each
//! leg's reading from the triangle A–B–P, with the noise the model declares on the measured
//! position and on the readings), identified by divide and conquer. Over the data sets, the
//! spread of each parameter's error against the mean σ reported for it; the coverage of the
//! 95 % intervals; and how many clean leg fits flag a row as an outlier.
use std::f64::consts::PI;

use legwise::identify::estimate::{identify_with, FitOptions, Strategy, StrategyResult};
use legwise::model::Mechanism;
use legwise::solver::SolverKind;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use rayon::prelude::*;

use crate::support::bundled;

/// Data sets.
const SETS: usize = 400;

/// A leg of the 5R in closed form: base joint `a`, driving link `l`, driven link `big_l`,
/// gain `k` and offset `gamma` (θ = k ψ + γ), elbow on side `side` (±1).
struct Leg {
    a: [f64; 2],
    l: f64,
    big_l: f64,
    k: f64,
    gamma: f64,
    side: f64,
}

impl Leg {
    /// The leg with the model's parameters `values` (l, L, Ax, Ay, k, γ).
    fn new(values: &[f64], side: f64) -> Self {
        Leg {
            a: [values[2], values[3]],
            l: values[0],
            big_l: values[1],
            k: values[4],
            gamma: values[5],
            side,
        }
    }

    /// The driving joint's angle with the platform point at `p`: the triangle A–B–P.
    fn joint(&self, p: [f64; 2]) -> f64 {
        let (dx, dy) = (p[0] - self.a[0], p[1] - self.a[1]);
        let d = dx.hypot(dy);
        let cos = (self.l * self.l + d * d - self.big_l * self.big_l) / (2.0 * self.l * d);
        assert!(cos.abs() < 1.0, "the pose is out of the leg's reach");
        dy.atan2(dx) + self.side * cos.acos()
    }

    /// The actuator reading at `p`.
    fn reading(&self, p: [f64; 2]) -> f64 {
        (self.joint(p) - self.gamma) / self.k
    }
}

/// The model's values of leg `l`'s parameters, nominal or real (the simulation block).
fn values(mechanism: &Mechanism, l: usize, real: bool) -> Vec<f64> {
    let simulation = mechanism.simulation.as_ref().expect("a simulation block");
    mechanism.legs[l]
        .params
        .iter()
        .map(|p| {
            if real {
                simulation.real[&p.name]
            } else {
                p.nominal
            }
        })
        .collect()
}

/// Each leg's elbow side: the one whose joint angle at the home pose, with the nominal
/// parameters, is the model's home joint value.
fn sides(mechanism: &Mechanism) -> Vec<f64> {
    let home = [mechanism.home_pose[0], mechanism.home_pose[1]];
    (0..2)
        .map(|l| {
            let nominal = values(mechanism, l, false);
            [1.0, -1.0]
                .into_iter()
                .find(|&s| {
                    let angle = Leg::new(&nominal, s).joint(home);
                    let leg = &mechanism.legs[l];
                    let home_value = leg.home_joints[leg.actuated];
                    ((angle - home_value + PI).rem_euclid(2.0 * PI) - PI).abs() < 1e-3
                })
                .expect("one side matches the home configuration")
        })
        .collect()
}

/// 18 poses per leg, uniform over the usable disc (the region's radius less the margin).
fn poses(rng: &mut ChaCha8Rng) -> Vec<Vec<[f64; 2]>> {
    let (centre, radius) = ([0.0, 1.095_652_173_9], 0.645_652_173_9 - 0.032_282_608_7);
    (0..2)
        .map(|_| {
            (0..18)
                .map(|_| {
                    let r = radius * rng.random::<f64>().sqrt();
                    let t = 2.0 * PI * rng.random::<f64>();
                    [centre[0] + r * t.cos(), centre[1] + r * t.sin()]
                })
                .collect()
        })
        .collect()
}

/// One data set as a measurement CSV: each leg's poses with the pose noise, its readings at
/// the true poses with the reading noise.
fn data_set(legs: &[Leg], poses: &[Vec<[f64; 2]>], noise: (f64, f64), seed: u64) -> String {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (pose, reading) = (
        Normal::new(0.0, noise.0).unwrap(),
        Normal::new(0.0, noise.1).unwrap(),
    );
    let mut csv = String::from("leg,x,y,A1,A2\n");
    for (l, leg) in legs.iter().enumerate() {
        for p in &poses[l] {
            let psi = leg.reading(*p) + reading.sample(&mut rng);
            let (x, y) = (p[0] + pose.sample(&mut rng), p[1] + pose.sample(&mut rng));
            let cells = if l == 0 {
                format!("{psi},")
            } else {
                format!(",{psi}")
            };
            csv.push_str(&format!("leg{},{x},{y},{cells}\n", l + 1));
        }
    }
    csv
}

/// Per parameter (model order over the legs): the spread of the errors over the mean reported
/// σ, and the coverage of the 95 % intervals; and the share of leg fits that flag a row.
fn calibration(results: &[StrategyResult], real: &[f64]) -> (Vec<f64>, Vec<f64>, f64) {
    let mut ratios = Vec::new();
    let mut coverage = Vec::new();
    for (k, &value) in real.iter().enumerate() {
        let (l, i) = (k / 6, k % 6);
        let estimates: Vec<_> = results.iter().map(|r| &r.legs[l].parameters[i]).collect();
        let errors: Vec<f64> = estimates.iter().map(|p| p.estimate - value).collect();
        let n = errors.len() as f64;
        let mean = errors.iter().sum::<f64>() / n;
        let spread = (errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let reported = estimates.iter().map(|p| p.std.unwrap()).sum::<f64>() / n;
        ratios.push(spread / reported);
        let covered = estimates
            .iter()
            .zip(&errors)
            .filter(|(p, e)| e.abs() <= p.half_width95().unwrap())
            .count();
        coverage.push(covered as f64 / n);
    }
    let fits = results.iter().flat_map(|r| &r.legs);
    let flagged = fits
        .clone()
        .filter(|l| !l.statistics.outliers.is_empty())
        .count();
    (ratios, coverage, flagged as f64 / fits.count() as f64)
}

/// Identifies every data set with `options`.
fn identify_all(
    mechanism: &Mechanism,
    sets: &[String],
    options: FitOptions,
) -> Vec<StrategyResult> {
    sets.par_iter()
        .map(|csv| {
            let path = std::path::Path::new("generated.csv");
            let data = legwise::measure::file::parse(csv, path, mechanism).unwrap();
            let strategy = Strategy::DivideAndConquer;
            identify_with(
                mechanism,
                &data,
                strategy,
                SolverKind::LevenbergMarquardt,
                options,
            )
            .unwrap()
        })
        .collect()
}

#[test]
fn over_400_independent_data_sets_the_reported_sigma_is_the_spread_of_the_estimates() {
    let mechanism = bundled("5r.yaml");
    let noise = mechanism.noise.expect("the 5R declares its noise");
    assert!(
        (noise.pose[0] - noise.pose[1]).abs() < 1e-15,
        "one σ for x and y"
    );
    let sides = sides(&mechanism);
    let real: Vec<f64> = (0..2).flat_map(|l| values(&mechanism, l, true)).collect();
    let legs: Vec<Leg> = (0..2)
        .map(|l| Leg::new(&real[6 * l..6 * l + 6], sides[l]))
        .collect();
    let poses = poses(&mut ChaCha8Rng::seed_from_u64(27));
    let sets: Vec<String> = (0..SETS as u64)
        .map(|s| data_set(&legs, &poses, (noise.pose[0], noise.reading), 1000 + s))
        .collect();
    let names: Vec<&str> = mechanism
        .legs
        .iter()
        .flat_map(|l| l.params.iter().map(|p| p.name.as_str()))
        .collect();
    for (what, options) in [
        ("default (weighted)", FitOptions::default()),
        ("unweighted (sandwich)", crate::support::unweighted()),
    ] {
        let results = identify_all(&mechanism, &sets, options);
        let (ratios, coverage, flagged) = calibration(&results, &real);
        let listed: Vec<String> = names
            .iter()
            .zip(ratios.iter().zip(&coverage))
            .map(|(n, (r, c))| format!("{n} {r:.3} ({:.1} %)", 100.0 * c))
            .collect();
        let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
        let summary = format!(
            "{what}: spread / σ (coverage): {}; mean {mean:.3}",
            listed.join(", ")
        );
        println!("{summary}; flagged {:.2} %", 100.0 * flagged);
        assert!((mean - 1.0).abs() <= 0.04, "{summary}");
        assert!(ratios.iter().all(|r| (r - 1.0).abs() <= 0.10), "{summary}");
        assert!(
            flagged <= 0.015,
            "{what}: {:.2} % of the leg fits flag a row",
            100.0 * flagged
        );
    }
}
