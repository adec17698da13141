//! The project's SVG line-plot writer for the paper-style figures (stacked panels
//! sharing the time axis, readable ticks, axis labels and a legend).

use std::fmt::Write;

/// One line in a panel.
#[derive(Clone, Debug)]
pub struct Series {
    pub name: String,
    pub color: &'static str,
    pub dashed: bool,
    pub points: Vec<(f64, f64)>,
}

/// One panel (its own y axis).
#[derive(Clone, Debug, Default)]
pub struct Panel {
    pub title: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// Fixed y range, or automatic from the data when `None`.
    pub y_range: Option<(f64, f64)>,
}

/// A figure: panels stacked vertically over a shared x axis.
#[derive(Clone, Debug, Default)]
pub struct Figure {
    pub title: String,
    /// A smaller second line under the title (wrapped at ~130 characters).
    pub subtitle: String,
    pub x_label: String,
    pub panels: Vec<Panel>,
}

/// "Nice" tick positions covering [lo, hi] (about `target` of them).
pub fn nice_ticks(lo: f64, hi: f64, target: usize) -> Vec<f64> {
    if !(hi > lo) || !lo.is_finite() || !hi.is_finite() {
        return vec![lo];
    }
    let raw = (hi - lo) / target.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0].iter().map(|m| m * mag).find(|s| *s >= raw).unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() * step;
    let mut ticks = Vec::new();
    let mut v = first;
    while v <= hi + 1e-9 * step {
        ticks.push(if v.abs() < 1e-12 * step { 0.0 } else { v });
        v += step;
    }
    ticks
}

