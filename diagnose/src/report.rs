//! Reports for people: a terminal summary, and an HTML page with SVG plots (residual
//! before and after on one scale, measured vs nominal vs fitted rates at every located
//! window, where the mismatch concentrates, the post-edge spectrum with the apparent tone
//! and its possible true frequencies marked). Parameters are printed with their
//! uncertainty rounded to 1-2 digits (`numfmt`); the JSON keeps every digit.

use std::fmt::Write as _;
use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::diagnosis::Analysis;
use crate::numfmt::{self, ParamText};
use crate::series::Series;

/// Array parameters with more than six entries (thrust scales) are printed this many
/// entries per line.
const ENTRIES_PER_LINE: usize = 4;

fn param_lines(p: &ParamText) -> Vec<String> {
    if p.entries.len() <= 6 {
        return vec![p.line()];
    }
    let u = if p.unit.is_empty() {
        String::new()
    } else {
        format!(" ({})", p.unit)
    };
    let mut out = vec![format!("{}{u}:", p.name)];
    for chunk in p.entries.chunks(ENTRIES_PER_LINE) {
        let list: Vec<String> = chunk.iter().map(|(l, v)| format!("{l} {v}")).collect();
        out.push(format!("  {}", list.join(", ")));
    }
    out
}

/// A sample rate: "100", "1000", "333.3".
fn hz(x: f64) -> String {
    if (x - x.round()).abs() < 1e-6 {
        format!("{:.0}", x)
    } else {
        numfmt::sig(x, 4)
    }
}

