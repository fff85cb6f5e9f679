//! `massid characterize` prints each value with a sensible number of digits and its standard
//! uncertainty where one can be derived (issue 26 item 6): no 17-digit numbers in the text,
//! `±` where there are repeated measurements or a stated stopwatch error, one line saying
//! where the uncertainty comes from (or that it is not available), and the uncertainty right
//! on synthetic data with known noise.
mod common;
use common::{ok, s, tmp};

/// Significant digits of every number in `text` (a run of digits and points, with an
/// optional exponent, not glued to a word such as `sph2`), with the number.
fn numbers(text: &str) -> Vec<(String, usize)> {
    let b = text.as_bytes();
    let mut out = vec![];
    let mut i = 0;
    while i < b.len() {
        let glued = i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_');
        if b[i].is_ascii_digit() && !glued {
            let start = i;
            while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.') {
                i += 1;
            }
            let mantissa = &text[start..i];
            if i < b.len() && b[i] == b'e' {
                let mut j = i + 1;
                if j < b.len() && (b[j] == b'-' || b[j] == b'+') {
                    j += 1;
                }
                if j < b.len() && b[j].is_ascii_digit() {
                    while j < b.len() && b[j].is_ascii_digit() {
                        j += 1;
                    }
                    i = j;
                }
            }
            let digits = mantissa
                .trim_end_matches('.')
                .chars()
                .filter(|c| *c != '.')
                .skip_while(|c| *c == '0')
                .count();
            out.push((text[start..i].to_string(), digits));
        } else {
            i += 1;
        }
    }
    out
}

