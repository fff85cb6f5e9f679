//! Planar identification on the real air-bearing flight
//! (`shared/data/real/airbearing-mpc/real_test_data.csv`): fit the first half, predict the
//! second, with command delay 0 and 40 ms, against the authors' nominal model.
//! `cargo run --release -p reference-f64 --example planar_real -- [FILE.csv]`
//!
//! The CSV is read by a minimal hand parser (quoted fields may hold commas); only
//! `Control_Time` (s), `Current_Angular_Vel` (rad/s) and `Command_Vector` are used.
use reference_f64::planar_id::{
    identify, interval_residuals, predict, PlanarModel, PlanarOptions, PlanarParams, PlanarThruster,
};

const DEFAULT: &str = "/work/shared/data/real/airbearing-mpc/real_test_data.csv";

/// Split one CSV line, honouring double quotes.
fn fields(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    for ch in line.chars() {
        match ch {
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(std::mem::take(&mut cur)),
            c => cur.push(c),
        }
    }
    out.push(cur);
    out
}

/// `"[1, 0, 1, 0, 1, 0, 1, 0]"` -> bit i = thruster i+1.
fn word(s: &str) -> Option<u16> {
    let inner = s.trim().strip_prefix('[')?.strip_suffix(']')?;
    let mut w = 0u16;
    for (i, v) in inner.split(',').enumerate() {
        match v.trim() {
            "1" => w |= 1 << i,
            "0" => {}
            _ => return None,
        }
    }
    Some(w)
}

fn read(path: &str) -> Result<(Vec<u64>, Vec<f64>, Vec<u16>), String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
    let mut lines = text.lines();
    let header = fields(lines.next().ok_or(format!("{path}: empty"))?);
    let col = |name: &str| {
        header
            .iter()
            .position(|h| h.trim() == name)
            .ok_or(format!("{path}: no column {name}"))
    };
    let (ct, cw, cc) = (
        col("Control_Time")?,
        col("Current_Angular_Vel")?,
        col("Command_Vector")?,
    );
    let (mut t, mut w, mut c) = (Vec::new(), Vec::new(), Vec::new());
    for (n, line) in lines.enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let f = fields(line);
        let get = |i: usize| f.get(i).map(String::as_str).unwrap_or("");
        let bad = |what: &str| format!("{path}:{}: bad {what}", n + 2);
        let time: f64 = get(ct).trim().parse().map_err(|_| bad("Control_Time"))?;
        if !(time.is_finite() && time >= 0.0) {
            return Err(bad("Control_Time"));
        }
        t.push((time * 1000.0).round() as u64);
        // A missing rate is NaN (the identification skips it).
        w.push(get(cw).trim().parse().unwrap_or(f64::NAN));
        c.push(word(get(cc)).ok_or_else(|| bad("Command_Vector"))?);
    }
    Ok((t, w, c))
}

/// The authors' nominal model (README beside the data).
fn model() -> PlanarModel {
    let table: [([f64; 2], [f64; 2], f64); 8] = [
        ([0.145, 0.06], [-1.0, 0.0], 0.441450),
        ([0.145, -0.06], [-1.0, 0.0], 0.430659),
        ([0.06, -0.145], [0.0, 1.0], 0.427716),
        ([-0.06, -0.145], [0.0, 1.0], 0.438017),
        ([-0.145, -0.06], [1.0, 0.0], 0.468918),
        ([-0.145, 0.06], [1.0, 0.0], 0.446846),
        ([-0.06, 0.145], [0.0, -1.0], 0.466956),
        ([0.06, 0.145], [0.0, -1.0], 0.484124),
    ];
    PlanarModel {
        thrusters: table
            .iter()
            .map(|&(pos_m, dir, force_n)| PlanarThruster {
                pos_m,
                dir,
                force_n,
            })
            .collect(),
        izz_kgm2: 0.3237,
        com_m: [0.0, 0.0],
    }
}

fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for x in v.filter(|x| x.is_finite()) {
        s += x * x;
        n += 1;
    }
    (s / n.max(1) as f64).sqrt()
}

fn opt(v: Option<f64>, s: Option<f64>, scale: f64) -> String {
    match (v, s) {
        (Some(v), Some(s)) => format!("{:+.4} +- {:.4}", v * scale, s * scale),
        _ => "unobservable/not fitted".into(),
    }
}

fn main() {
    let path = std::env::args().nth(1).unwrap_or(DEFAULT.into());
    let (t, w, c) = match read(&path) {
        Ok(v) => v,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    };
    let m = model();
    let half = t.len() / 2;
    println!(
        "{path}: {} samples, {:.1} s; fit on 0..{half}, held out {half}..{}",
        t.len(),
        t.last().copied().unwrap_or(0) as f64 / 1000.0,
        t.len()
    );
    for delay_ms in [0.0, 40.0] {
        let opts = PlanarOptions {
            delay_ms,
            ..PlanarOptions::default()
        };
        println!("\n== delay {delay_ms} ms ==");
        let nominal = PlanarParams::nominal(&m);
        // The held-out half starts with the last fitted sample so its first command is known.
        let (ht, hw, hc) = (&t[half - 1..], &w[half - 1..], &c[half - 1..]);
        let report = |name: &str, p: &PlanarParams| {
            let one = interval_residuals(&m, p, &opts, ht, hw, hc).unwrap_or_default();
            // Open-loop rate simulation restarted from the measured rate every 1 s (16 samples)
            // of the held-out half, so drift does not swamp the comparison.
            let mut sim_err = Vec::new();
            let mut k = 0;
            while k + 2 < ht.len() {
                let end = (k + 17).min(ht.len());
                if let Ok(s) = predict(&m, p, &opts, &ht[k..end], &hc[k..end], hw[k]) {
                    sim_err.extend(s.iter().zip(&hw[k..end]).skip(1).map(|(a, b)| a - b));
                }
                k = end - 1;
            }
            println!(
                "  held-out {name:>7}: one-interval residual RMS {:.5} rad/s, 1-s simulation RMS {:.5} rad/s",
                rms(one.into_iter()),
                rms(sim_err.into_iter())
            );
        };
        match identify(&m, &t[..half], &w[..half], &c[..half], &opts) {
            Ok(e) => {
                println!(
                    "  Izz {:.4} +- {:.4} kg m^2 (model 0.3237); status {:?}; unobservable {:?}",
                    e.izz_kgm2, e.izz_stderr, e.status, e.unobservable
                );
                println!(
                    "  CoM offset x {} mm, y {} mm",
                    opt(e.com_offset_m[0], e.com_stderr_m[0], 1000.0),
                    opt(e.com_offset_m[1], e.com_stderr_m[1], 1000.0)
                );
                println!(
                    "  damping {} N m s/rad; disturbance {} mN m",
                    opt(e.damping_nms, e.damping_stderr, 1.0),
                    opt(e.disturbance_nm, e.disturbance_stderr, 1000.0)
                );
                println!(
                    "  fit: {} intervals, residual RMS {:.5} rad/s, bandwidth {}, condition {:.1}",
                    e.intervals_used, e.residual_rms_rad_s, e.hac_bandwidth, e.condition_number
                );
                report("nominal", &nominal);
                report("fitted", &e.params());
            }
            Err(err) => {
                println!("  no estimate: {err} (status {})", err.status());
                report("nominal", &nominal);
            }
        }
    }
}
