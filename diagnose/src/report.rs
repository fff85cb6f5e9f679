//! Reports for people: a terminal summary, and an HTML page with SVG plots (residual
//! before and after, where the mismatch concentrates, the post-edge spectrum with the
//! apparent tone and its possible true frequencies marked).

use std::fmt::Write as _;
use std::path::Path;

use plotters::prelude::*;

use crate::diagnosis::Analysis;
use crate::series::Series;

/// Terminal summary.
pub fn summary(a: &Analysis) -> String {
    let o = &a.output;
    let mut s = String::new();
    let _ = writeln!(s, "recording {} ({} samples) against model {}", o.recording, o.samples, o.model);
    let _ = writeln!(
        s,
        "data issues: {} gaps, {} missing samples, {} duplicates, {} saturated",
        o.data_issues.gaps, o.data_issues.missing_samples, o.data_issues.duplicates, o.data_issues.saturated
    );
    let r = o.data_issues.railed;
    if r.iter().any(|&x| x > 0) {
        let _ = writeln!(s, "masked gyro samples (rail or stuck), x y z: {} {} {} (left out of every fit and statistic)", r[0], r[1], r[2]);
    }
    for w in &a.series.warnings {
        let _ = writeln!(s, "warning: {w}");
    }
    let f = |v: [f64; 3]| format!("[{:.5} {:.5} {:.5}]", v[0], v[1], v[2]);
    let _ = writeln!(s, "noise (per sample, rad/s): {}", f(a.noise.var.map(f64::sqrt)));
    let _ = writeln!(s, "residual RMS before (rad/s): {}", f(o.residual_rms_before));
    if o.effects.is_empty() {
        let _ = writeln!(s, "no effect: the nominal model explains the recording (residual at noise level)");
    }
    for (i, e) in o.effects.iter().enumerate() {
        let _ = writeln!(s, "{}. {}  (delta BIC {:.1})", i + 1, e.effect, e.delta_bic);
        for (k, v) in &e.params {
            let se = e.stderr.get(k).map(|x| x.to_string()).unwrap_or_default();
            let _ = writeln!(s, "     {k} = {v}  +/- {se}");
        }
        let _ = writeln!(s, "     why: {}", e.evidence);
        let _ = writeln!(s, "     residual RMS after: {}", f(e.rms_after));
    }
    for r in &a.rejections {
        let _ = writeln!(s, "not named (round {}): {} (delta BIC {:.0}): {}", r.round + 1, r.effect, r.delta_bic, r.reason);
    }
    let _ = writeln!(s, "residual RMS after (rad/s): {}", f(o.residual_rms_after));
    match &o.unexplained {
        Some(u) => {
            let _ = writeln!(s, "UNEXPLAINED: {}", u.note);
            let _ = writeln!(
                s,
                "     residual RMS {} against noise {}; Ljung-Box {:.0} {:.0} {:.0} (white below {:.0}); windows (ms) {:?}",
                f(u.rms),
                f(u.noise_rms),
                u.ljung_box[0],
                u.ljung_box[1],
                u.ljung_box[2],
                u.white_below,
                u.windows_ms
            );
        }
        None => {
            let _ = writeln!(s, "nothing unexplained: the residual after the named effects is at the noise and white");
        }
    }
    let lb = |t: &crate::stats::ResidualTests| {
        format!(
            "Ljung-Box Q {:.0} {:.0} {:.0} (white < {:.0}), input cross-corr z {:.1} {:.1} {:.1}",
            t.ljung_box_q[0],
            t.ljung_box_q[1],
            t.ljung_box_q[2],
            crate::stats::LJUNG_BOX_95,
            t.input_xcorr_z[0],
            t.input_xcorr_z[1],
            t.input_xcorr_z[2]
        )
    };
    let _ = writeln!(s, "residual tests before: {}", lb(&a.tests_before));
    let _ = writeln!(s, "residual tests after:  {}", lb(&a.tests_after));
    s
}

const COLORS: [RGBColor; 3] = [RGBColor(200, 30, 30), RGBColor(30, 140, 30), RGBColor(30, 60, 200)];

fn residual_svg(series: &Series, r: &[[f64; 3]], title: &str, labels: bool) -> Result<String, String> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (900, 260)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let real_s = |i: usize| series.real_ms(series.t_ms[i] as f64) * 1e-3;
        let t0 = real_s(0);
        let t1 = real_s(series.len() - 1).max(t0 + 1e-3);
        let lim = r.iter().flat_map(|x| x.iter()).fold(1e-6f64, |m, v| m.max(v.abs()));
        let mut b = ChartBuilder::on(&root);
        b.margin(8);
        if labels {
            b.caption(title, ("sans-serif", 16)).x_label_area_size(30).y_label_area_size(60);
        }
        let mut chart = b.build_cartesian_2d(t0..t1, -lim..lim).map_err(|e| e.to_string())?;
        let mut mesh = chart.configure_mesh();
        if labels {
            mesh.x_desc("time (s)").y_desc("rad/s");
        } else {
            mesh.x_labels(0).y_labels(0);
        }
        mesh.disable_mesh().draw().map_err(|e| e.to_string())?;
        let step = (r.len() / 3000).max(1);
        for a in 0..3 {
            let pts: Vec<(f64, f64)> =
                (0..r.len()).step_by(step).map(|i| (real_s(i), r[i][a])).collect();
            chart.draw_series(LineSeries::new(pts, COLORS[a].stroke_width(1))).map_err(|e| e.to_string())?;
        }
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(out)
}

