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
        /// Standard uncertainty of the --stopwatch time, s (the seed's 0.25 s, 2.3.6).
        #[arg(long, default_value_t = 0.25, requires = "stopwatch")]
        stopwatch_error: f64,
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

/// One named result.
enum Val {
    /// A number and its standard uncertainty, if one can be derived.
    Num(f64, Option<f64>),
    /// A vector and the standard uncertainties of its components.
    Arr(Vec<f64>, Option<Vec<f64>>),
    /// A matrix (no uncertainty).
    Mat(Vec<Vec<f64>>),
    /// Anything else, printed as is (a string without its quotes; `null` as the unit alone).
    Json(serde_json::Value),
}

/// What `characterize` says when nothing in its inputs measures the error of its result.
const NO_UNCERTAINTY: &str = "not available (no repeated measurements)";

/// Named results printed as `name = value [± u] unit` lines and one `uncertainty: SOURCE`
/// line, or one JSON object (full precision; `NAME_uncertainty` beside each value that has
/// one, and `uncertainty_source`).
///
/// Text digits: a value with an uncertainty is rounded to the uncertainty's second
/// significant digit (at most 8 significant digits), the uncertainty to two; a value without
/// one gets `digits` significant digits (5 unless the tool says otherwise).
struct Out {
    rows: Vec<(&'static str, Val, &'static str)>,
    error: Option<String>,
    source: String,
    digits: usize,
}

impl Out {
    fn new() -> Self {
        Out {
            rows: vec![],
            error: None,
            source: NO_UNCERTAINTY.to_string(),
            digits: 5,
        }
    }
    /// Where the uncertainties come from, stated once.
    fn source(mut self, s: impl Into<String>) -> Self {
        self.source = s.into();
        self
    }
    fn digits(mut self, d: usize) -> Self {
        self.digits = d;
        self
    }
    /// Records the first non-finite result (an input far outside what the formula supports,
    /// e.g. `--omega 1e-300`): `print` is then an error instead of a `null`.
    fn check(&mut self, name: &'static str, vs: &[f64], unit: &'static str) {
        if let Some(v) = vs.iter().find(|v| !v.is_finite()) {
            if self.error.is_none() {
                self.error = Some(format!(
                    "{name} = {v} {unit}: the inputs are outside the range this formula supports"
                ));
            }
        }
    }
    /// A computed number without an uncertainty.
    fn num(self, name: &'static str, v: f64, unit: &'static str) -> Self {
        self.num_u(name, v, None, unit)
    }
    /// A computed number with its standard uncertainty (`None`: not derivable).
    fn num_u(mut self, name: &'static str, v: f64, u: Option<f64>, unit: &'static str) -> Self {
        self.check(name, &[v], unit);
        if let Some(u) = u {
            self.check(name, &[u], unit);
        }
        self.rows.push((name, Val::Num(v, u), unit));
        self
    }
    fn arr(
        mut self,
        name: &'static str,
        v: Vec<f64>,
        u: Option<Vec<f64>>,
        unit: &'static str,
    ) -> Self {
        self.check(name, &v, unit);
        if let Some(u) = &u {
            self.check(name, u, unit);
        }
        self.rows.push((name, Val::Arr(v, u), unit));
        self
    }
    fn mat(mut self, name: &'static str, m: Vec<Vec<f64>>, unit: &'static str) -> Self {
        for r in &m {
            self.check(name, r, unit);
        }
        self.rows.push((name, Val::Mat(m), unit));
        self
    }
    fn val(mut self, name: &'static str, v: serde_json::Value, unit: &'static str) -> Self {
        self.rows.push((name, Val::Json(v), unit));
        self
    }
    fn json(&self) -> anyhow::Result<String> {
        let mut map = serde_json::Map::new();
        for (n, v, _) in &self.rows {
            let (value, u) = match v {
                Val::Num(x, u) => (serde_json::json!(x), u.map(|u| serde_json::json!(u))),
                Val::Arr(x, u) => (
                    serde_json::json!(x),
                    u.as_ref().map(|u| serde_json::json!(u)),
                ),
                Val::Mat(m) => (serde_json::json!(m), None),
                Val::Json(j) => (j.clone(), None),
            };
            map.insert(n.to_string(), value);
            if let Some(u) = u {
                map.insert(format!("{n}_uncertainty"), u);
            }
        }
        map.insert("uncertainty_source".into(), self.source.clone().into());
        let mut text = serde_json::to_string_pretty(&map)?;
        text.push('\n');
        Ok(text)
    }
    fn text(&self) -> String {
        let mut text = String::new();
        let d = self.digits;
        let list = |xs: Vec<String>| format!("[{}]", xs.join(", "));
        for (n, v, unit) in &self.rows {
            let shown = match v {
                Val::Num(x, Some(u)) => fmt_pm(*x, *u),
                Val::Num(x, None) => fmt_sig(*x, d),
                Val::Arr(x, Some(u)) => {
                    list(x.iter().zip(u).map(|(x, u)| fmt_pm(*x, *u)).collect())
                }
                Val::Arr(x, None) => list(x.iter().map(|x| fmt_sig(*x, d)).collect()),
                Val::Mat(m) => list(
                    m.iter()
                        .map(|r| list(r.iter().map(|x| fmt_sig(*x, d)).collect()))
                        .collect(),
                ),
                Val::Json(serde_json::Value::String(s)) => s.clone(),
                Val::Json(serde_json::Value::Null) => String::new(),
                Val::Json(j) => j.to_string(),
            };
            let line = format!("{n} = {shown} {unit}");
            let _ = writeln!(text, "{}", line.trim_end().replace("=  ", "= "));
        }
        let _ = writeln!(text, "uncertainty: {}", self.source);
        text
    }
    fn print(self, json: bool) -> anyhow::Result<()> {
        if let Some(e) = self.error {
            bail!("{e}");
        }
        emit(&if json { self.json()? } else { self.text() })
    }
}