/// Seeded normal deviates (SplitMix64 + Box-Muller), so the test needs no RNG crate.
struct Normal(u64);
impl Normal {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn sample(&mut self, sigma: f64) -> f64 {
        let (u1, u2) = (self.uniform(), self.uniform());
        sigma * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// A load-cell pulse: `n` samples of `f` plus independent noise `sigma` on each component.
fn pulse_file(dir: &std::path::Path, f: [f64; 3], sigma: f64, n: usize, seed: u64) -> String {
    let mut g = Normal(seed);
    let mut text = String::from("fx,fy,fz\n");
    for _ in 0..n {
        let v: Vec<String> = f
            .iter()
            .map(|x| (x + g.sample(sigma)).to_string())
            .collect();
        text.push_str(&v.join(","));
        text.push('\n');
    }
    let p = dir.join(format!("pulse-{seed}.csv"));
    std::fs::write(&p, text).unwrap();
    s(&p)
}

fn json(args: &[&str]) -> serde_json::Value {
    let mut a = vec!["characterize", "--json"];
    a.extend_from_slice(args);
    serde_json::from_str(&ok(&a)).expect("characterize --json is JSON")
}

fn field(v: &serde_json::Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} missing in {v}"))
}

const PRODUCTS5: [&str; 10] = [
    "--measurement",
    "0:0.0242",
    "--measurement",
    "30:0.0231",
    "--measurement",
    "60:0.0219",
    "--measurement",
    "90:0.0215",
    "--measurement",
    "120:0.0224",
];

#[test]
fn every_tool_prints_few_digits_and_says_where_its_uncertainty_comes_from() {
    let d = tmp("characterize_output", "digits");
    let pulse = pulse_file(&d, [0.12, 0.03, -0.01], 0.02, 200, 1);
    let mut products5 = vec!["products"];
    products5.extend_from_slice(&PRODUCTS5);
    // (arguments, whether an uncertainty is derivable from them)
    let cases: Vec<(Vec<&str>, bool)> = vec![
        (
            vec!["pendulum", "--stopwatch", "42", "--oscillations", "20"],
            true,
        ),
        (vec!["pendulum", "--period", "2.1"], false),
        (vec!["pendulum", "--omega", "2.933"], false),
        (vec!["kappa"], false),
        (vec!["kappa", "--omega", "2.9"], false),
        (
            vec!["kappa", "--inertia", "0.0674", "--omega", "2.933"],
            false,
        ),
        (
            vec![
                "damping",
                "--a0",
                "306",
                "--an",
                "299",
                "--oscillations",
                "13",
            ],
            false,
        ),
        (products5, true),
        (
            vec![
                "products",
                "--measurement",
                "0:0.0242",
                "--measurement",
                "30:0.0231",
                "--measurement",
                "60:0.0219",
            ],
            false,
        ),
        (
            vec![
                "six", "--ixx", "0.0245", "--iyy", "0.0215", "--izz", "0.0203", "--ixy45",
                "0.0231", "--iyz45", "0.0212", "--izx45", "0.0222",
            ],
            false,
        ),
        (
            vec!["com", "--mass", "3.5", "--upright", "0.01,-0.02"],
            false,
        ),
        (
            vec![
                "com",
                "--mass",
                "3.5",
                "--upright",
                "0.01,-0.02",
                "--side",
                "0.0103,0.004",
            ],
            true,
        ),
        (vec!["thrust", "--samples", &pulse], true),
        (
            vec![
                "parallel-axis",
                "--mass",
                "4",
                "--offset",
                "0.003",
                "--inertia",
                "0.02",
            ],
            false,
        ),
        (vec!["chord"], false),
        (vec!["energy"], false),
        (vec!["slosh"], false),
        (vec!["slosh", "--dt", "0.001"], false),
    ];
    for (args, derivable) in cases {
        let mut a = vec!["characterize"];
        a.extend_from_slice(&args);
        let text = ok(&a);
        let nums = numbers(&text);
        assert!(!nums.is_empty(), "{args:?}: no numbers in\n{text}");
        for (n, digits) in &nums {
            assert!(
                *digits <= 8,
                "{args:?}: {n} has {digits} significant digits in\n{text}"
            );
        }
        let said: Vec<&str> = text
            .lines()
            .filter(|l| l.starts_with("uncertainty: "))
            .collect();
        assert_eq!(said.len(), 1, "{args:?}: one uncertainty line in\n{text}");
        if derivable {
            assert!(text.contains(" ± "), "{args:?}: no ± in\n{text}");
            assert!(!said[0].contains("not available"), "{args:?}:\n{text}");
        } else {
            assert!(!text.contains('±'), "{args:?}: an invented ± in\n{text}");
            assert!(
                said[0].starts_with("uncertainty: not available ("),
                "{args:?}:\n{text}"
            );
        }
        // the JSON carries the same statement and, where derivable, the uncertainties
        let mut j = vec!["characterize", "--json"];
        j.extend_from_slice(&args);
        let v: serde_json::Value = serde_json::from_str(&ok(&j)).unwrap();
        let m = v.as_object().unwrap();
        assert_eq!(
            m["uncertainty_source"].as_str().unwrap(),
            said[0].trim_start_matches("uncertainty: ")
        );
        assert_eq!(
            m.keys().any(|k| k.ends_with("_uncertainty")),
            derivable,
            "{args:?}: {v}"
        );
    }
    std::fs::remove_dir_all(&d).ok();
}

/// The check on a thrust standard error: within 30 % of `sigma / sqrt(n)`.
fn se_right(reported: f64, sigma: f64, n: usize) -> bool {
    (reported / (sigma / (n as f64).sqrt()) - 1.0).abs() < 0.3
}

#[test]
fn thrust_standard_error_is_sigma_over_root_n() {
    let d = tmp("characterize_output", "thrust");
    let (sigma, n, f) = (0.02, 400, [0.13, 0.0, 0.0]);
    for seed in [3, 4, 5] {
        let pulse = pulse_file(&d, f, sigma, n, seed);
        let v = json(&["thrust", "--samples", &pulse]);
        // full precision kept beside the new fields
        assert_eq!(field(&v, "samples"), n as f64);
        let mag = field(&v, "magnitude_n");
        let u = field(&v, "magnitude_n_uncertainty");
        assert!(
            se_right(u, sigma, n),
            "seed {seed}: magnitude se {u} vs sigma/sqrt(n) {}",
            sigma / (n as f64).sqrt()
        );
        assert!((mag - 0.13).abs() < 4.0 * u, "seed {seed}: {mag} ± {u}");
        // the direction's y component moves by the y noise over |f|
        let uy = v["direction_uncertainty"][1].as_f64().unwrap();
        assert!(
            se_right(uy * 0.13, sigma, n),
            "seed {seed}: direction y se {uy}"
        );
        // the text shows the same number to two digits
        let text = ok(&["characterize", "thrust", "--samples", &pulse]);
        let line = text.lines().find(|l| l.starts_with("magnitude_n")).unwrap();
        let shown: f64 = line
            .split(" ± ")
            .nth(1)
            .unwrap()
            .split(' ')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        assert!((shown / u - 1.0).abs() < 0.05, "{line} vs {u}");
        // planted faults: an uncertainty from the wrong n (the spread itself, n = 1; or the
        // spread over n instead of sqrt(n)) fails the same check
        let spread = u * (n as f64).sqrt();
        assert!(!se_right(spread, sigma, n));
        assert!(!se_right(spread / n as f64, sigma, n));
    }
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn products_standard_errors_follow_the_residual_variance_and_the_design() {
    // 36 angles with known noise: the reported standard errors are within 30 % of
    // sigma sqrt(diag((A'A)^-1)).
    let sigma = 1e-4;
    let (iyy, izz, pyz) = (0.0242, 0.0214, 3.1e-4);
    let mut g = Normal(7);
    let mut args = vec!["products".to_string()];
    let mut a = nalgebra::DMatrix::<f64>::zeros(36, 3);
    for k in 0..36 {
        let b = (k as f64 * 5.0).to_radians();
        let (sn, c) = b.sin_cos();
        a[(k, 0)] = c * c;
        a[(k, 1)] = sn * sn;
        a[(k, 2)] = -(2.0 * b).sin();
        let i = izz * sn * sn + iyy * c * c - pyz * (2.0 * b).sin() + g.sample(sigma);
        args.push("--measurement".into());
        args.push(format!("{}:{i}", k * 5));
    }
    let inv = (a.transpose() * &a).try_inverse().unwrap();
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let v = json(&args);
    for (k, name) in ["iyy", "izz", "pyz"].into_iter().enumerate() {
        let want = sigma * inv[(k, k)].sqrt();
        let got = field(&v, &format!("{name}_uncertainty"));
        assert!(
            (got / want - 1.0).abs() < 0.3,
            "{name}: reported {got}, sigma sqrt((A'A)^-1) {want}"
        );
    }
}

#[test]
fn the_stopwatch_error_is_the_seed_s() {
    // Seed 2.3.6: a 0.25 s stopwatch error over 20 oscillations in 42 s with l = 2.6 m moves
    // the inertia by 0.0007696 kg m^2.
    let v = json(&[
        "pendulum",
        "--length",
        "2.6",
        "--stopwatch",
        "42",
        "--oscillations",
        "20",
    ]);
    let u = field(&v, "inertia_uncertainty");
    assert!((u - 0.0007696).abs() < 5e-8, "{u}");
    assert_eq!(field(&v, "total_inertia_uncertainty"), u);
    let text = ok(&[
        "characterize",
        "pendulum",
        "--length",
        "2.6",
        "--stopwatch",
        "42",
        "--oscillations",
        "20",
        "--stopwatch-error",
        "0.5",
    ]);
    assert!(text.contains("0.5 s (--stopwatch-error)"), "{text}");
}

#[test]
fn the_digit_counter_counts() {
    let n = numbers("omega = 2.9919930034 ± 0.018 rad/s, sph2 z1_z0 eq. 2.14-2.15 7.1e-7 0.000120");
    let got: Vec<(&str, usize)> = n.iter().map(|(s, d)| (s.as_str(), *d)).collect();
    assert_eq!(
        got,
        [
            ("2.9919930034", 11),
            ("0.018", 2),
            ("2.14", 3),
            ("2.15", 3),
            ("7.1e-7", 2),
            ("0.000120", 3)
        ]
    );
}
