//! Numbers for people: a value with its uncertainty, the uncertainty rounded to one or two
//! significant digits (two when they start with 1 or 2, so 0.013 keeps its second digit
//! and 0.034 becomes 0.03) and the value rounded to the same decimal place, in the units
//! of the contract's parameter names. The JSON keeps every digit; only text uses this.

use serde_json::Value;

use crate::output::EffectReport;

/// An uncertainty at or above this (in the parameter's own units), or not finite, says
/// "the data do not determine this parameter": the JSON carries such uncertainties as the
/// placeholder 1e9 (`output::num`), e.g. the scale of a thruster that never fired. No
/// parameter of the vocabulary has a real uncertainty near a million of its units.
pub const UNIDENTIFIABLE: f64 = 1e6;

/// Whether `se` is a placeholder for "unidentifiable" rather than an uncertainty.
pub fn unidentifiable(se: f64) -> bool {
    !se.is_finite() || se >= UNIDENTIFIABLE
}

/// `se` rounded to 1-2 significant digits: (rounded value, decimal place), where the
/// decimal place is the power of ten of its last digit, negated (0.03 -> 2, 12 -> 0,
/// 300 -> -2).
fn round_uncertainty(se: f64) -> (f64, i32) {
    let mut e = se.log10().floor() as i32;
    for _ in 0..2 {
        let lead = se / 10f64.powi(e);
        let sig = if lead < 3.0 { 2 } else { 1 };
        let d = sig - 1 - e;
        let r = round_at(se, d);
        // 0.0096 rounds to 0.010: a carry into the next decade, which then keeps two digits
        if r >= 10f64.powi(e + 1) * (1.0 - 1e-12) && r > 0.0 {
            e += 1;
            continue;
        }
        return (r, d);
    }
    let d = 1 - e;
    (round_at(se, d), d)
}

/// `x` rounded to the decimal place `d` (digits after the point; negative: tens, hundreds).
fn round_at(x: f64, d: i32) -> f64 {
    if d >= 0 {
        let f = 10f64.powi(d);
        (x * f).round() / f
    } else {
        let f = 10f64.powi(-d);
        (x / f).round() * f
    }
}

/// `x` with `d` digits after the point (none when `d` <= 0), without a "-0".
fn fixed(x: f64, d: i32) -> String {
    let s = format!("{:.*}", d.max(0) as usize, round_at(x, d));
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s
    }
}

/// A value alone, four significant digits (for parameters without an uncertainty).
pub fn value(v: f64) -> String {
    if !v.is_finite() {
        return "n/a".into();
    }
    if v == 0.0 {
        return "0".into();
    }
    let e = v.abs().log10().floor() as i32;
    if (-3..6).contains(&e) {
        fixed(v, 3 - e)
    } else {
        format!("{:.3}e{}", v / 10f64.powi(e), e)
    }
}

/// "6.07 ± 0.03": the uncertainty to 1-2 significant digits and the value to the same
/// decimal place; "(1.20 ± 0.03)e-5" when fixed notation would need many zeros;
/// "6.07 (unidentifiable)" when `se` is the placeholder.
pub fn value_pm(v: f64, se: f64) -> String {
    if !v.is_finite() {
        return "n/a".into();
    }
    if unidentifiable(se) {
        return format!("{} (unidentifiable)", value(v));
    }
    if se <= 0.0 {
        return format!("{} ± 0", value(v));
    }
    let (r, d) = round_uncertainty(se);
    let big = v.abs().max(r);
    if !(r.is_finite() && r > 0.0 && big.is_finite()) {
        // only for uncertainties near the smallest f64 (subnormal): no rounding to show
        return format!("{} ± {}", value(v), value(se));
    }
    // fixed notation unless it would need more than four leading zeros after the point
    if big < 1e6 && ((big >= 1e-3 && d <= 8) || d <= 5) {
        return format!("{} ± {}", fixed(v, d), fixed(r, d));
    }
    // scientific with one exponent for both: the mantissa of the larger has one digit
    // before the point
    let e = big.log10().floor() as i32;
    let s = 10f64.powi(e);
    format!("({} ± {})e{}", fixed(v / s, d + e), fixed(r / s, d + e), e)
}