/// The decimal exponent of `x` once rounded to `sig` significant digits.
fn exp10(x: f64, sig: usize) -> i32 {
    let s = format!("{:.*e}", sig.max(1) - 1, x);
    s[s.find('e').map_or(s.len(), |i| i + 1)..]
        .parse()
        .unwrap_or(0)
}

/// Drops the trailing zeros of a decimal fraction (and of a scientific mantissa).
fn strip_zeros(s: String) -> String {
    let (m, e) = match s.find('e') {
        Some(i) => (&s[..i], &s[i..]),
        None => (&s[..], ""),
    };
    if !m.contains('.') {
        return s;
    }
    format!("{}{e}", m.trim_end_matches('0').trim_end_matches('.'))
}

/// `x` to `sig` significant digits: fixed notation for 1e-4 <= |x| < 1e6, scientific
/// otherwise; trailing zeros dropped (the value has no uncertainty to say they count).
fn fmt_sig(x: f64, sig: usize) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let e = exp10(x, sig);
    strip_zeros(if (-4..6).contains(&e) {
        let dec = (sig as i32 - 1 - e).max(0) as usize;
        format!("{x:.dec$}")
    } else {
        format!("{:.*e}", sig.max(1) - 1, x)
    })
}

/// Significant digits a value with an uncertainty is never printed beyond.
const MAX_DIGITS: i32 = 8;