/// The equivalent effects of `e` in one line: `measurement_delay (delay_ms 6.05)`.
fn equivalents_text(e: &crate::output::EffectReport) -> String {
    e.equivalent_to
        .iter()
        .map(|v| {
            let params = v["params"]
                .as_object()
                .map(|m| {
                    m.iter()
                        .map(|(k, x)| format!("{k} {}", short(x)))
                        .collect::<Vec<_>>()
                        .join(", ")
                })
                .unwrap_or_default();
            format!("{} ({params})", v["effect"].as_str().unwrap_or("?"))
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// A JSON number or array of numbers with 4 significant digits.
fn short(x: &serde_json::Value) -> String {
    match x {
        serde_json::Value::Array(a) => {
            let v: Vec<String> = a.iter().map(short).collect();
            format!("[{}]", v.join(" "))
        }
        serde_json::Value::Number(n) => n
            .as_f64()
            .map(|f| {
                let digits = if f == 0.0 {
                    0
                } else {
                    (3 - f.abs().log10().floor() as i32).clamp(0, 12) as usize
                };
                format!("{f:.digits$}")
            })
            .unwrap_or_default(),
        other => other.to_string(),
    }
}

fn windows_text(w: &[[i64; 2]]) -> String {
    if w.is_empty() {
        return "none".into();
    }
    w.iter()
        .map(|&w| numfmt::window(w))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Terminal summary of a fit-then-predict check (`holdout.rs`).
pub fn holdout_summary(h: &crate::holdout::Holdout) -> String {
    let names: Vec<&str> = h.analysis.fitted.iter().map(|(k, _)| k.name()).collect();
    let shown = measured_axes(&h.analysis.series);
    let f = |v: [f64; 3]| rates_on(v, &shown);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "held-out check: diagnosed the first {} samples (to {:.3} s), predicted the other {}",
        h.fitted_samples,
        h.split_ms * 1e-3,
        h.held_out_samples
    );
    let _ = writeln!(
        s,
        "     effects named on the fitted part: {}",
        if names.is_empty() {
            "none".to_string()
        } else {
            names.join(", ")
        }
    );
    let _ = writeln!(
        s,
        "     held-out residual RMS, nominal model (rad/s, x y z): {}",
        f(h.rms_nominal)
    );
    let _ = writeln!(
        s,
        "     held-out residual RMS, fitted model  (rad/s, x y z): {}",
        f(h.rms_fitted)
    );
    s
}

/// Terminal summary.
pub fn summary(a: &Analysis) -> String {
    let o = &a.output;
    let shown = measured_axes(&a.series);
    let f = |v: [f64; 3]| rates_on(v, &shown);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "recording {} ({} samples, {} Hz) against model {}",
        o.recording,
        o.samples,
        hz(a.series.sample_rate_hz),
        o.model
    );
    let _ = writeln!(
        s,
        "data issues: {} gaps, {} missing samples, {} duplicates, {} saturated",
        o.data_issues.gaps,
        o.data_issues.missing_samples,
        o.data_issues.duplicates,
        o.data_issues.saturated
    );
    let r = o.data_issues.railed;
    if r.iter().any(|&x| x > 0) {
        let _ = writeln!(s, "masked gyro samples (rail or stuck), x y z: {} {} {} (left out of every fit and statistic)", r[0], r[1], r[2]);
    }
    for w in &a.series.warnings {
        let _ = writeln!(s, "warning: {w}");
    }
    let _ = writeln!(
        s,
        "noise (per sample, rad/s, x y z): {}",
        f(a.noise.var.map(f64::sqrt))
    );
    if let Some((_, what)) = a.response.name() {
        let _ = writeln!(s, "rate sensor: {what}");
    }
    let _ = writeln!(
        s,
        "residual RMS before (rad/s, x y z): {}",
        f(o.residual_rms_before)
    );
    if o.effects.is_empty() {
        let _ = writeln!(s, "no effect named: no mechanism of the vocabulary improves the nominal model's prediction in a way that generalises");
    }
    for (i, e) in o.effects.iter().enumerate() {
        let _ = writeln!(s, "{}. {}  (delta BIC {:.0})", i + 1, e.effect, e.delta_bic);
        for p in numfmt::effect_params(e) {
            for l in param_lines(&p) {
                let _ = writeln!(s, "     {l}");
            }
        }
        let _ = writeln!(s, "     why: {}", e.evidence);
        if !e.equivalent_to.is_empty() {
            let _ = writeln!(s, "     same rates as: {}", equivalents_text(e));
        }
        let _ = writeln!(s, "     where: {}", windows_text(&e.windows_ms));
        let _ = writeln!(s, "     residual RMS after (rad/s): {}", f(e.rms_after));
    }
    for r in &a.rejections {
        let _ = writeln!(
            s,
            "not named (round {}): {} (delta BIC {:.0}): {}",
            r.round + 1,
            r.effect,
            r.delta_bic,
            r.reason
        );
    }
    let _ = writeln!(
        s,
        "residual RMS after (rad/s, x y z): {}",
        f(o.residual_rms_after)
    );
    match &o.unexplained {
        Some(u) => {
            let _ = writeln!(s, "UNEXPLAINED: {}", u.note);
            let _ = writeln!(
                s,
                "     residual RMS {} against noise {} rad/s; Ljung-Box {:.0} {:.0} {:.0}; where: {}",
                f(u.rms),
                f(u.noise_rms),
                u.ljung_box[0],
                u.ljung_box[1],
                u.ljung_box[2],
                windows_text(&u.windows_ms)
            );
        }
        None => {
            let _ = writeln!(s, "nothing unexplained: the residual after the named effects is at the noise and white");
        }
    }
    let lb = |t: &crate::stats::ResidualTests| {
        format!(
            "Ljung-Box Q {:.0} {:.0} {:.0}, input cross-corr z {:.1} {:.1} {:.1}",
            t.ljung_box_q[0],
            t.ljung_box_q[1],
            t.ljung_box_q[2],
            t.input_xcorr_z[0],
            t.input_xcorr_z[1],
            t.input_xcorr_z[2]
        )
    };
    let _ = writeln!(
        s,
        "residual tests (Ljung-Box Q over {} lags of 50 ms block means: white below {:.0}, the chi-square 99.9 % quantile):",
        crate::stats::LJUNG_BOX_LAGS,
        crate::stats::WHITE_BELOW
    );
    let _ = writeln!(s, "residual tests before: {}", lb(&a.tests_before));
    let _ = writeln!(s, "residual tests after:  {}", lb(&a.tests_after));
    s
}

const AXES: [&str; 3] = ["x", "y", "z"];

/// Three per-axis rates, "-" for an axis the recording does not measure.
fn rates_on(v: [f64; 3], shown: &[usize]) -> String {
    (0..3)
        .map(|a| {
            if shown.contains(&a) {
                numfmt::sig(v[a], 3)
            } else {
                "-".into()
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// The axes with at least one usable sample (all three when none has): a planar craft's
/// recording measures z only, and empty x and y panels would only take room.
fn measured_axes(series: &Series) -> Vec<usize> {
    let shown: Vec<usize> = (0..3)
        .filter(|&a| series.valid.iter().any(|v| v[a]))
        .collect();
    if shown.is_empty() {
        vec![0, 1, 2]
    } else {
        shown
    }
}
const MEASURED: RGBColor = RGBColor(90, 90, 90);
const NOMINAL: RGBColor = RGBColor(40, 90, 220);
const FITTED: RGBColor = RGBColor(220, 60, 20);
const WINDOW_FILL: RGBColor = RGBColor(255, 236, 170);
const SIGNIFICANCE: RGBColor = RGBColor(0, 140, 90);
/// Thruster activity bars under the rates (one row per thruster that fires in view).
const VALVE_ON: RGBColor = RGBColor(60, 60, 60);
/// Where the model's rate is re-fitted (a `--horizon` stretch or a telemetry gap starts).
const REFIT: RGBColor = RGBColor(20, 150, 150);

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;

/// A title on the left and a legend (coloured line, label) on the right of a strip.
fn title_strip(area: &Area, title: &str, items: &[(&str, RGBColor, u32)]) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<_>| x.to_string();
    area.draw(&Text::new(
        title.to_string(),
        (10, 6),
        ("sans-serif", 16).into_font(),
    ))
    .map_err(e)?;
    let (w, _) = area.dim_in_pixel();
    let mut x = w as i32 - 10 - items.iter().map(|i| 40 + 8 * i.0.len() as i32).sum::<i32>();
    for (label, color, width) in items {
        area.draw(&PathElement::new(
            vec![(x, 14), (x + 26, 14)],
            color.stroke_width(*width),
        ))
        .map_err(e)?;
        area.draw(&Text::new(
            label.to_string(),
            (x + 30, 6),
            ("sans-serif", 14).into_font(),
        ))
        .map_err(e)?;
        x += 40 + 8 * label.len() as i32;
    }
    Ok(())
}

/// Real time (s) of every sample.
fn times_s(series: &Series) -> Vec<f64> {
    series
        .t_ms
        .iter()
        .map(|&t| series.real_ms(t as f64) * 1e-3)
        .collect()
}

/// Largest |residual| over the usable samples of both residuals: one y scale for the
/// before and after plots.
fn residual_limit(series: &Series, rs: &[&[[f64; 3]]]) -> f64 {
    let mut lim = 1e-6f64;
    for r in rs {
        for (x, v) in r.iter().zip(&series.valid) {
            for a in 0..3 {
                if v[a] {
                    lim = lim.max(x[a].abs());
                }
            }
        }
    }
    lim * 1.05
}

/// The residual of the nominal model and after the named effects, one row per axis, all on
/// one y scale (`lim`), in the colours of the window panels' models.
fn residual_svg(
    series: &Series,
    t: &[f64],
    before: &[[f64; 3]],
    after: &[[f64; 3]],
    lim: f64,
) -> Result<String, String> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (900, 520)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let (top, body) = root.split_vertically(28);
        title_strip(
            &top,
            "residual (measured minus model), one scale",
            &[
                ("nominal model", NOMINAL, 2),
                ("after the named effects", FITTED, 2),
            ],
        )?;
        let t0 = t.first().copied().unwrap_or(0.0);
        let t1 = t.last().copied().unwrap_or(0.0).max(t0 + 1e-3);
        let step = (before.len() / 3000).max(1);
        let shown = measured_axes(series);
        let rows = body.split_evenly((shown.len(), 1));
        for (row, (&ax, area)) in shown.iter().zip(rows.iter()).enumerate() {
            let last = row + 1 == shown.len();
            let mut chart = ChartBuilder::on(area)
                .margin_left(8)
                .margin_right(12)
                .margin_top(6)
                .x_label_area_size(if last { 34 } else { 18 })
                .y_label_area_size(72)
                .build_cartesian_2d(t0..t1, -lim..lim)
                .map_err(|e| e.to_string())?;
            let fmt_y = |y: &f64| tick(y, 2.0 * lim);
            let ydesc = format!("{} (rad/s)", AXES[ax]);
            let mut mesh = chart.configure_mesh();
            mesh.disable_mesh()
                .y_label_formatter(&fmt_y)
                .y_desc(ydesc.as_str())
                .y_labels(5);
            if last {
                mesh.x_desc("time (s)");
            }
            mesh.draw().map_err(|e| e.to_string())?;
            for (r, color) in [(before, NOMINAL), (after, FITTED)] {
                let pts: Vec<(f64, f64)> = (0..r.len())
                    .step_by(step)
                    .filter(|&i| series.valid[i][ax])
                    .map(|i| (t[i], r[i][ax]))
                    .collect();
                chart
                    .draw_series(LineSeries::new(pts, color.stroke_width(1)))
                    .map_err(|e| e.to_string())?;
            }
        }
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(out)
}

/// Windows that touch or overlap merged, for plotting (ms).
fn merge_windows(w: &[[i64; 2]]) -> Vec<[i64; 2]> {
    let mut v = w.to_vec();
    v.sort();
    let mut out: Vec<[i64; 2]> = vec![];
    for x in v {
        match out.last_mut() {
            Some(l) if x[0] <= l[1] => l[1] = l[1].max(x[1]),
            _ => out.push(x),
        }
    }
    out
}

/// A y tick label: two significant digits, and 0 for the rounding dust of a zero tick.
fn tick(y: &f64, span: f64) -> String {
    if y.abs() < 1e-9 * span.max(1e-300) {
        "0".into()
    } else {
        numfmt::sig(*y, 2)
    }
}

/// What a window panel marks: the located window (shaded) or a fitted time (a line, s).
#[derive(Clone, Copy)]
enum Mark {
    Shade,
    At(f64),
}

/// Measured, nominal-model and fitted-model rates per axis around `window` (ms of the
/// recording), the window itself shaded or a time marked.
fn window_svg(
    a: &Analysis,
    t: &[f64],
    window: [i64; 2],
    title: &str,
    mark: Mark,
) -> Result<String, String> {
    let series = &a.series;
    let (w0, w1) = (window[0] as f64 * 1e-3, window[1] as f64 * 1e-3);
    // context on both sides: half the window, at least 30 ms and 10 samples
    let pad = (0.5 * (w1 - w0))
        .max(0.03)
        .max(10.0 / series.sample_rate_hz.max(1e-3));
    // the view stays inside the recording (a located window may reach past its end)
    let (first, last) = (
        t.first().copied().unwrap_or(0.0),
        t.last().copied().unwrap_or(0.0),
    );
    let (v0, v1) = ((w0 - pad).max(first), (w1 + pad).min(last));
    if v1 <= v0 {
        return Err("the window is outside the recording".into());
    }
    let i0 = t.partition_point(|&x| x < v0);
    let i1 = t.partition_point(|&x| x <= v1);
    if i1 <= i0 + 1 {
        return Err("no samples in the window".into());
    }
    let n = i1 - i0;
    let step = (n / 2000).max(1);
    let idx: Vec<usize> = (i0..i1).step_by(step).collect();
    let firing = firing_thrusters(series, v0, v1);
    let strip_px = if firing.is_empty() {
        0
    } else {
        30 + 18 * firing.len() as u32
    };
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (900, 520 + strip_px)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let (top, body) = root.split_vertically(28);
        let mut legend = vec![
            ("measured", MEASURED, 1),
            ("nominal model", NOMINAL, 2),
            ("fitted model", FITTED, 2),
        ];
        if let Mark::At(_) = mark {
            legend.push(("fitted time", BLACK, 1));
        }
        if !firing.is_empty() {
            legend.push(("thruster on", VALVE_ON, 6));
        }
        let refits = refit_times(series, t, v0, v1);
        if !refits.is_empty() {
            legend.push(("rate re-fitted", REFIT, 2));
        }
        title_strip(&top, title, &legend)?;
        let (body, strip) = body.split_vertically(body.dim_in_pixel().1 - strip_px);
        let shown = measured_axes(series);
        let rows = body.split_evenly((shown.len(), 1));
        let decimals = if v1 - v0 < 2.0 { 3 } else { 1 };
        for (&ax, area) in shown.iter().zip(rows.iter()) {
            let usable: Vec<usize> = idx
                .iter()
                .copied()
                .filter(|&i| series.valid[i][ax])
                .collect();
            let meas: Vec<(f64, f64)> =
                usable.iter().map(|&i| (t[i], series.rate[i][ax])).collect();
            let nom: Vec<(f64, f64)> = usable
                .iter()
                .map(|&i| (t[i], series.rate[i][ax] - a.residual_before[i][ax]))
                .collect();
            let fit: Vec<(f64, f64)> = usable
                .iter()
                .map(|&i| (t[i], series.rate[i][ax] - a.residual_after[i][ax]))
                .collect();
            let (mut lo, mut hi) = meas
                .iter()
                .chain(&nom)
                .chain(&fit)
                .fold((f64::MAX, f64::MIN), |m, p| (m.0.min(p.1), m.1.max(p.1)));
            if lo > hi {
                (lo, hi) = (-1e-3, 1e-3);
            }
            let span = (hi - lo).max(1e-4);
            let (lo, hi) = (lo - 0.08 * span, hi + 0.08 * span);
            let last = Some(&ax) == shown.last();
            let mut chart = ChartBuilder::on(area)
                .margin_left(8)
                .margin_right(12)
                .margin_top(6)
                .x_label_area_size(if last { 34 } else { 18 })
                .y_label_area_size(72)
                .build_cartesian_2d(v0..v1, lo..hi)
                .map_err(|e| e.to_string())?;
            let fmt_x = |x: &f64| format!("{:.*}", decimals, x);
            let fmt_y = |y: &f64| tick(y, hi - lo);
            let ydesc = format!("{} rate (rad/s)", AXES[ax]);
            let mut mesh = chart.configure_mesh();
            mesh.disable_mesh()
                .x_label_formatter(&fmt_x)
                .y_label_formatter(&fmt_y)
                .y_desc(ydesc.as_str())
                .y_labels(5);
            if last {
                mesh.x_desc("time (s)");
            }
            mesh.draw().map_err(|e| e.to_string())?;
            match mark {
                Mark::Shade => {
                    chart
                        .draw_series(std::iter::once(Rectangle::new(
                            [(w0.max(v0), lo), (w1.min(v1), hi)],
                            WINDOW_FILL.filled(),
                        )))
                        .map_err(|e| e.to_string())?;
                }
                Mark::At(at) => {
                    chart
                        .draw_series(DashedLineSeries::new(
                            vec![(at, lo), (at, hi)],
                            6,
                            4,
                            BLACK.stroke_width(1),
                        ))
                        .map_err(|e| e.to_string())?;
                }
            }
            for &at in &refits {
                chart
                    .draw_series(DashedLineSeries::new(
                        vec![(at, lo), (at, hi)],
                        3,
                        3,
                        REFIT.stroke_width(2),
                    ))
                    .map_err(|e| e.to_string())?;
            }
            // the models first, the measurement on top of them (thin, so both stay visible)
            chart
                .draw_series(LineSeries::new(nom, NOMINAL.stroke_width(2)))
                .map_err(|e| e.to_string())?;
            chart
                .draw_series(LineSeries::new(fit, FITTED.stroke_width(2)))
                .map_err(|e| e.to_string())?;
            chart
                .draw_series(LineSeries::new(
                    meas.iter().copied(),
                    MEASURED.stroke_width(1),
                ))
                .map_err(|e| e.to_string())?;
            if meas.len() <= 300 {
                chart
                    .draw_series(meas.iter().map(|&p| Circle::new(p, 2, MEASURED.filled())))
                    .map_err(|e| e.to_string())?;
            }
        }
        if !firing.is_empty() {
            valve_strip(&strip, series, &firing, v0, v1)?;
        }
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(out)
}

/// Times (s) in `v0..=v1` where the models' rate is re-fitted: the first sample of every
/// `--horizon` stretch and after every telemetry gap. The rate there is a jump fitted by
/// least squares over the whole stretch that follows, so where the model misses physics the
/// curves start away from the measurement; the marker says why.
fn refit_times(series: &Series, t: &[f64], v0: f64, v1: f64) -> Vec<f64> {
    series
        .gap_resets
        .iter()
        .filter_map(|&i| t.get(i).copied())
        .filter(|&x| (v0..=v1).contains(&x))
        .collect()
}

/// The thrusters (0-based) commanded open at some time in `v0..v1` s.
fn firing_thrusters(series: &Series, v0: f64, v1: f64) -> Vec<usize> {
    let (k0, k1) = (ms_index(series, v0), ms_index(series, v1));
    let any = series.word_ms[k0..k1].iter().fold(0u16, |a, &w| a | w);
    (0..16).filter(|i| any & (1 << i) != 0).collect()
}

/// The 1 ms command grid's index at `t` s of the recording, inside the grid.
fn ms_index(series: &Series, t: f64) -> usize {
    let len = series.word_ms.len();
    let model_ms = series.model_ms(t * 1e3).round().max(0.0) as usize;
    model_ms.min(len)
}

/// One row of on/off bars per thruster under the rate panels, on the same time axis: a
/// valve latency shows as the rate bending after the bar starts.
fn valve_strip(
    area: &Area,
    series: &Series,
    firing: &[usize],
    v0: f64,
    v1: f64,
) -> Result<(), String> {
    let n = firing.len() as f64;
    let mut chart = ChartBuilder::on(area)
        .margin_left(8)
        .margin_right(12)
        .x_label_area_size(0)
        .y_label_area_size(72)
        .build_cartesian_2d(v0..v1, 0.0..n)
        .map_err(|e| e.to_string())?;
    let label = |y: &f64| {
        let row = y.floor() as usize;
        match firing.get(row) {
            Some(i) if (y - y.floor() - 0.5).abs() < 1e-9 => format!("T{}", i + 1),
            _ => String::new(),
        }
    };
    let centres: Vec<f64> = (0..firing.len()).map(|r| r as f64 + 0.5).collect();
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(firing.len() * 2 + 1)
        .y_label_formatter(&label)
        .y_desc("valves")
        .draw()
        .map_err(|e| e.to_string())?;
    let (k0, k1) = (ms_index(series, v0), ms_index(series, v1));
    for (row, &i) in firing.iter().enumerate() {
        let y = centres[row];
        // runs of the commanded-open state on the 1 ms grid
        let mut k = k0;
        while k < k1 {
            if series.word_ms[k] & (1 << i) == 0 {
                k += 1;
                continue;
            }
            let start = k;
            while k < k1 && series.word_ms[k] & (1 << i) != 0 {
                k += 1;
            }
            let (a, b) = (
                series.real_ms(start as f64) * 1e-3,
                series.real_ms(k as f64) * 1e-3,
            );
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(a.max(v0), y - 0.35), (b.min(v1), y + 0.35)],
                    VALVE_ON.filled(),
                )))
                .map_err(|e| e.to_string())?;
        }
    }
    Ok(())
}

