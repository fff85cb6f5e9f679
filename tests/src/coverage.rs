//! Monte Carlo coverage of reported standard errors: many simulated flights of the nominal
//! SPH2 (truth = the model: CoM offset 0, the model's inertia) that differ only in the noise
//! seed, through the f64 reference (online form) and the f32 and fixed-point kernels.
use massid_sim::{simulate, Maneuver, SimSpec};
use reference_f64::pipeline::{estimate_online, Estimate, PipelineConfig};
use reference_f64::satellite::Satellite;

/// The terms measured: CoM x y z (mm), principal inertias (kg m^2).
pub const TERMS: [&str; 6] = ["cm_x", "cm_y", "cm_z", "Ixx", "Iyy", "Izz"];
/// The implementations.
pub const IMPLS: [&str; 3] = ["f64", "f32", "fixed"];

/// Per implementation and term: flights, within 1 sigma, within 2 sigma, sum of error/sigma,
/// sum of squared error, sum of squared reported sigma.
#[derive(Clone, Debug, Default)]
pub struct Table {
    pub cells: [[Cell; 6]; 3],
}

/// One implementation's record for one term.
#[derive(Clone, Copy, Debug, Default)]
pub struct Cell {
    pub n: u32,
    pub in1: u32,
    pub in2: u32,
    pub z_sum: f64,
    pub err_sq: f64,
    pub sigma_sq: f64,
}

impl Cell {
    fn add(&mut self, err: f64, sigma: f64) {
        self.n += 1;
        let z = err / sigma;
        if z.abs() <= 1.0 {
            self.in1 += 1;
        }
        if z.abs() <= 2.0 {
            self.in2 += 1;
        }
        self.z_sum += if z.is_finite() { z } else { 0.0 };
        self.err_sq += err * err;
        self.sigma_sq += sigma * sigma;
    }
    /// Share within 1 sigma, %.
    pub fn cover1(&self) -> f64 {
        100.0 * f64::from(self.in1) / f64::from(self.n.max(1))
    }
    /// Share within 2 sigma, %.
    pub fn cover2(&self) -> f64 {
        100.0 * f64::from(self.in2) / f64::from(self.n.max(1))
    }
    /// Mean error in sigma.
    pub fn bias(&self) -> f64 {
        self.z_sum / f64::from(self.n.max(1))
    }
    /// RMS error over RMS reported sigma (1 when the sigmas are honest).
    pub fn ratio(&self) -> f64 {
        (self.err_sq / self.sigma_sq.max(f64::MIN_POSITIVE)).sqrt()
    }
}

impl Table {
    /// Adds one flight's estimate of implementation `k`.
    pub fn add(&mut self, k: usize, e: &Estimate, sat: &Satellite) {
        for j in 0..3 {
            self.cells[k][j].add(e.com_offset_mm[j], e.com_offset_stderr_mm[j]);
        }
        for j in 0..3 {
            self.cells[k][3 + j].add(
                e.inertia_kgm2[j] - sat.inertia_kgm2[j],
                e.inertia_stderr_kgm2[j],
            );
        }
    }

    /// The table as markdown rows.
    pub fn markdown(&self) -> String {
        let mut s = String::from("| impl | term | flights | within 1 sigma | within 2 sigma | bias (sigma) | RMS error / RMS sigma |\n|---|---|---|---|---|---|---|\n");
        for (k, name) in IMPLS.iter().enumerate() {
            for (j, t) in TERMS.iter().enumerate() {
                let c = &self.cells[k][j];
                s += &format!(
                    "| {name} | {t} | {} | {:.1} % | {:.1} % | {:+.2} | {:.2} |\n",
                    c.n,
                    c.cover1(),
                    c.cover2(),
                    c.bias(),
                    c.ratio()
                );
            }
        }
        s
    }
}

/// Flies `n` rga12 flights (seeds `seed0..seed0+n`) and tabulates the coverage.
pub fn run_flights(n: u64, seed0: u64) -> Table {
    run_flights_with(n, seed0, |_| {})
}

/// [`run_flights`] with the kernels' estimates altered by `fault` first (planted-fault tests).
pub fn run_flights_with(n: u64, seed0: u64, fault: impl Fn(&mut Estimate)) -> Table {
    let sat = Satellite::builtin("sph2").expect("sph2");
    let cfg = PipelineConfig {
        keep_history: false,
        ..PipelineConfig::default()
    };
    let mut t = Table::default();
    for seed in seed0..seed0 + n {
        let mut spec = SimSpec::new(sat.clone(), Vec::new(), Maneuver::Rga12);
        spec.seed = seed;
        let rec = simulate(&spec).expect("simulation").recording;
        t.add(0, &estimate_online(&rec, &sat, &cfg), &sat);
        if let Ok(mut e) = massid_kernel_host::estimate::<f32>(&rec, &sat) {
            fault(&mut e);
            t.add(1, &e, &sat);
        }
        if let Ok(mut e) = massid_kernel_host::estimate::<massid_kernel::Q8_24>(&rec, &sat) {
            fault(&mut e);
            t.add(2, &e, &sat);
        }
    }
    t
}