/// `x ± u`: `u` to two significant digits and `x` rounded at the same decimal place (at most
/// `MAX_DIGITS` significant digits of `x`).
fn fmt_pm(x: f64, u: f64) -> String {
    if !(u.is_finite() && u > 0.0) {
        return format!("{} ± 0", fmt_sig(x, 5));
    }
    let eu = exp10(u, 2);
    let q = eu - 1; // the decimal place of the uncertainty's second digit
    let ex = if x == 0.0 { eu } else { exp10(x, 12).max(eu) };
    let wanted = ex - q + 1;
    let sig = wanted.min(MAX_DIGITS);
    if (-4..6).contains(&ex) {
        if sig == wanted && q >= -8 {
            let dec = (-q).max(0) as usize;
            let at = |v: f64| (v / 10f64.powi(q)).round() * 10f64.powi(q);
            return format!("{:.dec$} ± {:.dec$}", at(x), at(u));
        }
        if sig < wanted {
            let dec = (MAX_DIGITS - 1 - ex).max(0) as usize;
            return format!("{x:.dec$} ± {u:.1e}");
        }
    }
    format!("{:.*e} ± {u:.1e}", (sig - 1) as usize, x)
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
            stopwatch_error,
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
            // With a stopwatch, its error propagated (seed 2.3.6: |I(T + dT) - I(T)|, the
            // setup and the base inertia taken as exact); otherwise nothing to derive one from.
            let (uw, ui, source) = match (stopwatch, oscillations) {
                (Some(t), Some(n)) => {
                    if !(stopwatch_error.is_finite() && stopwatch_error >= 0.0) {
                        bail!("--stopwatch-error {stopwatch_error}: must be a finite non-negative time in s");
                    }
                    if stopwatch_error >= t {
                        bail!("--stopwatch-error {stopwatch_error} s is not smaller than the --stopwatch time {t} s");
                    }
                    let uw = (ch::omega_from_stopwatch(t + stopwatch_error, n)? - w).abs();
                    let ui = p.stopwatch_inertia_error(t, n, stopwatch_error)?;
                    (
                        Some(uw),
                        Some(ui),
                        format!(
                            "the stopwatch error {} s (--stopwatch-error) propagated through eq. 2.14-2.15 as |x(T + dT) - x(T)| (seed 2.3.6); setup and base inertia taken as exact",
                            super::num(stopwatch_error)
                        ),
                    )
                }
                _ => (None, None, NO_UNCERTAINTY.to_string()),
            };
            Out::new()
                .source(source)
                .num_u("omega", w, uw, "rad/s")
                .num_u("total_inertia", p.total_inertia(w)?, ui, "kg m^2")
                .num("base_inertia", p.base_inertia_kgm2, "kg m^2 (given)")
                .num_u("inertia", p.inertia(w)?, ui, "kg m^2")
        }
        Tool::Kappa {
            setup,
            inertia,
            omega,
        } => match (inertia, omega) {
            (Some(i), Some(w)) => Out::new()
                .num("kappa", ch::torsion_kappa(i, w)?, "N m/rad")
                .val("equation", "2.8".into(), ""),
            (None, None) => Out::new()
                .num("kappa", setup.trifilar().kappa()?, "N m/rad")
                .val("equation", "2.9".into(), ""),
            (None, Some(w)) => {
                let k = setup.trifilar().kappa()?;
                Out::new()
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
            Out::new().num("zeta", z, "").num(
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
            let se = fit.standard_errors;
            let source = match se {
                Some(_) => format!(
                    "least-squares standard errors: residual variance over {} degree{} of freedom times (A'A)^-1 (equal, independent errors on every measured inertia)",
                    fit.dof,
                    if fit.dof == 1 { "" } else { "s" }
                ),
                None => "not available (no repeated measurements: 3 angles for 3 unknowns leave no residual to estimate the error from)".to_string(),
            };
            Out::new()
                .source(source)
                .num_u("iyy", fit.iyy, se.map(|e| e[0]), "kg m^2")
                .num_u("izz", fit.izz, se.map(|e| e[1]), "kg m^2")
                .num_u(
                    "pyz",
                    fit.pyz,
                    se.map(|e| e[2]),
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
            Out::new().mat("inertia_tensor", rows, "kg m^2")
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
                Out::new()
                    .num("com_x_mm", m.y / w * 1e3, "mm")
                    .num("com_y_mm", -m.x / w * 1e3, "mm")
                    .val(
                        "com_z_mm",
                        serde_json::Value::Null,
                        "(unobserved: add --side)",
                    )
            } else {
                let c = ch::com_from_load_cell_with_uncertainty(&tests, mass, g)?;
                let se = c.standard_errors_m.map(|e| e * 1e3);
                // two mountings: 4 equations for 3 unknowns; the one redundant equation is
                // the second reading of com_y
                let source = match se {
                    Some(_) => format!(
                        "least-squares standard errors from the residual of the redundant moment equation{} ({} degree{} of freedom: the two mountings' readings of com_y; a rough estimate), equal independent errors on every averaged moment",
                        if c.dof == 1 { "" } else { "s" },
                        c.dof,
                        if c.dof == 1 { "" } else { "s" },
                    ),
                    None => NO_UNCERTAINTY.to_string(),
                };
                Out::new()
                    .source(source)
                    .num_u("com_x_mm", c.com_m.x * 1e3, se.map(|e| e.x), "mm")
                    .num_u("com_y_mm", c.com_m.y * 1e3, se.map(|e| e.y), "mm")
                    .num_u("com_z_mm", c.com_m.z * 1e3, se.map(|e| e.z), "mm")
            }
        }
        Tool::Thrust { samples, bias } => {
            let s = read_force_samples(&samples)?;
            let t = ch::thrust_from_load_cell_with_uncertainty(&s, Vector3::from(bias))?;
            let source = match t.magnitude_se_n {
                Some(_) => format!(
                    "standard error of the mean over the {} load-cell samples (their spread / sqrt({}); samples taken as independent, the bias as exact), propagated to magnitude and direction",
                    s.len(),
                    s.len()
                ),
                None => "not available (no repeated measurements: 1 load-cell sample has no spread to estimate the error from)".to_string(),
            };
            Out::new()
                .source(source)
                .num("samples", s.len() as f64, "")
                .num_u("magnitude_n", t.thrust.magnitude_n, t.magnitude_se_n, "N")
                .arr(
                    "direction",
                    t.thrust.direction.to_vec(),
                    t.direction_se.map(|d| d.to_vec()),
                    "",
                )
        }
        Tool::ParallelAxis {
            mass,
            offset,
            inertia,
        } => {
            let mut o = Out::new().num(
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
            Out::new()
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
            Out::new()
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
            // An exact discretisation, not a measurement; 8 digits because the poles sit just
            // inside z = 1 (d0 = exp(-0.02 dt)), where 5 would lose the damping.
            Out::new()
                .source("not available (an exact discretisation of the seed's model, no measurement); coefficients to 8 significant digits, the JSON has them in full")
                .digits(8)
                .num("dt_s", dt, "s")
                .mat(
                    "ad",
                    vec![vec![d.ad[(0, 0)], d.ad[(0, 1)]], vec![d.ad[(1, 0)], d.ad[(1, 1)]]],
                    "",
                )
                .arr("bd", vec![d.bd[0], d.bd[1]], None, "")
                .arr("numerator_z1_z0", num.to_vec(), None, "")
                .arr(
                    "denominator_z1_z0",
                    den.to_vec(),
                    None,
                    "(z^2 + d1 z + d0)",
                )
        }
    };
    out.print(json)
}

#[cfg(test)]
mod tests {
    use super::{fmt_pm, fmt_sig, Out};

    #[test]
    fn values_are_rounded_at_the_uncertainty_s_second_digit() {
        assert_eq!(fmt_pm(0.130123456789, 0.000341), "0.13012 ± 0.00034");
        assert_eq!(fmt_pm(-0.99871234, 0.0123), "-0.999 ± 0.012");
        assert_eq!(fmt_pm(12345.678, 564.0), "12350 ± 560");
        assert_eq!(fmt_pm(9.996, 0.0499), "9.996 ± 0.050");
        assert_eq!(fmt_pm(9.9996, 0.0499), "10.000 ± 0.050");
        assert_eq!(fmt_pm(1.2345678e-7, 3.41e-10), "1.2346e-7 ± 3.4e-10");
        assert_eq!(fmt_pm(0.123456789012, 1e-15), "0.12345679 ± 1.0e-15");
        assert_eq!(fmt_pm(0.25, 0.0), "0.25 ± 0");
        assert_eq!(fmt_sig(0.047400000000000005, 5), "0.0474");
        assert_eq!(fmt_sig(200.0, 5), "200");
        assert_eq!(fmt_sig(7.173e-7, 5), "7.173e-7");
        assert_eq!(fmt_sig(-1.99980001234, 8), "-1.9998");
    }

    #[test]
    fn a_result_outside_the_formula_is_an_error_not_null() {
        // `--omega 1e-300` made the pendulum inertia infinite and printed `null`.
        let e = Out::new()
            .num("omega", 1e-300, "rad/s")
            .num("total_inertia", f64::INFINITY, "kg m^2")
            .print(true);
        assert!(e
            .expect_err("not finite")
            .to_string()
            .contains("total_inertia = inf"));
        assert!(Out::new().num("chord_m", 0.0174, "m").error.is_none());
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