fn fmt_tick(v: f64, step: f64) -> String {
    let decimals = if step >= 1.0 { 0 } else { (-step.log10().floor()) as usize + 1 }.min(6);
    let s = format!("{v:.decimals$}");
    if decimals > 0 && s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Greedy word wrap at `width` characters.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    let mut cur = String::new();
    for w in text.split_whitespace() {
        if !cur.is_empty() && cur.chars().count() + 1 + w.chars().count() > width {
            lines.push(std::mem::take(&mut cur));
        }
        if !cur.is_empty() {
            cur.push(' ');
        }
        cur.push_str(w);
    }
    if !cur.is_empty() {
        lines.push(cur);
    }
    lines
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// Reduce a series to at most ~2·`buckets` points keeping each bucket's min
/// and max (so oscillation peaks survive).
pub fn decimate(points: &[(f64, f64)], buckets: usize) -> Vec<(f64, f64)> {
    if points.len() <= 2 * buckets {
        return points.to_vec();
    }
    let per = points.len().div_ceil(buckets);
    let mut out = Vec::with_capacity(2 * buckets + 2);
    for chunk in points.chunks(per) {
        let (mut imin, mut imax) = (0, 0);
        for (i, p) in chunk.iter().enumerate() {
            if p.1 < chunk[imin].1 {
                imin = i;
            }
            if p.1 > chunk[imax].1 {
                imax = i;
            }
        }
        let (a, b) = if imin <= imax { (imin, imax) } else { (imax, imin) };
        out.push(chunk[a]);
        if b != a {
            out.push(chunk[b]);
        }
    }
    out
}

impl Figure {
    /// Render to an SVG document.
    pub fn to_svg(&self) -> String {
        let width = 960.0;
        let panel_h = 250.0;
        let sub_lines = wrap(&self.subtitle, 130);
        let (ml, mr, mb, gap) = (80.0, 30.0, 55.0, 45.0);
        let mt = 62.0 + 16.0 * sub_lines.len() as f64;
        let height = mt + mb + self.panels.len() as f64 * panel_h + (self.panels.len().saturating_sub(1)) as f64 * gap;
        let pw = width - ml - mr;
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" font-family="Helvetica, Arial, sans-serif" font-size="13">"#
        );
        let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
        let _ = writeln!(
            s,
            r#"<text x="{}" y="28" text-anchor="middle" font-size="17" font-weight="bold">{}</text>"#,
            width / 2.0,
            esc(&self.title)
        );
        for (i, line) in sub_lines.iter().enumerate() {
            let _ = writeln!(
                s,
                r##"<text x="{}" y="{}" text-anchor="middle" font-size="12" fill="#444">{}</text>"##,
                width / 2.0,
                46.0 + 16.0 * i as f64,
                esc(line)
            );
        }
        // shared x range
        let (mut x0, mut x1) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in &self.panels {
            for se in &p.series {
                for &(x, _) in &se.points {
                    if x.is_finite() {
                        x0 = x0.min(x);
                        x1 = x1.max(x);
                    }
                }
            }
        }
        if !(x1 > x0) {
            x0 = 0.0;
            x1 = 1.0;
        }
        let xt = nice_ticks(x0, x1, 10);
        let xstep = if xt.len() > 1 { xt[1] - xt[0] } else { 1.0 };
        for (k, p) in self.panels.iter().enumerate() {
            let top = mt + k as f64 * (panel_h + gap);
            let (mut y0, mut y1) = p.y_range.unwrap_or((f64::INFINITY, f64::NEG_INFINITY));
            if p.y_range.is_none() {
                for se in &p.series {
                    for &(_, y) in &se.points {
                        if y.is_finite() {
                            y0 = y0.min(y);
                            y1 = y1.max(y);
                        }
                    }
                }
                if !(y1 > y0) {
                    let c = if y0.is_finite() { y0 } else { 0.0 };
                    y0 = c - 1.0;
                    y1 = c + 1.0;
                }
                // a nearly constant signal is drawn as such, not blown up to full height
                let min_span = 0.05 * y0.abs().max(y1.abs());
                if y1 - y0 < min_span {
                    let c = 0.5 * (y0 + y1);
                    y0 = c - 0.5 * min_span;
                    y1 = c + 0.5 * min_span;
                }
                let pad = 0.06 * (y1 - y0);
                y0 -= pad;
                y1 += pad;
            }
            let px = |x: f64| ml + (x - x0) / (x1 - x0) * pw;
            let py = |y: f64| top + panel_h - (y - y0) / (y1 - y0) * panel_h;
            let _ = writeln!(
                s,
                r#"<text x="{}" y="{}" font-size="14" font-weight="bold">{}</text>"#,
                ml,
                top - 8.0,
                esc(&p.title)
            );
            let _ = writeln!(s, r##"<rect x="{ml}" y="{top}" width="{pw}" height="{panel_h}" fill="none" stroke="#333"/>"##);
            let yt = nice_ticks(y0, y1, 6);
            let ystep = if yt.len() > 1 { yt[1] - yt[0] } else { 1.0 };
            for &v in &yt {
                let y = py(v);
                let _ = writeln!(
                    s,
                    r##"<line x1="{ml}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#ddd"/><text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"##,
                    ml + pw,
                    ml - 6.0,
                    y + 4.0,
                    fmt_tick(v, ystep)
                );
            }
            for &v in &xt {
                let x = px(v);
                let _ = writeln!(
                    s,
                    r##"<line x1="{x:.1}" y1="{top}" x2="{x:.1}" y2="{:.1}" stroke="#eee"/><text x="{x:.1}" y="{:.1}" text-anchor="middle">{}</text>"##,
                    top + panel_h,
                    top + panel_h + 17.0,
                    fmt_tick(v, xstep)
                );
            }
            let _ = writeln!(
                s,
                r#"<text transform="translate({:.1},{:.1}) rotate(-90)" text-anchor="middle">{}</text>"#,
                22.0,
                top + panel_h / 2.0,
                esc(&p.y_label)
            );
            let _ = writeln!(s, r#"<clipPath id="c{k}"><rect x="{ml}" y="{top}" width="{pw}" height="{panel_h}"/></clipPath>"#);
            for se in &p.series {
                let pts = decimate(&se.points, 800);
                let mut d = String::with_capacity(pts.len() * 16);
                let mut pen_down = false;
                for &(x, y) in &pts {
                    if !x.is_finite() || !y.is_finite() {
                        pen_down = false;
                        continue;
                    }
                    let _ = write!(d, "{}{:.1},{:.1} ", if pen_down { "L" } else { "M" }, px(x), py(y));
                    pen_down = true;
                }
                let dash = if se.dashed { r#" stroke-dasharray="7,4""# } else { "" };
                let _ = writeln!(
                    s,
                    r#"<path clip-path="url(#c{k})" d="{}" fill="none" stroke="{}" stroke-width="1.6"{dash}/>"#,
                    d.trim_end(),
                    se.color
                );
            }
            // legend, top right inside the panel
            let lw = 14.0 + 8.0 * p.series.iter().map(|se| se.name.chars().count()).max().unwrap_or(0) as f64 + 40.0;
            let lx = ml + pw - lw - 8.0;
            let ly = top + 8.0;
            let _ = writeln!(
                s,
                r##"<rect x="{lx:.1}" y="{ly:.1}" width="{lw:.1}" height="{:.1}" fill="white" fill-opacity="0.85" stroke="#999"/>"##,
                8.0 + 18.0 * p.series.len() as f64
            );
            for (j, se) in p.series.iter().enumerate() {
                let y = ly + 16.0 + 18.0 * j as f64;
                let dash = if se.dashed { r#" stroke-dasharray="7,4""# } else { "" };
                let _ = writeln!(
                    s,
                    r#"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="{}" stroke-width="2"{dash}/><text x="{:.1}" y="{:.1}">{}</text>"#,
                    lx + 8.0,
                    y - 4.0,
                    lx + 38.0,
                    y - 4.0,
                    se.color,
                    lx + 44.0,
                    y,
                    esc(&se.name)
                );
            }
        }
        let last_bottom = mt + self.panels.len() as f64 * panel_h + (self.panels.len().saturating_sub(1)) as f64 * gap;
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
            ml + pw / 2.0,
            last_bottom + 40.0,
            esc(&self.x_label)
        );
        s.push_str("</svg>\n");
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_nice_and_cover_the_range() {
        assert_eq!(nice_ticks(0.0, 5.0, 10), vec![0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0]);
        let t = nice_ticks(-3.2, 27.0, 6);
        assert_eq!(t, vec![0.0, 10.0, 20.0]);
        assert_eq!(nice_ticks(-3.0, 27.0, 6), vec![0.0, 5.0, 10.0, 15.0, 20.0, 25.0]);
        assert_eq!(fmt_tick(0.05, 0.01), "0.05");
        assert_eq!(fmt_tick(20.0, 5.0), "20");
    }

    #[test]
    fn decimation_keeps_extremes() {
        let pts: Vec<(f64, f64)> = (0..100_000).map(|i| (i as f64, if i == 54_321 { 99.0 } else { 0.0 })).collect();
        let d = decimate(&pts, 500);
        assert!(d.len() <= 1001);
        assert!(d.iter().any(|p| p.1 == 99.0));
    }

    #[test]
    fn svg_has_labels_legend_and_paths() {
        let fig = Figure {
            title: "Force <tracking>".into(),
            subtitle: "a long description that wraps ".repeat(10),
            x_label: "time [s]".into(),
            panels: vec![Panel {
                title: "(a) force".into(),
                y_label: "f_ext [N]".into(),
                series: vec![
                    Series { name: "NAIC".into(), color: "#d62728", dashed: false, points: vec![(0.0, 0.0), (1.0, 10.0)] },
                    Series { name: "desired".into(), color: "#000", dashed: true, points: vec![(0.0, 10.0), (1.0, 10.0)] },
                ],
                y_range: None,
            }],
        };
        let svg = fig.to_svg();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains("Force &lt;tracking&gt;") && svg.contains("time [s]") && svg.contains("f_ext [N]"));
        assert!(svg.contains(">NAIC<") && svg.contains(">desired<"));
        assert_eq!(svg.matches("<path").count(), 2);
        assert!(svg.contains("stroke-dasharray"));
        assert!(wrap(&fig.subtitle, 130).len() >= 3 && wrap(&fig.subtitle, 130).iter().all(|l| l.chars().count() <= 130));
    }
}
