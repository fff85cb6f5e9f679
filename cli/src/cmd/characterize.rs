//! `massid characterize`: the ground characterization tools of seed chapters 2-3 and the
//! appendix B slosh discretisation, one subcommand each, all from `reference_f64`.
use super::mix::{emit, parse_triple};
use anyhow::{anyhow, bail, Context};
use nalgebra::{Matrix3, Vector3};
use reference_f64::characterize::{self as ch, LoadCellMoments, Trifilar};
use reference_f64::slosh::SloshModel;
use std::fmt::Write as _;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
#[command(about = "Ground characterization tools (seed ch. 2-3, App. B)")]
pub struct Args {
    #[command(subcommand)]
    tool: Tool,
    /// Print JSON instead of text.
    #[arg(long, global = true)]
    json: bool,
}

/// The trifilar pendulum's setup (seed 2.3.1, eq. 2.6); defaults are the seed's.
#[derive(clap::Args, Debug, Clone)]
struct Setup {
    /// Mass on the strings (object + plate), kg.
    #[arg(long, default_value_t = Trifilar::SEED.mass_kg)]
    mass: f64,
    /// Radius of the string circle, m.
    #[arg(long, default_value_t = Trifilar::SEED.radius_m)]
    radius: f64,
    /// String length, m.
    #[arg(long, default_value_t = Trifilar::SEED.length_m)]
    length: f64,
    /// Gravity, m/s^2.
    #[arg(long, default_value_t = Trifilar::SEED.g_m_s2)]
    g: f64,
    /// Inertia of the empty mounting to remove, kg m^2.
    #[arg(long, default_value_t = Trifilar::SEED.base_inertia_kgm2)]
    base_inertia: f64,
}

impl Setup {
    fn trifilar(&self) -> Trifilar {
        Trifilar {
            mass_kg: self.mass,
            g_m_s2: self.g,
            radius_m: self.radius,
            length_m: self.length,
            base_inertia_kgm2: self.base_inertia,
        }
    }
}

