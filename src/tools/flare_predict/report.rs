//! A range prediction ([`super::range`]) as the command writes it: a plain text table, a CSV
//! file of every position, and an SVG plot: for a grid a heat map of the chosen estimator over
//! the frame (cells reaching the threshold outlined) with a legend of sec. 9.2's bins, for a
//! path the estimator along the path with the threshold as a dashed line.

use super::range::{Estimator, Range, RangePrediction};
use std::fmt::Write;

fn view(v: [f64; 3]) -> String {
    format!("{:.4},{:.4},{:.4}", v[0], v[1], v[2])
}

/// The range's description: what the positions are.
pub fn describe(r: &RangePrediction) -> String {
    let frame = r.positions.first().map(|p| p.prediction.frame_px).unwrap_or([0, 0]);
    let ghosts = r.positions.first().map(|p| p.prediction.ghosts).unwrap_or(0);
    let what = match r.request.range {
        Range::Grid { cols, rows, fov_deg } => {
            format!("a {cols}x{rows} grid of lights over the frame (horizontal field of view {fov_deg} deg)")
        }
        Range::Path { from, to, steps } => format!("{steps} lights on the path {} to {}", view(from), view(to)),
    };
    format!("{what}, {ghosts} fitted ghosts on {}x{} px", frame[0], frame[1])
}

/// The threshold as a sentence's part: "contrast-ratio <= 0.95".
fn threshold_text(e: Estimator, t: f64) -> String {
    format!("{} {} {t}", e.name(), if e.rises_with_flare() { ">=" } else { "<=" })
}

/// The plain text table: every position, the statistics of every estimator, the bins of the
/// chosen one and the share reaching the threshold.
pub fn text(r: &RangePrediction) -> String {
    let mut s = String::new();
    let e = r.request.estimator;
    let grid = matches!(r.request.range, Range::Grid { .. });
    let scale = r.positions.first().map(|p| p.prediction.brightness_scale).unwrap_or(0.0);
    let _ = writeln!(s, "flare over {}; brightness scale (eq 8.3) {scale:.6}", describe(r));
    let _ = writeln!(
        s,
        "| # | {} | light X,Y,Z | angle deg | roll deg | min | max | sum | average | log-average | K_real/K_ideal | bin of {} |",
        if grid { "cell col,row | centre px" } else { "step" },
        e.name()
    );
    let _ = writeln!(s, "|---|{}---|---|---|---|---|---|---|---|---|---|", if grid { "---|---|" } else { "---|" });
    for (i, p) in r.positions.iter().enumerate() {
        let where_ = match p.light.frame_px {
            Some(px) => format!("{},{} | {:.1},{:.1}", p.light.cell[0], p.light.cell[1], px[0], px[1]),
            None => format!("{}", p.light.cell[0]),
        };
        let (q, x) = (&p.prediction, &p.prediction.estimators);
        let _ = writeln!(
            s,
            "| {i} | {where_} | {} | {:.4} | {:.4} | {:.6e} | {:.6e} | {:.6e} | {:.6e} | {:.6e} | {:.6} | {}{} |",
            view(p.light.view),
            q.angle_deg,
            q.roll_deg,
            x.min,
            x.max,
            x.sum,
            x.average,
            x.log_average,
            q.contrast_ratio,
            p.bin,
            if p.reaches { " *" } else { "" }
        );
    }
    let _ = writeln!(s, "statistics over the {} positions (sec. 9.2):", r.positions.len());
    let _ = writeln!(s, "| estimator | min | mean | max | at min (#) | at max (#) |\n|---|---|---|---|---|---|");
    for st in &r.statistics {
        let _ = writeln!(
            s,
            "| {} | {:.6e} | {:.6e} | {:.6e} | {} | {} |",
            st.estimator.name(),
            st.min,
            st.mean,
            st.max,
            st.at_min,
            st.at_max
        );
    }
    let n = r.bins.counts.len();
    let _ = writeln!(s, "bins of {} (sec. 9.2: its range from min to max in {n} equal bins):", e.name());
    let _ = writeln!(s, "| bin | from | to | positions |\n|---|---|---|---|");
    for (i, c) in r.bins.counts.iter().enumerate() {
        let (lo, hi) = r.bins.edges(i);
        let _ = writeln!(s, "| {i} | {lo:.6e} | {hi:.6e} | {c} |");
    }
    match r.threshold {
        Some(t) => {
            let _ = writeln!(
                s,
                "{} (the flare at least that strong; * above) at {} of {} positions ({:.1}%)",
                threshold_text(e, t),
                r.reaching,
                r.positions.len(),
                100.0 * r.share()
            );
        }
        None => {
            let _ = writeln!(s, "no --threshold for {}: no share reported", e.name());
        }
    }
    s
}

