//! Numbers as the diagnosis contract writes them: JSON has no infinity, so a non-finite
//! uncertainty (an unbounded one, e.g. an unfired thruster's scale) is written as 1e9.

use serde_json::Value;

/// A number JSON can carry: non-finite uncertainties become 1e9 ("unbounded").
pub fn num(x: f64) -> Value {
    let x = if x.is_finite() { x } else { 1e9 };
    serde_json::Number::from_f64(x)
        .map(Value::Number)
        .unwrap_or(Value::Null)
}

/// A JSON array of numbers.
pub fn nums(xs: &[f64]) -> Value {
    Value::Array(xs.iter().map(|&x| num(x)).collect())
}