#[derive(clap::Subcommand, Debug)]
enum Tool {
    /// Trifilar pendulum inertia, eq. 2.6 (I = m g r^2 / (l w^2) - I_0), from one of
    /// --omega, --period or --stopwatch with --oscillations (eq. 2.14-2.15).
    #[command(allow_negative_numbers = true)]
    Pendulum {
        #[command(flatten)]
        setup: Setup,
        /// Angular frequency of the oscillation, rad/s.
        #[arg(long, conflicts_with_all = ["period", "stopwatch"])]
        omega: Option<f64>,
        /// Oscillation period, s.
        #[arg(long, conflicts_with = "stopwatch")]
        period: Option<f64>,
        /// Stopwatch time over --oscillations full oscillations, s.
        #[arg(long, requires = "oscillations")]
        stopwatch: Option<f64>,
        /// Number of oscillations timed by --stopwatch.
        #[arg(long)]
        oscillations: Option<u32>,
    },
    /// Torsional-spring constant: eq. 2.8 (kappa = I w^2) from --inertia and --omega, or
    /// eq. 2.9 (kappa = m g r^2 / l) from the pendulum setup.
    #[command(allow_negative_numbers = true)]
    Kappa {
        #[command(flatten)]
        setup: Setup,
        /// Known inertia, kg m^2 (with --omega: eq. 2.8).
        #[arg(long, requires = "omega")]
        inertia: Option<f64>,
        /// Angular frequency, rad/s.
        #[arg(long)]
        omega: Option<f64>,
    },
    /// Damping ratio from amplitude decay, eq. 2.10, and its inertia error 100 zeta^2 %.
    #[command(allow_negative_numbers = true)]
    Damping {
        /// Initial amplitude (any unit, e.g. gyro counts).
        #[arg(long)]
        a0: f64,
        /// Amplitude after --oscillations oscillations.
        #[arg(long)]
        an: f64,
        /// Number of oscillations between the two amplitudes.
        #[arg(long)]
        oscillations: u32,
    },
    /// Products of inertia from inertias measured about axes rotated in one plane, eq. 2.7.
    #[command(allow_negative_numbers = true)]
    Products {
        /// A measurement ANGLE_DEG:INERTIA (repeat, at least 3 distinct angles).
        #[arg(
            long = "measurement",
            value_name = "ANGLE_DEG:INERTIA",
            required = true,
            allow_hyphen_values = true
        )]
        measurements: Vec<String>,
    },
    /// Full inertia tensor from the six-measurement scheme (X, Y, Z and 45 deg between
    /// X-Y, Y-Z, Z-X), seed 2.3.3.
    #[command(allow_negative_numbers = true)]
    Six {
        #[arg(long)]
        ixx: f64,
        #[arg(long)]
        iyy: f64,
        #[arg(long)]
        izz: f64,
        /// Inertia about the axis 45 deg between X and Y.
        #[arg(long)]
        ixy45: f64,
        /// Inertia about the axis 45 deg between Y and Z.
        #[arg(long)]
        iyz45: f64,
        /// Inertia about the axis 45 deg between Z and X.
        #[arg(long)]
        izx45: f64,
    },
    /// CoM offset from load-cell moments (seed 2.2): upright mounting gives x, y; mounted on
    /// its side (body z along the cell's x) gives z.
    #[command(allow_negative_numbers = true)]
    Com {
        /// Satellite mass, kg.
        #[arg(long)]
        mass: f64,
        /// Gravity, m/s^2.
        #[arg(long, default_value_t = ch::SEED_G)]
        g: f64,
        /// Averaged moments MX,MY (N m) with the satellite upright.
        #[arg(long, value_name = "MX,MY", allow_hyphen_values = true, value_parser = parse_pair)]
        upright: [f64; 2],
        /// Averaged moments MX,MY of the empty stand for the upright test (bias).
        #[arg(long, value_name = "MX,MY", allow_hyphen_values = true, value_parser = parse_pair, default_value = "0,0")]
        upright_bias: [f64; 2],
        /// Averaged moments MX,MY (N m) with the satellite on its side.
        #[arg(long, value_name = "MX,MY", allow_hyphen_values = true, value_parser = parse_pair)]
        side: Option<[f64; 2]>,
        /// Bias moments for the on-its-side test.
        #[arg(long, value_name = "MX,MY", allow_hyphen_values = true, value_parser = parse_pair, default_value = "0,0")]
        side_bias: [f64; 2],
    },
    /// Thrust magnitude and direction from load-cell forces averaged over a pulse (seed 3.5).
    #[command(allow_negative_numbers = true)]
    Thrust {
        /// CSV file of force samples during the pulse, one "FX,FY,FZ" (N) per line; lines
        /// starting with # and a non-numeric header are skipped.
        #[arg(long, value_name = "FILE")]
        samples: PathBuf,
        /// Load-cell bias FX,FY,FZ with the valve closed, N.
        #[arg(long, value_name = "FX,FY,FZ", allow_hyphen_values = true, value_parser = parse_triple, default_value = "0,0,0")]
        bias: [f64; 3],
    },
    /// Parallel-axis error m d^2 of an axis offset d from the CoM, eq. 2.12.
    #[command(allow_negative_numbers = true)]
    ParallelAxis {
        /// Mass, kg.
        #[arg(long)]
        mass: f64,
        /// Axis offset from the CoM, m.
        #[arg(long)]
        offset: f64,
        /// Inertia about the CoM axis, kg m^2 (prints the parallel-axis inertia too).
        #[arg(long)]
        inertia: Option<f64>,
    },
    /// Small-angle (arc vs chord) error of seed 2.3.6.
    #[command(allow_negative_numbers = true)]
    Chord {
        /// Radius, m.
        #[arg(long, default_value_t = Trifilar::SEED.radius_m)]
        radius: f64,
        /// Swing angle, deg.
        #[arg(long, default_value_t = 20.0)]
        angle_deg: f64,
    },
    /// Rotational vs translational oscillation energies, eq. 2.16-2.21.
    #[command(allow_negative_numbers = true)]
    Energy {
        #[command(flatten)]
        setup: Setup,
        /// Rotation amplitude, deg.
        #[arg(long, default_value_t = 20.0)]
        rotation_deg: f64,
        /// Sideways swing amplitude, m.
        #[arg(long, default_value_t = 0.01)]
        swing: f64,
    },
    /// Fuel-slosh model of App. B (H(s) = 1/(s^2 + 0.02 s + 6)) discretised by ZOH.
    #[command(allow_negative_numbers = true)]
    Slosh {
        /// Sample time, s.
        #[arg(long, default_value_t = 0.01)]
        dt: f64,
    },
}