/// One line per position, with a header.
pub fn csv(r: &RangePrediction) -> String {
    let mut s = String::from(
        "index,col_or_step,row,frame_x_px,frame_y_px,light_x,light_y,light_z,angle_deg,roll_deg,\
         min,max,sum,average,log_average,contrast_ratio,bin,reaches_threshold\n",
    );
    for (i, p) in r.positions.iter().enumerate() {
        let (px, py) = p.light.frame_px.map(|f| (f[0].to_string(), f[1].to_string())).unwrap_or_default();
        let (q, x) = (&p.prediction, &p.prediction.estimators);
        let [lx, ly, lz] = p.light.view;
        let _ = writeln!(
            s,
            "{i},{},{},{px},{py},{lx},{ly},{lz},{},{},{},{},{},{},{},{},{},{}",
            p.light.cell[0],
            p.light.cell[1],
            q.angle_deg,
            q.roll_deg,
            x.min,
            x.max,
            x.sum,
            x.average,
            x.log_average,
            q.contrast_ratio,
            p.bin,
            p.reaches
        );
    }
    s
}

/// Text for an SVG document (`&`, `<`, `>`, `"` escaped).
fn escaped(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// A perceptually ordered colour map (five stops of viridis, dark blue to yellow) at t in 0..1.
fn colour(t: f64) -> String {
    const STOPS: [[f64; 3]; 5] =
        [[68.0, 1.0, 84.0], [59.0, 82.0, 139.0], [33.0, 145.0, 140.0], [94.0, 201.0, 98.0], [253.0, 231.0, 37.0]];
    let x = if t.is_finite() { t.clamp(0.0, 1.0) * 4.0 } else { 0.0 };
    let i = (x.floor() as usize).min(3);
    let f = x - i as f64;
    let c: Vec<u8> = (0..3).map(|k| (STOPS[i][k] + f * (STOPS[i + 1][k] - STOPS[i][k])).round() as u8).collect();
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// Where `value` lies in the chosen estimator's range, 1 the most flare.
fn flare_t(r: &RangePrediction, value: f64) -> f64 {
    let (lo, hi) = (r.bins.lower, r.bins.upper);
    let t = if hi > lo { (value - lo) / (hi - lo) } else { 0.5 };
    if r.request.estimator.rises_with_flare() {
        t
    } else {
        1.0 - t
    }
}

/// A compact number for the plot's labels.
fn label(v: f64) -> String {
    if v != 0.0 && (v.abs() < 1e-3 || v.abs() >= 1e4) {
        format!("{v:.3e}")
    } else {
        format!("{v:.4}")
    }
}

/// The SVG plot: a heat map for a grid, a line for a path.
pub fn svg(r: &RangePrediction) -> String {
    match r.request.range {
        Range::Grid { cols, rows, .. } => heat_map(r, cols, rows),
        Range::Path { .. } => path_plot(r),
    }
}

const PLOT_W: f64 = 640.0;
const MARGIN: f64 = 40.0;
const LEGEND_W: f64 = 280.0;

fn heat_map(r: &RangePrediction, cols: u32, rows: u32) -> String {
    let frame = r.positions.first().map(|p| p.prediction.frame_px).unwrap_or([1, 1]);
    let plot_h = (PLOT_W * frame[1] as f64 / frame[0].max(1) as f64).clamp(40.0, 640.0);
    let legend_h = 20.0 * r.bins.counts.len() as f64 + 60.0;
    let (w, h) = (MARGIN * 2.0 + PLOT_W + LEGEND_W, (MARGIN * 2.0 + plot_h).max(MARGIN * 2.0 + legend_h));
    let (cw, ch) = (PLOT_W / cols as f64, plot_h / rows as f64);
    let e = r.request.estimator;
    let mut s = svg_start(w, h, &format!("{} over {}", e.name(), describe(r)));
    let _ = writeln!(s, "<g class=\"cells\" transform=\"translate({MARGIN},{MARGIN})\">");
    for p in &r.positions {
        let [c, row] = p.light.cell;
        let outline = if p.reaches { " stroke=\"red\" stroke-width=\"2\"" } else { "" };
        let _ = writeln!(
            s,
            "<rect class=\"cell\" x=\"{:.3}\" y=\"{:.3}\" width=\"{cw:.3}\" height=\"{ch:.3}\" fill=\"{}\"{outline}><title>cell {c},{row}: {} {}</title></rect>",
            c as f64 * cw,
            row as f64 * ch,
            colour(flare_t(r, p.value)),
            e.name(),
            label(p.value)
        );
    }
    let _ = writeln!(s, "</g>");
    let _ = writeln!(
        s,
        "<rect x=\"{MARGIN}\" y=\"{MARGIN}\" width=\"{PLOT_W}\" height=\"{plot_h:.3}\" fill=\"none\" stroke=\"black\"/>"
    );
    legend(&mut s, r, MARGIN * 2.0 + PLOT_W, MARGIN);
    s.push_str("</svg>\n");
    s
}

/// Sec. 9.2's bins as colour swatches with their ranges and counts, the most flare on top.
fn legend(s: &mut String, r: &RangePrediction, x: f64, y: f64) {
    let e = r.request.estimator;
    let _ = writeln!(s, "<g class=\"legend\" transform=\"translate({x},{y})\">");
    let _ = writeln!(s, "<text x=\"0\" y=\"0\">{} in {} bins</text>", e.name(), r.bins.counts.len());
    let mut order: Vec<usize> = (0..r.bins.counts.len()).collect();
    if e.rises_with_flare() {
        order.reverse();
    }
    for (k, &i) in order.iter().enumerate() {
        let (lo, hi) = r.bins.edges(i);
        let yy = 10.0 + 20.0 * k as f64;
        let _ = writeln!(
            s,
            "<rect class=\"bin\" x=\"0\" y=\"{yy}\" width=\"16\" height=\"16\" fill=\"{}\"/><text x=\"22\" y=\"{}\">{} to {} ({})</text>",
            colour(flare_t(r, 0.5 * (lo + hi))),
            yy + 12.0,
            label(lo),
            label(hi),
            r.bins.counts[i]
        );
    }
    let yy = 10.0 + 20.0 * r.bins.counts.len() as f64 + 16.0;
    if let Some(t) = r.threshold {
        let _ = writeln!(
            s,
            "<rect x=\"0\" y=\"{}\" width=\"16\" height=\"16\" fill=\"none\" stroke=\"red\" stroke-width=\"2\"/><text x=\"22\" y=\"{}\">{}: {} of {}</text>",
            yy - 4.0,
            yy + 8.0,
            escaped(&threshold_text(e, t)),
            r.reaching,
            r.positions.len()
        );
    }
    let _ = writeln!(s, "</g>");
}

fn path_plot(r: &RangePrediction) -> String {
    let e = r.request.estimator;
    let (plot_w, plot_h) = (PLOT_W + 80.0, 360.0);
    let (w, h) = (MARGIN * 2.0 + 40.0 + plot_w, MARGIN * 2.0 + 30.0 + plot_h);
    let (mut lo, mut hi) = (r.bins.lower, r.bins.upper);
    if let Some(t) = r.threshold {
        (lo, hi) = (lo.min(t), hi.max(t));
    }
    if !(hi > lo) {
        (lo, hi) = (lo - 0.5 * lo.abs().max(1e-12), hi + 0.5 * hi.abs().max(1e-12));
    }
    let (x0, y0) = (MARGIN + 40.0, MARGIN);
    let n = r.positions.len().max(2) - 1;
    let px = |i: usize| x0 + plot_w * i as f64 / n as f64;
    let py = |v: f64| y0 + plot_h * (1.0 - (v - lo) / (hi - lo));
    let mut s = svg_start(w, h, &format!("{} along {}", e.name(), describe(r)));
    let _ = writeln!(
        s,
        "<rect x=\"{x0}\" y=\"{y0}\" width=\"{plot_w}\" height=\"{plot_h}\" fill=\"none\" stroke=\"black\"/>"
    );
    for k in 0..=4 {
        let v = lo + (hi - lo) * k as f64 / 4.0;
        let y = py(v);
        let _ = writeln!(
            s,
            "<line x1=\"{}\" y1=\"{y:.3}\" x2=\"{x0}\" y2=\"{y:.3}\" stroke=\"black\"/><text x=\"{}\" y=\"{:.3}\" text-anchor=\"end\">{}</text>",
            x0 - 4.0,
            x0 - 6.0,
            y + 4.0,
            label(v),
        );
    }
    let every = n.div_ceil(10).max(1);
    for i in (0..r.positions.len()).step_by(every) {
        let _ = writeln!(s, "<text x=\"{:.3}\" y=\"{}\" text-anchor=\"middle\">{i}</text>", px(i), y0 + plot_h + 16.0);
    }
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">step along the path</text>",
        x0 + 0.5 * plot_w,
        y0 + plot_h + 34.0
    );
    if let Some(t) = r.threshold {
        let y = py(t);
        let _ = writeln!(
            s,
            "<line class=\"threshold\" x1=\"{x0}\" y1=\"{y:.3}\" x2=\"{}\" y2=\"{y:.3}\" stroke=\"red\" stroke-dasharray=\"6,4\"/><text x=\"{}\" y=\"{:.3}\" text-anchor=\"end\" fill=\"red\">{}: {} of {}</text>",
            x0 + plot_w,
            x0 + plot_w - 4.0,
            py(t) - 4.0,
            escaped(&threshold_text(e, t)),
            r.reaching,
            r.positions.len(),
        );
    }
    let points: Vec<String> =
        r.positions.iter().enumerate().map(|(i, p)| format!("{:.3},{:.3}", px(i), py(p.value))).collect();
    let _ = writeln!(
        s,
        "<polyline class=\"estimator\" points=\"{}\" fill=\"none\" stroke=\"#3b528b\" stroke-width=\"2\"/>",
        points.join(" ")
    );
    for (i, p) in r.positions.iter().enumerate() {
        let fill = if p.reaches { "red" } else { "#3b528b" };
        let _ = writeln!(
            s,
            "<circle class=\"point\" cx=\"{:.3}\" cy=\"{:.3}\" r=\"3\" fill=\"{fill}\"><title>step {i}: {}</title></circle>",
            px(i),
            py(p.value),
            label(p.value)
        );
    }
    s.push_str("</svg>\n");
    s
}

/// An SVG document's opening of `w` x `h` px: a white background and `title` (escaped) at the top.
fn svg_start(w: f64, h: f64, title: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\" font-family=\"sans-serif\" font-size=\"12\">"
    );
    let _ = writeln!(s, "<rect width=\"{w}\" height=\"{h}\" fill=\"white\"/>");
    let _ = writeln!(s, "<text x=\"{MARGIN}\" y=\"24\" font-size=\"10\">{}</text>", escaped(title));
    s
}