fn spectrum_svg(a: &Analysis, labels: bool) -> Result<String, String> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (900, 260)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let sp = &a.spectrum_before;
        if sp.is_empty() {
            return Ok(String::new());
        }
        let fmax = sp.last().map(|p| p.0).unwrap_or(1.0);
        let pmax = sp.iter().fold(1e-9f64, |m, p| m.max(p.1));
        let mut b = ChartBuilder::on(&root);
        b.margin(8);
        if labels {
            b.caption("post-edge tone statistic (2 ln LR) vs apparent frequency", ("sans-serif", 16))
                .x_label_area_size(30)
                .y_label_area_size(60);
        }
        let mut chart = b.build_cartesian_2d(0.0..fmax, 0.0..pmax * 1.05).map_err(|e| e.to_string())?;
        let mut mesh = chart.configure_mesh();
        if labels {
            mesh.x_desc("Hz").y_desc("2 ln LR");
        } else {
            mesh.x_labels(0).y_labels(0);
        }
        mesh.disable_mesh().draw().map_err(|e| e.to_string())?;
        chart.draw_series(LineSeries::new(sp.iter().cloned(), BLACK.stroke_width(1))).map_err(|e| e.to_string())?;
        let (fa, _) = &a.alias_marks;
        if *fa > 0.0 {
            chart
                .draw_series(LineSeries::new(vec![(*fa, 0.0), (*fa, pmax * 1.05)], RED.stroke_width(2)))
                .map_err(|e| e.to_string())?;
        }
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(out)
}

/// Writes `DIR/report.html` (plots inline as SVG) and `DIR/summary.txt`.
pub fn write_html(dir: &Path, a: &Analysis) -> std::io::Result<()> {
    let series = &a.series;
    std::fs::create_dir_all(dir)?;
    let plot = |f: &dyn Fn(bool) -> Result<String, String>| f(true).or_else(|_| f(false)).unwrap_or_default();
    let before = plot(&|l| residual_svg(series, &a.residual_before, "residual before (x red, y green, z blue)", l));
    let after = plot(&|l| residual_svg(series, &a.residual_after, "residual after all accepted effects", l));
    let spec = plot(&|l| spectrum_svg(a, l));
    let mut h = String::new();
    h.push_str("<!doctype html><html><head><meta charset=\"utf-8\"><title>massid diagnosis</title>");
    h.push_str("<style>body{font-family:sans-serif;max-width:960px;margin:auto}td,th{padding:2px 8px;text-align:right}</style></head><body>");
    let _ = write!(h, "<h1>Diagnosis of {}</h1><pre>{}</pre>", esc(&a.output.recording), esc(&summary(a)));
    let _ = write!(h, "<h2>Residual before</h2>{before}<h2>Residual after</h2>{after}");
    h.push_str("<h2>Where the mismatch concentrates</h2><table><tr><th>condition</th><th>samples</th><th>RMS before x y z (rad/s)</th><th>RMS after x y z</th></tr>");
    for (b, af) in a.by_condition_before.iter().zip(a.by_condition_after.iter()) {
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{:.5} {:.5} {:.5}</td><td>{:.5} {:.5} {:.5}</td></tr>",
            esc(&b.0.label()),
            b.1,
            b.2[0].sqrt(),
            b.2[1].sqrt(),
            b.2[2].sqrt(),
            af.2[0].sqrt(),
            af.2[1].sqrt(),
            af.2[2].sqrt()
        );
    }
    h.push_str("</table>");
    let (fa, cands) = &a.alias_marks;
    let _ = write!(h, "<h2>Spectrum after valve edges</h2>{spec}");
    if *fa > 0.0 {
        let c: Vec<String> = cands.iter().map(|f| format!("{f:.1}")).collect();
        let _ = write!(
            h,
            "<p>Red line: strongest post-edge tone, {:.1} Hz apparent at {} Hz sampling; it could fold from the true frequencies {} Hz.</p>",
            fa,
            series.sample_rate_hz,
            c.join(", ")
        );
    }
    h.push_str("<h2>Candidate scores (delta BIC per selection round)</h2><table><tr><th>round</th><th>mechanism</th><th>delta BIC</th></tr>");
    for s in &a.scores {
        let _ = write!(h, "<tr><td>{}</td><td>{}</td><td>{:.1}</td></tr>", s.round + 1, s.effect, s.delta_bic);
    }
    h.push_str("</table></body></html>\n");
    std::fs::write(dir.join("report.html"), h)?;
    std::fs::write(dir.join("summary.txt"), summary(a))?;
    Ok(())
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}