fn parse_pair(s: &str) -> Result<[f64; 2], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 2 {
        return Err(format!("expected two comma-separated numbers, got {s:?}"));
    }
    let a: f64 = parts[0]
        .parse()
        .map_err(|_| format!("{:?} is not a number", parts[0]))?;
    let b: f64 = parts[1]
        .parse()
        .map_err(|_| format!("{:?} is not a number", parts[1]))?;
    if !(a.is_finite() && b.is_finite()) {
        return Err(format!("{s:?} is not finite"));
    }
    Ok([a, b])
}

/// Named results printed as `name = value unit` lines or one JSON object.
struct Out(
    Vec<(&'static str, serde_json::Value, &'static str)>,
    Option<String>,
);

impl Out {
    /// A computed number; one that is not finite (an input far outside what the formula
    /// supports, e.g. `--omega 1e-300`) makes `print` an error instead of a `null`.
    fn num(mut self, name: &'static str, v: f64, unit: &'static str) -> Self {
        if !v.is_finite() && self.1.is_none() {
            self.1 = Some(format!(
                "{name} = {v} {unit}: the inputs are outside the range this formula supports"
            ));
        }
        self.0.push((name, serde_json::json!(v), unit));
        self
    }
    fn val(mut self, name: &'static str, v: serde_json::Value, unit: &'static str) -> Self {
        self.0.push((name, v, unit));
        self
    }
    fn print(self, json: bool) -> anyhow::Result<()> {
        if let Some(e) = self.1 {
            bail!("{e}");
        }
        let mut text = String::new();
        if json {
            let map: serde_json::Map<String, serde_json::Value> = self
                .0
                .into_iter()
                .map(|(n, v, _)| (n.to_string(), v))
                .collect();
            text = serde_json::to_string_pretty(&map)?;
            text.push('\n');
        } else {
            for (n, v, u) in self.0 {
                writeln!(text, "{n} = {v} {u}")?;
            }
        }
        emit(&text)
    }
}