/// The unit of a contract parameter, from its name.
pub fn unit(key: &str) -> &'static str {
    match key {
        "newton_per_extra_thruster" => "N",
        "counts" => "counts",
        "scale" | "damping_ratio" | "inertia_fraction" => "",
        k if k.ends_with("_rad_s") => "rad/s",
        k if k.ends_with("_kgm2") => "kg m^2",
        k if k.ends_with("_nm") => "N m",
        k if k.ends_with("_mm") => "mm",
        k if k.ends_with("_ms") => "ms",
        k if k.ends_with("_hz") => "Hz",
        k if k.ends_with("_s") => "s",
        _ => "",
    }
}

/// Labels of an array parameter's entries: thrusters 1..12, axes, inertia terms.
fn element_labels(key: &str, n: usize) -> Vec<String> {
    match (key, n) {
        ("inertia_kgm2", 6) => ["xx", "yy", "zz", "xy", "xz", "yz"]
            .iter()
            .map(|s| s.to_string())
            .collect(),
        (_, 3) => ["x", "y", "z"].iter().map(|s| s.to_string()).collect(),
        (_, 12) => (1..=12).map(|i| format!("thruster {i}")).collect(),
        _ => (1..=n).map(|i| format!("{i}")).collect(),
    }
}

/// One parameter of an effect, ready to print.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamText {
    pub name: String,
    pub unit: &'static str,
    /// (entry label, value ± uncertainty); one unlabelled entry for a scalar.
    pub entries: Vec<(String, String)>,
}

impl ParamText {
    /// "open_ms = 6.07 ± 0.03 ms", "offset_mm (mm): x 1.52 ± 0.03, y ..."
    pub fn line(&self) -> String {
        if self.entries.len() == 1 && self.entries[0].0.is_empty() {
            let u = if self.unit.is_empty() {
                String::new()
            } else {
                format!(" {}", self.unit)
            };
            return format!("{} = {}{u}", self.name, self.entries[0].1);
        }
        let u = if self.unit.is_empty() {
            String::new()
        } else {
            format!(" ({})", self.unit)
        };
        let list: Vec<String> = self
            .entries
            .iter()
            .map(|(l, v)| format!("{l} {v}"))
            .collect();
        format!("{}{u}: {}", self.name, list.join(", "))
    }
}

/// The parameters of a reported effect with their uncertainties, for text and HTML. A
/// thruster that never fired prints as "not fired", an entry held at the model's value
/// (the extra key `held`) as "held at the model's", any other placeholder uncertainty as
/// "unidentifiable".
pub fn effect_params(e: &EffectReport) -> Vec<ParamText> {
    let thrust_scale = e.effect == "thrust_scale";
    e.params
        .iter()
        .map(|(k, v)| {
            let se = e.stderr.get(k);
            let held = |i: usize| {
                e.held
                    .get(k)
                    .and_then(Value::as_array)
                    .is_some_and(|ix| ix.iter().any(|j| j.as_u64() == Some(i as u64)))
            };
            let one = |v: Option<f64>, s: Option<f64>| -> String {
                let v = v.unwrap_or(f64::NAN);
                match s {
                    Some(s) if thrust_scale && k == "scale" && unidentifiable(s) => {
                        "not fired".into()
                    }
                    Some(s) => value_pm(v, s),
                    None => value(v),
                }
            };
            let entries = match v {
                Value::Array(xs) => {
                    let ses: Vec<Option<f64>> = match se {
                        Some(Value::Array(s)) => (0..xs.len())
                            .map(|i| s.get(i).and_then(Value::as_f64))
                            .collect(),
                        _ => vec![None; xs.len()],
                    };
                    element_labels(k, xs.len())
                        .into_iter()
                        .zip(xs.iter().zip(ses))
                        .enumerate()
                        .map(|(i, (l, (x, s)))| match x {
                            _ if held(i) => (
                                l,
                                format!(
                                    "{} (held at the model's)",
                                    value(x.as_f64().unwrap_or(f64::NAN))
                                ),
                            ),
                            // a row of a matrix (a thruster's direction): its numbers
                            Value::Array(row) => (
                                l,
                                format!(
                                    "({})",
                                    row.iter()
                                        .map(|y| sig(y.as_f64().unwrap_or(f64::NAN), 4))
                                        .collect::<Vec<_>>()
                                        .join(" ")
                                ),
                            ),
                            // a list of thruster numbers (no uncertainty)
                            Value::Number(n) if s.is_none() && n.is_u64() => {
                                (String::new(), n.to_string())
                            }
                            _ => (l, one(x.as_f64(), s)),
                        })
                        .collect()
                }
                _ => vec![(String::new(), one(v.as_f64(), se.and_then(Value::as_f64)))],
            };
            ParamText {
                name: k.clone(),
                unit: unit(k),
                entries,
            }
        })
        .collect()
}