fn spectrum_svg(a: &Analysis) -> Result<String, String> {
    let sp = &a.spectrum_before;
    if sp.is_empty() {
        return Ok(String::new());
    }
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (900, 280)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let (top, body) = root.split_vertically(28);
        let (fa, _) = &a.alias_marks;
        let mut legend = vec![("tone statistic", BLACK, 1)];
        let threshold = a.spectrum_threshold;
        if threshold.is_finite() {
            legend.push(("significance (named above)", SIGNIFICANCE, 2));
        }
        if *fa > 0.0 {
            legend.push(("named ringing (apparent)", RED, 2));
        }
        title_strip(
            &top,
            "post-edge tone statistic (2 ln LR) vs apparent frequency",
            &legend,
        )?;
        let fmax = sp.last().map(|p| p.0).unwrap_or(1.0);
        // the line stays in view when every peak is below it
        let pmax = sp
            .iter()
            .fold(1e-9f64, |m, p| m.max(p.1))
            .max(if threshold.is_finite() {
                threshold
            } else {
                0.0
            });
        let mut chart = ChartBuilder::on(&body)
            .margin(8)
            .x_label_area_size(34)
            .y_label_area_size(64)
            .build_cartesian_2d(0.0..fmax, 0.0..pmax * 1.05)
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("apparent frequency (Hz)")
            .y_desc("2 ln LR")
            .draw()
            .map_err(|e| e.to_string())?;
        chart
            .draw_series(LineSeries::new(sp.iter().cloned(), BLACK.stroke_width(1)))
            .map_err(|e| e.to_string())?;
        if threshold.is_finite() {
            chart
                .draw_series(DashedLineSeries::new(
                    vec![(0.0, threshold), (fmax, threshold)],
                    8,
                    5,
                    SIGNIFICANCE.stroke_width(2),
                ))
                .map_err(|e| e.to_string())?;
        }
        if *fa > 0.0 {
            chart
                .draw_series(LineSeries::new(
                    vec![(*fa, 0.0), (*fa, pmax * 1.05)],
                    RED.stroke_width(2),
                ))
                .map_err(|e| e.to_string())?;
        }
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(out)
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// The located windows of one list as panels (adjacent windows merged into one panel).
fn window_panels(h: &mut String, a: &Analysis, t: &[f64], windows: &[[i64; 2]], what: &str) {
    for w in merge_windows(windows) {
        let title = format!("{what}: {}", numfmt::window(w));
        match window_svg(a, t, w, &title, Mark::Shade) {
            Ok(svg) => {
                let _ = write!(h, "<div class=\"panel\">{svg}</div>");
            }
            Err(e) => {
                let _ = write!(h, "<p>{}: no plot ({})</p>", esc(&title), esc(&e));
            }
        }
    }
}

const CSS: &str =
    "body{font-family:sans-serif;max-width:980px;margin:auto;padding:0 12px;line-height:1.4}\
pre{white-space:pre-wrap;overflow-wrap:anywhere;font-size:13px}\
table{border-collapse:collapse;margin:6px 0}\
td,th{padding:2px 8px;text-align:left;vertical-align:top;border-bottom:1px solid #ddd}\
td.n{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}\
svg{max-width:100%;height:auto}\
.verdict{background:#f3f3f3;border-left:5px solid #4a4;padding:6px 12px}\
.verdict.warn{border-left-color:#d70}\
.why{overflow-wrap:anywhere}\
.panel{margin:8px 0}\
h3{margin-bottom:4px}";

/// The HTML report (plots inline as SVG).
pub fn html(a: &Analysis) -> String {
    let o = &a.output;
    let series = &a.series;
    let shown = measured_axes(series);
    let rates = |v: [f64; 3]| rates_on(v, &shown);
    let t = times_s(series);
    let mut h = String::new();
    h.push_str(
        "<!doctype html><html><head><meta charset=\"utf-8\"><title>massid diagnosis</title><style>",
    );
    h.push_str(CSS);
    h.push_str("</style></head><body>");
    let _ = write!(
        h,
        "<h1>Diagnosis of {}</h1><p>{} samples at {} Hz, {} s, against the nominal model <b>{}</b>.</p>",
        esc(&o.recording),
        o.samples,
        hz(series.sample_rate_hz),
        numfmt::sig(series.duration_s(), 3),
        esc(&o.model)
    );

    // verdict
    let named: Vec<&str> = o.effects.iter().map(|e| e.effect.as_str()).collect();
    let warn = if o.unexplained.is_some() { " warn" } else { "" };
    let named_text = match (named.is_empty(), o.unexplained.is_some()) {
        (false, _) => esc(&named.join(", ")),
        (true, false) => "nothing: the nominal model explains the recording".to_string(),
        (true, true) => "nothing: no mechanism of the vocabulary improves the prediction in a way that generalises".to_string(),
    };
    let _ = write!(
        h,
        "<div class=\"verdict{warn}\"><p><b>Named:</b> {named_text}</p>"
    );
    match &o.unexplained {
        Some(u) => {
            let _ = write!(h, "<p><b>Unexplained:</b> {}</p>", esc(&u.note));
        }
        None => h.push_str("<p><b>Unexplained:</b> nothing; the residual after the named effects is at the noise and white.</p>"),
    }
    let _ = write!(
        h,
        "<p>Residual RMS (rad/s, x y z): before {}, after {}; gyro noise {}.</p></div>",
        rates(o.residual_rms_before),
        rates(o.residual_rms_after),
        rates(a.noise.var.map(f64::sqrt))
    );

    // data issues
    let d = &o.data_issues;
    let _ = write!(
        h,
        "<h2>Data issues</h2><p>{} gaps, {} missing samples, {} duplicates, {} saturated; masked gyro samples (rail or stuck) x y z: {} {} {}.</p>",
        d.gaps, d.missing_samples, d.duplicates, d.saturated, d.railed[0], d.railed[1], d.railed[2]
    );
    for w in &series.warnings {
        let _ = write!(h, "<p>Warning: {}</p>", esc(w));
    }

    // named effects
    h.push_str("<h2>Named effects</h2>");
    if o.effects.is_empty() {
        h.push_str("<p>None.</p>");
    }
    for (i, e) in o.effects.iter().enumerate() {
        let _ = write!(
            h,
            "<h3>{}. {} <small>(delta BIC {:.0})</small></h3>",
            i + 1,
            esc(&e.effect),
            e.delta_bic
        );
        h.push_str(
            "<table><tr><th>parameter</th><th></th><th>value ± uncertainty</th><th>unit</th></tr>",
        );
        for p in numfmt::effect_params(e) {
            for (l, v) in &p.entries {
                let _ = write!(
                    h,
                    "<tr><td>{}</td><td>{}</td><td class=\"n\">{}</td><td>{}</td></tr>",
                    esc(&p.name),
                    esc(l),
                    esc(v),
                    esc(p.unit)
                );
            }
        }
        h.push_str("</table>");
        let _ = write!(h, "<p class=\"why\"><b>Why:</b> {}</p>", esc(&e.evidence));
        if !e.equivalent_to.is_empty() {
            let _ = write!(
                h,
                "<p><b>Same rates as:</b> {} (named once; on rates alone the data cannot tell them apart).</p>",
                esc(&equivalents_text(e))
            );
        }
        let _ = write!(
            h,
            "<p>Residual RMS with this and the earlier effects (rad/s, x y z): {}.</p><p><b>Located windows</b> (where the mismatch this effect explains is concentrated, shaded below): {}.</p>",
            rates(e.rms_after),
            esc(&windows_text(&e.windows_ms))
        );
        window_panels(&mut h, a, &t, &e.windows_ms, &e.effect);
        // a change in time is shown where it happens, too: in the recorded rates that is a
        // named measurement delay later than on the body's clock
        let delay_s = a
            .output
            .effects
            .iter()
            .find(|o| o.effect == "measurement_delay")
            .and_then(|o| o.params.get("delay_ms"))
            .and_then(|v| v.as_f64())
            .unwrap_or(0.0)
            * 1e-3;
        for key in ["at_s", "start_s"] {
            if let Some(fitted) = e.params.get(key).and_then(|v| v.as_f64()) {
                let at = fitted + delay_s;
                let ms = (at * 1e3).round() as i64;
                let seen = if delay_s > 0.0 {
                    format!(
                        ", seen {} ms later behind the measurement delay",
                        numfmt::sig(delay_s * 1e3, 3)
                    )
                } else {
                    String::new()
                };
                let title = format!(
                    "{} at its fitted {key} = {} s{seen}",
                    e.effect,
                    numfmt::sig(fitted, 4)
                );
                match window_svg(a, &t, [ms - 1000, ms + 1000], &title, Mark::At(at)) {
                    Ok(svg) => {
                        let _ = write!(h, "<div class=\"panel\">{svg}</div>");
                    }
                    Err(err) => {
                        let _ = write!(h, "<p>{}: no plot ({})</p>", esc(&title), esc(&err));
                    }
                }
            }
        }
    }

    // rejected candidates
    h.push_str("<h2>Strong candidates not named</h2>");
    if a.rejections.is_empty() {
        h.push_str("<p>None: no candidate was set aside by the acceptance checks.</p>");
    } else {
        h.push_str(
            "<table><tr><th>round</th><th>mechanism</th><th>delta BIC</th><th>why not</th></tr>",
        );
        for r in &a.rejections {
            let _ = write!(
                h,
                "<tr><td class=\"n\">{}</td><td>{}</td><td class=\"n\">{:.0}</td><td class=\"why\">{}</td></tr>",
                r.round + 1,
                r.effect,
                r.delta_bic,
                esc(&r.reason)
            );
        }
        h.push_str("</table>");
    }

    // unexplained
    h.push_str("<h2>Unexplained</h2>");
    match &o.unexplained {
        None => h.push_str("<p>Nothing: after the named effects the residual is at the gyro noise and white on every axis.</p>"),
        Some(u) => {
            let _ = write!(h, "<p class=\"why\">{}</p>", esc(&u.note));
            h.push_str("<table><tr><th>axis</th><th>residual RMS (rad/s)</th><th>noise RMS (rad/s)</th><th>ratio</th><th>Ljung-Box</th><th>flagged</th></tr>");
            for &ax in &shown {
                let _ = write!(
                    h,
                    "<tr><td>{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"n\">{:.2}</td><td class=\"n\">{:.0}</td><td>{}</td></tr>",
                    AXES[ax],
                    numfmt::sig(u.rms[ax], 3),
                    numfmt::sig(u.noise_rms[ax], 3),
                    u.rms[ax] / u.noise_rms[ax].max(1e-30),
                    u.ljung_box[ax],
                    if u.axes.iter().any(|x| x == AXES[ax]) { "yes" } else { "" }
                );
            }
            let _ = write!(
                h,
                "</table><p>White below Ljung-Box {:.0}. Concentrated: {}; apparent tone: {}; windows: {}.</p>",
                u.white_below,
                esc(&u.condition),
                u.apparent_hz.map(|f| format!("{} Hz", numfmt::sig(f, 3))).unwrap_or_else(|| "none".into()),
                esc(&windows_text(&u.windows_ms))
            );
            window_panels(&mut h, a, &t, &u.windows_ms, "unexplained");
        }
    }

    // residuals on one scale
    let lim = residual_limit(series, &[&a.residual_before, &a.residual_after]);
    h.push_str("<h2>Residual before and after, on one scale</h2>");
    if o.effects.is_empty() {
        h.push_str("<p>Nothing was named, so the two residuals are the same curve.</p>");
    }
    match residual_svg(series, &t, &a.residual_before, &a.residual_after, lim) {
        Ok(svg) => {
            let _ = write!(h, "<div class=\"panel\">{svg}</div>");
        }
        Err(e) => {
            let _ = write!(h, "<p>no plot ({})</p>", esc(&e));
        }
    }

    h.push_str("<h2>Where the mismatch concentrates</h2><table><tr><th>condition</th><th>samples</th><th>RMS before x y z (rad/s)</th><th>RMS after x y z (rad/s)</th></tr>");
    for (b, af) in a
        .by_condition_before
        .iter()
        .zip(a.by_condition_after.iter())
    {
        let _ = write!(
            h,
            "<tr><td>{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td></tr>",
            esc(&b.0.label()),
            b.1,
            rates(b.2.map(f64::sqrt)),
            rates(af.2.map(f64::sqrt))
        );
    }
    h.push_str("</table>");

    h.push_str("<h2>Spectrum after valve edges</h2>");
    match spectrum_svg(a) {
        Ok(svg) if !svg.is_empty() => {
            let _ = write!(h, "<div class=\"panel\">{svg}</div>");
            if a.spectrum_threshold.is_finite() {
                let _ = write!(
                    h,
                    "<p>Green dashed line: significance, 2 ln LR = {:.0} (the tone's parameters' BIC cost plus the acceptance margin); a tone is named only above it.</p>",
                    a.spectrum_threshold
                );
            }
        }
        _ => h.push_str(
            "<p>No post-edge spectrum (no ringing scan was possible on this recording).</p>",
        ),
    }
    let (fa, cands) = &a.alias_marks;
    if *fa > 0.0 {
        let c: Vec<String> = cands.iter().map(|f| format!("{f:.1}")).collect();
        let _ = write!(
            h,
            "<p>Red line: the named ringing's tone, {:.1} Hz apparent at {} Hz sampling; it could fold from the true frequencies {} Hz.</p>",
            fa,
            hz(series.sample_rate_hz),
            c.join(", ")
        );
    }

    h.push_str("<h2>Candidate scores (delta BIC per selection round)</h2><table><tr><th>round</th><th>mechanism</th><th>delta BIC</th><th>outcome</th></tr>");
    // `massid diagnose` runs the default settings
    let margin = crate::select::Settings::default().accept_margin;
    for s in &a.scores {
        let named_here = o.effects.get(s.round).map(|e| e.effect.as_str());
        let named_score = a
            .scores
            .iter()
            .find(|x| x.round == s.round && Some(x.effect) == named_here)
            .map(|x| x.delta_bic);
        let outcome = if named_here == Some(s.effect) {
            "named"
        } else if a
            .rejections
            .iter()
            .any(|r| r.round == s.round && r.effect == s.effect)
        {
            "not named (reason above)"
        } else if s.delta_bic >= 0.0 {
            "no gain"
        } else if named_score.map(|n| s.delta_bic > n).unwrap_or(false) {
            "weaker than the named one"
        } else if s.delta_bic > -margin {
            "below the acceptance level"
        } else {
            "not tried (only a round's strongest few are)"
        };
        let _ = write!(
            h,
            "<tr><td class=\"n\">{}</td><td>{}</td><td class=\"n\">{:.0}</td><td>{}</td></tr>",
            s.round + 1,
            s.effect,
            s.delta_bic,
            outcome
        );
    }
    h.push_str("</table>");
    let _ = write!(
        h,
        "<h2>Terminal summary</h2><pre>{}</pre>",
        esc(&summary(a))
    );
    h.push_str("</body></html>\n");
    h
}

/// Writes `DIR/report.html` (plots inline as SVG) and `DIR/summary.txt`.
pub fn write_html(dir: &Path, a: &Analysis) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    std::fs::write(dir.join("report.html"), html(a))?;
    std::fs::write(dir.join("summary.txt"), summary(a))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::{self, Maneuver};
    use crate::{diagnose_recording, Settings};

    /// A recording with an effect: the report shows it with rounded digits, its located
    /// windows as measured / nominal / fitted panels with a legend, residuals on one scale,
    /// and never a raw placeholder.
    #[test]
    fn html_has_window_panels_with_a_legend_for_a_named_effect() {
        let eff = synth::effect(
            r#"{"effect":"thruster_latency","params":{"open_ms":6.0,"close_ms":6.0}}"#,
        );
        let s = synth::make("sph4", Maneuver::Combo { seconds: 20 }, 100, vec![eff], 104);
        let mut a = diagnose_recording(&s.recording, &s.satellite, &Settings::default())
            .expect("diagnosis");
        assert!(
            a.output
                .effects
                .iter()
                .any(|e| e.effect == "thruster_latency"),
            "{}",
            summary(&a)
        );
        let e = &a.output.effects[0];
        assert!(!e.windows_ms.is_empty());
        let h = html(&a);
        // one panel per (merged) located window, each with three axes and the legend
        let panels: Vec<&str> = h.split("<div class=\"panel\">").skip(1).collect();
        for w in merge_windows(&e.windows_ms) {
            let title = format!("thruster_latency: {}", numfmt::window(w));
            let p = panels
                .iter()
                .find(|p| p.contains(&title))
                .unwrap_or_else(|| panic!("no panel {title}"));
            for label in [
                "measured",
                "nominal model",
                "fitted model",
                "x rate (rad/s)",
                "y rate (rad/s)",
                "z rate (rad/s)",
            ] {
                assert!(p.contains(label), "{title}: no {label}");
            }
            // the thruster activity under the rates, so a latency can be seen
            assert!(
                p.contains("thruster on") && p.contains("valves"),
                "{title}: no valves"
            );
        }
        // one whiteness threshold, the one the verdicts use
        let white = format!("white below {:.0}", crate::stats::WHITE_BELOW);
        assert!(h.contains(&white), "{white}");
        assert!(
            !h.contains("white &lt;") && !h.contains("white <"),
            "a second threshold"
        );
        // the post-edge spectrum carries its significance line
        if !a.spectrum_before.is_empty() {
            assert!(a.spectrum_threshold > 0.0);
            assert!(h.contains("significance (named above)"));
        }
        let n_windows = a
            .output
            .effects
            .iter()
            .map(|e| merge_windows(&e.windows_ms).len())
            .sum::<usize>()
            + a.output
                .unexplained
                .as_ref()
                .map(|u| merge_windows(&u.windows_ms).len())
                .unwrap_or(0);
        assert!(
            panels.len() > n_windows,
            "{} panels for {n_windows} windows + the residual plot",
            panels.len()
        );
        assert!(
            h.contains(&numfmt::window(e.windows_ms[0])),
            "located windows listed"
        );
        // parameters rounded, in their units
        let open = e.params["open_ms"].as_f64().unwrap();
        let se = e.stderr["open_ms"].as_f64().unwrap();
        let text = numfmt::value_pm(open, se);
        assert!(h.contains(&format!("{text}</td><td>ms")), "{text}");
        assert!(summary(&a).contains(&format!("open_ms = {text} ms")));
        assert!(
            !h.contains(&format!("{open}")),
            "full-precision {open} printed"
        );
        // sections people read
        for section in [
            "Strong candidates not named",
            "<h2>Unexplained</h2>",
            "after the named effects",
            "white-space:pre-wrap",
        ] {
            assert!(h.contains(section), "{section}");
        }
        assert!(!h.contains("1000000000"));
        // where the models' rate is re-fitted (a --horizon stretch or a gap starts) the panel
        // marks it, so a curve that starts away from the measurement there is explained
        let t = times_s(&a.series);
        let w = merge_windows(&e.windows_ms)[0];
        let marked = |a: &Analysis| {
            window_svg(a, &t, w, "w", Mark::Shade)
                .expect("panel")
                .contains("rate re-fitted")
        };
        assert!(a.series.gap_resets.is_empty() && !marked(&a));
        let inside = t.partition_point(|&x| x < (w[0] + w[1]) as f64 * 0.5e-3);
        a.series.gap_resets = vec![inside];
        assert!(marked(&a));
        a.series.gap_resets = vec![t.len() - 1];
        assert!(!marked(&a), "a re-fit outside the window is not drawn");
    }

    #[test]
    fn adjacent_windows_merge_into_one_panel() {
        assert_eq!(
            merge_windows(&[[41000, 42000], [40000, 41000], [45000, 46000]]),
            vec![[40000, 42000], [45000, 46000]]
        );
        assert_eq!(merge_windows(&[]), Vec::<[i64; 2]>::new());
    }
}