fn read_force_samples(path: &PathBuf) -> anyhow::Result<Vec<Vector3<f64>>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        match parse_triple(t) {
            Ok(v) => out.push(Vector3::from(v)),
            Err(_) if out.is_empty() && n == 0 && t.chars().any(|c| c.is_ascii_alphabetic()) => {
                continue
            } // header
            Err(e) => bail!("{}:{}: {e}", path.display(), n + 1),
        }
    }
    if out.is_empty() {
        bail!("{}: no force samples", path.display());
    }
    Ok(out)
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let json = args.json;
    let out = match args.tool {
        Tool::Pendulum {
            setup,
            omega,
            period,
            stopwatch,
            oscillations,
        } => {
            let p = setup.trifilar();
            let w = match (omega, period, stopwatch) {
                (Some(w), None, None) => w,
                (None, Some(t), None) => ch::omega_from_period(t)?,
                (None, None, Some(t)) => ch::omega_from_stopwatch(
                    t,
                    oscillations.ok_or_else(|| anyhow!("--stopwatch needs --oscillations"))?,
                )?,
                _ => bail!("give exactly one of --omega, --period, --stopwatch"),
            };
            Out(vec![], None)
                .num("omega", w, "rad/s")
                .num("total_inertia", p.total_inertia(w)?, "kg m^2")
                .num("base_inertia", p.base_inertia_kgm2, "kg m^2")
                .num("inertia", p.inertia(w)?, "kg m^2")
        }
        Tool::Kappa {
            setup,
            inertia,
            omega,
        } => match (inertia, omega) {
            (Some(i), Some(w)) => Out(vec![], None)
                .num("kappa", ch::torsion_kappa(i, w)?, "N m/rad")
                .val("equation", "2.8".into(), ""),
            (None, None) => Out(vec![], None)
                .num("kappa", setup.trifilar().kappa()?, "N m/rad")
                .val("equation", "2.9".into(), ""),
            (None, Some(w)) => {
                let k = setup.trifilar().kappa()?;
                Out(vec![], None)
                    .num("kappa", k, "N m/rad")
                    .num(
                        "inertia_from_kappa",
                        ch::inertia_from_kappa(k, w)?,
                        "kg m^2",
                    )
                    .val("equation", "2.9, then 2.8 inverted".into(), "")
            }
            (Some(_), None) => bail!("--inertia needs --omega"),
        },
        Tool::Damping {
            a0,
            an,
            oscillations,
        } => {
            let z = ch::damping_ratio(a0, an, oscillations)?;
            Out(vec![], None).num("zeta", z, "").num(
                "inertia_error_percent",
                ch::damping_inertia_error_percent(z)?,
                "%",
            )
        }
        Tool::Products { measurements } => {
            let mut ms = Vec::new();
            for m in &measurements {
                let (a, i) = m
                    .split_once(':')
                    .ok_or_else(|| anyhow!("measurement {m:?}: expected ANGLE_DEG:INERTIA"))?;
                let a: f64 = a
                    .trim()
                    .parse()
                    .map_err(|_| anyhow!("measurement {m:?}: angle {a:?} is not a number"))?;
                let i: f64 = i
                    .trim()
                    .parse()
                    .map_err(|_| anyhow!("measurement {m:?}: inertia {i:?} is not a number"))?;
                ms.push((a.to_radians(), i));
            }
            let fit = ch::products_of_inertia_from_rotations(&ms)?;
            Out(vec![], None)
                .num("iyy", fit.iyy, "kg m^2")
                .num("izz", fit.izz, "kg m^2")
                .num(
                    "pyz",
                    fit.pyz,
                    "kg m^2 (product of inertia; tensor entry is -pyz)",
                )
                .num("rms_residual", fit.rms_residual, "kg m^2")
        }
        Tool::Six {
            ixx,
            iyy,
            izz,
            ixy45,
            iyz45,
            izx45,
        } => {
            let t = ch::inertia_tensor_from_six(ixx, iyy, izz, ixy45, iyz45, izx45)?;
            let rows: Vec<Vec<f64>> = (0..3)
                .map(|r| (0..3).map(|c| t[(r, c)]).collect())
                .collect();
            Out(vec![], None).val("inertia_tensor", serde_json::json!(rows), "kg m^2")
        }
        Tool::Com {
            mass,
            g,
            upright,
            upright_bias,
            side,
            side_bias,
        } => {
            let mut tests = vec![LoadCellMoments {
                body_to_cell: Matrix3::identity(),
                moment_nm: Vector3::new(upright[0], upright[1], 0.0),
                bias_nm: Vector3::new(upright_bias[0], upright_bias[1], 0.0),
            }];
            if let Some(s) = side {
                tests.push(LoadCellMoments {
                    body_to_cell: Matrix3::new(0.0, 0.0, 1.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0),
                    moment_nm: Vector3::new(s[0], s[1], 0.0),
                    bias_nm: Vector3::new(side_bias[0], side_bias[1], 0.0),
                });
            }
            if side.is_none() {
                // upright alone: x and y only (2 equations, the vertical axis unobserved)
                let w = mass * g;
                if !(w.is_finite() && w > 0.0) {
                    bail!("mass and gravity must be positive");
                }
                let m = Vector3::new(
                    upright[0] - upright_bias[0],
                    upright[1] - upright_bias[1],
                    0.0,
                );
                Out(vec![], None)
                    .num("com_x_mm", m.y / w * 1e3, "mm")
                    .num("com_y_mm", -m.x / w * 1e3, "mm")
                    .val(
                        "com_z_mm",
                        serde_json::Value::Null,
                        "(unobserved: add --side)",
                    )
            } else {
                let c = ch::com_from_load_cell(&tests, mass, g)?;
                Out(vec![], None)
                    .num("com_x_mm", c.x * 1e3, "mm")
                    .num("com_y_mm", c.y * 1e3, "mm")
                    .num("com_z_mm", c.z * 1e3, "mm")
            }
        }
        Tool::Thrust { samples, bias } => {
            let s = read_force_samples(&samples)?;
            let t = ch::thrust_from_load_cell(&s, Vector3::from(bias))?;
            Out(vec![], None)
                .num("samples", s.len() as f64, "")
                .num("magnitude_n", t.magnitude_n, "N")
                .val("direction", serde_json::json!(t.direction), "")
        }
        Tool::ParallelAxis {
            mass,
            offset,
            inertia,
        } => {
            let mut o = Out(vec![], None).num(
                "inertia_error",
                ch::parallel_axis_error(mass, offset)?,
                "kg m^2",
            );
            if let Some(i) = inertia {
                o = o.num(
                    "parallel_axis_inertia",
                    ch::parallel_axis(i, mass, offset)?,
                    "kg m^2",
                );
            }
            o
        }
        Tool::Chord { radius, angle_deg } => {
            let (arc, chord, err) = ch::chord_error(radius, angle_deg.to_radians())?;
            Out(vec![], None)
                .num("arc_m", arc, "m")
                .num("chord_m", chord, "m")
                .num("error_m", err, "m")
                .num("error_percent", 100.0 * err / arc, "%")
        }
        Tool::Energy {
            setup,
            rotation_deg,
            swing,
        } => {
            let p = setup.trifilar();
            let ea = p.rotational_energy(rotation_deg.to_radians())?;
            let eb = p.translational_energy(swing)?;
            Out(vec![], None)
                .num("rotational_energy_j", ea, "J")
                .num("translational_energy_j", eb, "J")
                .num(
                    "inertia_error_percent",
                    100.0 * p.swing_inertia_error_fraction(rotation_deg.to_radians(), swing)?,
                    "%",
                )
        }
        Tool::Slosh { dt } => {
            // A step longer than half the slosh period cannot represent it (Nyquist); 1e308
            // used to print nulls.
            let nyquist_s = std::f64::consts::PI / SloshModel::SEED.stiffness_per_mass.sqrt();
            if !(dt.is_finite() && dt > 0.0 && dt <= nyquist_s) {
                anyhow::bail!(
                    "--dt {}: the sample time must be in (0, {nyquist_s:.4}] s, half the period of the slosh mode (sqrt(k/M) = {:.4} rad/s); a longer step cannot represent it",
                    super::num(dt),
                    SloshModel::SEED.stiffness_per_mass.sqrt()
                );
            }
            let d = SloshModel::SEED.discretize_zoh(dt)?;
            let (num, den) = d.transfer_function();
            Out(vec![], None)
                .num("dt_s", dt, "s")
                .val(
                    "ad",
                    serde_json::json!([[d.ad[(0, 0)], d.ad[(0, 1)]], [d.ad[(1, 0)], d.ad[(1, 1)]]]),
                    "",
                )
                .val("bd", serde_json::json!([d.bd[0], d.bd[1]]), "")
                .val("numerator_z1_z0", serde_json::json!(num), "")
                .val(
                    "denominator_z1_z0",
                    serde_json::json!(den),
                    "(z^2 + d1 z + d0)",
                )
        }
    };
    out.print(json)
}

#[cfg(test)]
mod tests {
    use super::Out;

    #[test]
    fn a_result_outside_the_formula_is_an_error_not_null() {
        // `--omega 1e-300` made the pendulum inertia infinite and printed `null`.
        let e = Out(vec![], None)
            .num("omega", 1e-300, "rad/s")
            .num("total_inertia", f64::INFINITY, "kg m^2")
            .print(true);
        assert!(e
            .expect_err("not finite")
            .to_string()
            .contains("total_inertia = inf"));
        assert!(Out(vec![], None).num("chord_m", 0.0174, "m").1.is_none());
    }

    #[test]
    fn a_chord_is_only_defined_below_half_a_turn() {
        use reference_f64::characterize::chord_error;
        assert!(chord_error(0.1, 360f64.to_radians()).is_err());
        assert!(chord_error(0.1, 180f64.to_radians()).is_err());
        let (arc, chord, err) = chord_error(0.1, 10f64.to_radians()).expect("10 deg");
        assert!(chord > 0.0 && chord < arc && err > 0.0);
    }
}