/// Three rates (rad/s) to three significant digits: "0.00287 0.00172 0.00157".
pub fn rates(v: [f64; 3]) -> String {
    v.iter().map(|&x| sig(x, 3)).collect::<Vec<_>>().join(" ")
}

/// `x` to `n` significant digits in fixed notation (scientific below 1e-6 or from 1e6).
pub fn sig(x: f64, n: i32) -> String {
    if !x.is_finite() {
        return "n/a".into();
    }
    if x == 0.0 {
        return "0".into();
    }
    let e = x.abs().log10().floor() as i32;
    if (-6..6).contains(&e) {
        fixed(x, n - 1 - e)
    } else {
        format!("{:.*}e{}", (n - 1).max(0) as usize, x / 10f64.powi(e), e)
    }
}

/// A time window in ms of the recording as seconds: "12.300-12.320 s".
pub fn window(w: [i64; 2]) -> String {
    let d = if w[1] - w[0] < 1000 { 3 } else { 1 };
    format!(
        "{:.*}-{:.*} s",
        d,
        w[0] as f64 * 1e-3,
        d,
        w[1] as f64 * 1e-3
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn uncertainty_one_or_two_digits_value_to_the_same_place() {
        assert_eq!(value_pm(6.0712345, 0.0312), "6.07 ± 0.03");
        assert_eq!(value_pm(6.0712345, 0.0134), "6.071 ± 0.013");
        assert_eq!(value_pm(6.0712345, 0.25), "6.07 ± 0.25");
        assert_eq!(value_pm(6.0712345, 0.67), "6.1 ± 0.7");
        assert_eq!(
            value_pm(14.613512815660512, 0.009313285586738655),
            "14.614 ± 0.009"
        );
        // carry into the next decade keeps two digits
        assert_eq!(value_pm(2.0, 0.0096), "2.000 ± 0.010");
        assert_eq!(value_pm(1234.5, 340.0), "1200 ± 300");
        assert_eq!(value_pm(-129.4, 12.3), "-129 ± 12");
        assert_eq!(value_pm(-0.0004, 0.03), "0.00 ± 0.03");
    }

    #[test]
    fn small_and_large_magnitudes() {
        // inertia: fixed notation stays readable
        assert_eq!(
            value_pm(0.025986416435103736, 2.433326786925074e-6),
            "0.0259864 ± 0.0000024"
        );
        // products of inertia and torques: one shared exponent
        assert_eq!(
            value_pm(-0.00021788815996758, 5.972458260170613e-7),
            "(-2.179 ± 0.006)e-4"
        );
        assert_eq!(value_pm(1.2e-5, 3.1e-7), "(1.20 ± 0.03)e-5");
        assert_eq!(value_pm(0.0, 0.0), "0 ± 0");
        assert_eq!(value(1e-9), "1.000e-9");
        // no panic at the ends of the f64 range
        for (v, se) in [
            (0.0, 5e-324),
            (1e300, 1e-300),
            (-1e-300, 1e5),
            (0.0, 1e-320),
        ] {
            assert!(!value_pm(v, se).is_empty());
        }
        // p08's dead thruster
        assert_eq!(value_pm(0.00033, 0.00013), "0.00033 ± 0.00013");
    }

    /// A report of `effect` with these `params`, `stderr` and `held` objects (JSON), the
    /// rest empty: what the printing tests read.
    fn report(effect: &str, params: Value, stderr: Value, held: Value) -> EffectReport {
        let object = |v: Value| v.as_object().cloned().unwrap_or_default();
        EffectReport {
            effect: effect.into(),
            params: object(params),
            stderr: object(stderr),
            evidence: String::new(),
            windows_ms: vec![],
            rms_after: [0.0; 3],
            equivalent_to: vec![],
            held: object(held),
            delta_bic: 0.0,
        }
    }

    #[test]
    fn placeholders_are_words_not_numbers() {
        assert_eq!(value_pm(1.0, 1e9), "1.000 (unidentifiable)");
        assert_eq!(value_pm(1.0, f64::INFINITY), "1.000 (unidentifiable)");
        let e = report(
            "thrust_scale",
            json!({"scale": [0.98, 1.0]}),
            json!({"scale": [0.0123, 1e9]}),
            json!({}),
        );
        let p = effect_params(&e);
        assert_eq!(p[0].entries[1].1, "not fired");
        let line = p[0].line();
        assert_eq!(line, "scale: 1 0.980 ± 0.012, 2 not fired");
        assert!(!line.contains("1000000000"), "{line}");
    }

    /// An inertia whose products are held at the model's prints them as held, not as
    /// "unidentifiable" (their JSON error is the same placeholder); the moments keep their
    /// errors. Planted: the same report without the `held` key says "unidentifiable".
    #[test]
    fn held_entries_say_held_and_the_rest_keep_their_errors() {
        let with = |held: Value| {
            report(
                "inertia",
                json!({"inertia_kgm2": [0.0266, 0.0214, 0.0194, 0.000108, 0.000157, 1.23e-5]}),
                json!({"inertia_kgm2": [0.00012, 0.0001, 0.0001, 1e9, 1e9, 1e9]}),
                held,
            )
        };
        let line = effect_params(&with(json!({"inertia_kgm2": [3, 4, 5]})))[0].line();
        assert_eq!(
            line,
            "inertia_kgm2 (kg m^2): xx 0.02660 ± 0.00012, yy 0.02140 ± 0.00010, \
             zz 0.01940 ± 0.00010, xy 1.080e-4 (held at the model's), \
             xz 1.570e-4 (held at the model's), yz 1.230e-5 (held at the model's)"
        );
        let planted = effect_params(&with(json!({})))[0].line();
        assert!(
            planted.contains("xy 1.080e-4 (unidentifiable)"),
            "{planted}"
        );
    }

    /// Planted fault: printing the stored f64 (what the summary did before) fails both the
    /// digit count and the placeholder checks this module exists for.
    #[test]
    fn planted_fault_full_digits_would_fail() {
        let printed_before = format!("{} +/- {}", 14.613512815660512, 0.009313285586738655);
        let now = value_pm(14.613512815660512, 0.009313285586738655);
        let digits = |s: &str| s.chars().filter(|c| c.is_ascii_digit()).count();
        assert!(digits(&printed_before) > 20);
        assert_eq!(now, "14.614 ± 0.009");
        assert!(digits(&now) < 10, "{now}");
        assert!(format!("{}", 1e9f64).contains("1000000000"));
        assert!(!value_pm(1.0, 1e9).contains("1000000000"));
    }

    #[test]
    fn units_from_the_contract_names() {
        assert_eq!(unit("open_ms"), "ms");
        assert_eq!(unit("start_s"), "s");
        assert_eq!(unit("tau_s"), "s");
        assert_eq!(unit("offset_mm"), "mm");
        assert_eq!(unit("inertia_kgm2"), "kg m^2");
        assert_eq!(unit("torque_nm"), "N m");
        assert_eq!(unit("freq_hz"), "Hz");
        assert_eq!(unit("amplitude_rad_s"), "rad/s");
        assert_eq!(unit("newton_per_extra_thruster"), "N");
        assert_eq!(unit("scale"), "");
        let e = report(
            "thruster_latency",
            json!({"open_ms": 6.0712, "close_ms": 5.8}),
            json!({"open_ms": 0.0312, "close_ms": 0.4}),
            json!({}),
        );
        let lines: Vec<String> = effect_params(&e).iter().map(ParamText::line).collect();
        assert!(
            lines.contains(&"open_ms = 6.07 ± 0.03 ms".to_string()),
            "{lines:?}"
        );
        assert!(
            lines.contains(&"close_ms = 5.8 ± 0.4 ms".to_string()),
            "{lines:?}"
        );
    }

    #[test]
    fn rates_and_windows() {
        assert_eq!(
            rates([0.00287123, 0.0017, 0.0156789]),
            "0.00287 0.00170 0.0157"
        );
        assert_eq!(window([12300, 12320]), "12.300-12.320 s");
        assert_eq!(window([40000, 41000]), "40.0-41.0 s");
    }
}
