//! Compares the host run with a QEMU run, line by line.
//!
//! Lines starting with `info ` state facts of the target (e.g. the state size, which depends
//! on the alignment of 64-bit fields) and are skipped. Lines of the fixed kernel (and `#`
//! lines) must be identical. Lines of the `f32` kernel
//! must have the same words, except that 8-hex-digit words (the raw bits of an `f32`) may
//! differ by at most `MAX_ULP` units in the last place (default 0: both sides are IEEE-754
//! binary32 with the same operation order, so equality is expected; a larger budget can be
//! passed explicitly and the largest difference seen is always printed).
use std::fs;

/// Distance in units in the last place between two `f32` bit patterns (monotonic mapping).
pub fn ulp_distance(a: u32, b: u32) -> u64 {
    fn ordered(bits: u32) -> i64 {
        let i = i64::from(bits as i32);
        if i < 0 {
            i64::from(i32::MIN) - i
        } else {
            i
        }
    }
    ordered(a).abs_diff(ordered(b))
}

fn hex_word(w: &str) -> Option<u32> {
    if w.len() == 8 && w.bytes().all(|b| b.is_ascii_hexdigit()) {
        u32::from_str_radix(w, 16).ok()
    } else {
        None
    }
}

/// Result of a comparison.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct Outcome {
    /// Lines compared.
    pub lines: usize,
    /// Largest `f32` difference seen, ULP.
    pub max_ulp: u64,
    /// Problems (empty when equal within the budget).
    pub errors: Vec<String>,
}

/// Compares two outputs.
pub fn compare_text(host: &str, qemu: &str, max_ulp: u64) -> Outcome {
    let mut out = Outcome::default();
    let keep = |l: &&str| !l.starts_with("info ");
    let (h, q): (Vec<&str>, Vec<&str>) = (host.lines().filter(keep).collect(), qemu.lines().filter(keep).collect());
    if h.len() != q.len() {
        out.errors.push(format!("host has {} lines, QEMU has {}", h.len(), q.len()));
    }
    for (n, (a, b)) in h.iter().zip(q.iter()).enumerate() {
        out.lines += 1;
        let line = n + 1;
        if a == b {
            continue;
        }
        if !(a.starts_with("f32 ") && b.starts_with("f32 ")) {
            out.errors.push(format!("line {line} differs:\n  host: {a}\n  qemu: {b}"));
            continue;
        }
        let (wa, wb): (Vec<&str>, Vec<&str>) = (a.split(' ').collect(), b.split(' ').collect());
        if wa.len() != wb.len() {
            out.errors.push(format!("line {line} differs in shape:\n  host: {a}\n  qemu: {b}"));
            continue;
        }
        for (x, y) in wa.iter().zip(wb.iter()) {
            if x == y {
                continue;
            }
            match (hex_word(x), hex_word(y)) {
                (Some(u), Some(v)) => {
                    let d = ulp_distance(u, v);
                    out.max_ulp = out.max_ulp.max(d);
                    if d > max_ulp {
                        out.errors.push(format!("line {line}: f32 {x} vs {y} differ by {d} ULP (budget {max_ulp})"));
                    }
                }
                _ => out.errors.push(format!("line {line}: word {x:?} vs {y:?}:\n  host: {a}\n  qemu: {b}")),
            }
        }
    }
    out
}

pub fn main(args: &[String]) -> Result<(), String> {
    let (Some(host), Some(qemu)) = (args.first(), args.get(1)) else {
        return Err("usage: compare HOST.txt QEMU.txt [MAX_ULP]".into());
    };
    let max_ulp = match args.get(2) {
        Some(s) => s.parse::<u64>().map_err(|_| format!("MAX_ULP {s:?} is not an integer"))?,
        None => 0,
    };
    let read = |p: &String| fs::read_to_string(p).map_err(|e| format!("{p}: {e}"));
    let (h, q) = (read(host)?, read(qemu)?);
    if !q.lines().any(|l| l == "# done") {
        return Err(format!("{qemu}: the QEMU run did not finish (no '# done' line)"));
    }
    let o = compare_text(&h, &q, max_ulp);
    for e in o.errors.iter().take(20) {
        eprintln!("{e}");
    }
    if o.errors.is_empty() {
        println!("{qemu}: {} lines equal to the host's (fixed bit for bit; f32 max difference {} ULP, budget {max_ulp})", o.lines, o.max_ulp);
        Ok(())
    } else {
        Err(format!("{qemu}: {} differences from {host}", o.errors.len()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ulp_distance_crosses_zero_and_counts_steps() {
        assert_eq!(ulp_distance(1.0f32.to_bits(), 1.0f32.to_bits()), 0);
        let next = f32::from_bits(1.0f32.to_bits() + 1);
        assert_eq!(ulp_distance(1.0f32.to_bits(), next.to_bits()), 1);
        // +0 and -0 are the same point; the smallest subnormals on each side are 2 apart.
        assert_eq!(ulp_distance(0.0f32.to_bits(), (-0.0f32).to_bits()), 0);
        assert_eq!(ulp_distance(f32::from_bits(1).to_bits(), (-f32::from_bits(1)).to_bits()), 2);
    }

    #[test]
    fn fixed_lines_must_be_identical_and_f32_within_budget() {
        let host = "fixed t=1 com 00000001\nf32 t=1 com 3f800000\n";
        let off_fixed = "fixed t=1 com 00000002\nf32 t=1 com 3f800000\n";
        assert_eq!(compare_text(host, off_fixed, 10).errors.len(), 1);
        let off_f32 = "fixed t=1 com 00000001\nf32 t=1 com 3f800002\n";
        assert_eq!(compare_text(host, off_f32, 1).errors.len(), 1);
        let o = compare_text(host, off_f32, 2);
        assert!(o.errors.is_empty());
        assert_eq!(o.max_ulp, 2);
        assert_eq!(compare_text(host, "fixed t=1 com 00000001\n", 0).errors.len(), 1);
    }
}
