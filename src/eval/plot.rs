//! Line charts as SVG text, for the sweep and path plots: one or more panels stacked
//! vertically, each with a left axis, an optional right axis (its series dashed), a linear or
//! logarithmic x axis and a legend. Written by hand rather than with a plotting crate: the
//! charts need a few dozen lines of markup and no fonts or rasterization.
//! Cost: linear in the number of points.

use std::fmt::Write;

/// Which y axis a series is measured against.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    /// The left axis (solid lines).
    Left,
    /// The right axis (dashed lines).
    Right,
}

/// One line of a chart.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// Points `(x, y)`; non-finite ones are skipped.
    pub points: Vec<(f64, f64)>,
    /// The axis it is drawn against.
    pub axis: Axis,
    /// Index into the palette (a series and its counterpart on the other axis share one).
    pub colour: usize,
}

/// One panel.
#[derive(Clone, Debug, PartialEq)]
pub struct Chart {
    /// Title above the panel.
    pub title: String,
    /// Label of the x axis.
    pub x_label: String,
    /// Whether x is drawn on a log scale (all x must then be positive).
    pub x_log: bool,
    /// Label of the left axis.
    pub left_label: String,
    /// Label of the right axis (used if a series is on it).
    pub right_label: String,
    /// The lines.
    pub series: Vec<Series>,
}

const WIDTH: f64 = 760.0;
const PANEL_HEIGHT: f64 = 380.0;
const MARGIN_LEFT: f64 = 80.0;
const MARGIN_RIGHT: f64 = 90.0;
const MARGIN_TOP: f64 = 40.0;
const MARGIN_BOTTOM: f64 = 56.0;
/// Up to this many distinct x values are each given a tick (sweeps); more get round ticks.
const MAX_DATA_TICKS: usize = 12;
/// Line colours, in series order (Okabe–Ito, readable with colour-blindness).
const PALETTE: [&str; 8] = [
    "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000", "#F0E442",
];

/// The SVG document of `charts`, stacked top to bottom.
pub fn svg(charts: &[Chart]) -> String {
    let height = PANEL_HEIGHT * charts.len().max(1) as f64;
    let mut out = String::new();
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{height}" viewBox="0 0 {WIDTH} {height}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(
        out,
        r#"<rect width="{WIDTH}" height="{height}" fill="white"/>"#
    );
    for (i, chart) in charts.iter().enumerate() {
        panel(&mut out, chart, i as f64 * PANEL_HEIGHT);
    }
    out.push_str("</svg>\n");
    out
}

/// A range `[lo, hi]` with round tick marks.
struct Scale {
    lo: f64,
    hi: f64,
    log: bool,
}

impl Scale {
    fn of(values: impl Iterator<Item = f64>, log: bool, from_zero: bool) -> Scale {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in values.filter(|v| v.is_finite() && (!log || *v > 0.0)) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        if !lo.is_finite() {
            (lo, hi) = if log { (1.0, 10.0) } else { (0.0, 1.0) };
        }
        if log {
            return Scale {
                lo: lo.log10(),
                hi: if hi > lo {
                    hi.log10()
                } else {
                    lo.log10() + 1.0
                },
                log,
            };
        }
        if from_zero && lo > 0.0 {
            lo = 0.0;
        }
        if hi <= lo {
            hi = lo + if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
        }
        let step = nice_step(hi - lo);
        Scale {
            lo: (lo / step).floor() * step,
            hi: (hi / step).ceil() * step,
            log,
        }
    }

    /// Position of `v` in `[0, 1]`.
    fn unit(&self, v: f64) -> f64 {
        let v = if self.log { v.log10() } else { v };
        (v - self.lo) / (self.hi - self.lo)
    }

    fn ticks(&self) -> Vec<f64> {
        if self.log {
            let (a, b) = (self.lo.floor() as i32, self.hi.ceil() as i32);
            return (a..=b).map(|e| 10f64.powi(e)).collect();
        }
        let step = nice_step(self.hi - self.lo);
        let n = ((self.hi - self.lo) / step).round() as i64;
        (0..=n).map(|i| self.lo + i as f64 * step).collect()
    }
}

/// A step of 1, 2 or 5 × 10^k giving about five intervals over `span`.
fn nice_step(span: f64) -> f64 {
    let raw = span / 5.0;
    let magnitude = 10f64.powf(raw.log10().floor());
    let r = raw / magnitude;
    magnitude
        * if r <= 1.0 {
            1.0
        } else if r <= 2.0 {
            2.0
        } else if r <= 5.0 {
            5.0
        } else {
            10.0
        }
}

fn label(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if a >= 1e6 {
        format!("{:.1}M", v / 1e6)
    } else if a >= 1e4 {
        format!("{:.0}k", v / 1e3)
    } else if a >= 100.0 || v.fract() == 0.0 {
        format!("{v:.0}")
    } else if a >= 1.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.2}")
    }
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

fn panel(out: &mut String, chart: &Chart, top: f64) {
    let (x0, x1) = (MARGIN_LEFT, WIDTH - MARGIN_RIGHT);
    let (y0, y1) = (top + MARGIN_TOP, top + PANEL_HEIGHT - MARGIN_BOTTOM);
    let finite = |s: &&Series| -> Vec<(f64, f64)> {
        s.points
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite() && (!chart.x_log || *x > 0.0))
            .collect()
    };
    let all_x: Vec<f64> = chart
        .series
        .iter()
        .flat_map(|s| finite(&s))
        .map(|p| p.0)
        .collect();
    let xs = Scale::of(all_x.iter().copied(), chart.x_log, false);
    let on = |axis| {
        let values: Vec<f64> = chart
            .series
            .iter()
            .filter(|s| s.axis == axis)
            .flat_map(|s| finite(&s))
            .map(|p| p.1)
            .collect();
        (!values.is_empty()).then(|| Scale::of(values.into_iter(), false, true))
    };
    let (left, right) = (on(Axis::Left), on(Axis::Right));
    let px = |x: f64| x0 + xs.unit(x) * (x1 - x0);
    let py = |s: &Scale, y: f64| y1 - s.unit(y) * (y1 - y0);

    let _ = writeln!(
        out,
        r#"<text x="{}" y="{}" text-anchor="middle" font-size="14" font-weight="bold">{}</text>"#,
        (x0 + x1) / 2.0,
        top + 22.0,
        escape(&chart.title)
    );
    let _ = writeln!(
        out,
        r##"<rect x="{x0}" y="{y0}" width="{}" height="{}" fill="none" stroke="#444"/>"##,
        x1 - x0,
        y1 - y0
    );
    // x ticks: the data's own values when there are few (sweeps), round values otherwise.
    let mut distinct = all_x.clone();
    distinct.sort_by(f64::total_cmp);
    distinct.dedup();
    let x_ticks = if distinct.len() <= MAX_DATA_TICKS && !distinct.is_empty() {
        distinct
    } else {
        xs.ticks()
    };
    for x in x_ticks {
        let u = xs.unit(x);
        if !(-1e-9..=1.0 + 1e-9).contains(&u) {
            continue;
        }
        let p = px(x);
        let _ = writeln!(
            out,
            r##"<line x1="{p:.1}" y1="{y0}" x2="{p:.1}" y2="{y1}" stroke="#ddd"/><text x="{p:.1}" y="{}" text-anchor="middle">{}</text>"##,
            y1 + 16.0,
            label(x)
        );
    }
    let _ = writeln!(
        out,
        r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
        (x0 + x1) / 2.0,
        y1 + 36.0,
        escape(&chart.x_label)
    );
    for (scale, side) in [(&left, Axis::Left), (&right, Axis::Right)] {
        let Some(scale) = scale else { continue };
        let (tx, anchor, lx, text) = match side {
            Axis::Left => (x0 - 6.0, "end", 18.0, &chart.left_label),
            Axis::Right => (x1 + 6.0, "start", WIDTH - 12.0, &chart.right_label),
        };
        for y in scale.ticks() {
            let p = py(scale, y);
            if side == Axis::Left {
                let _ = writeln!(
                    out,
                    r##"<line x1="{x0}" y1="{p:.1}" x2="{x1}" y2="{p:.1}" stroke="#eee"/>"##
                );
            }
            let _ = writeln!(
                out,
                r#"<text x="{tx}" y="{:.1}" text-anchor="{anchor}">{}</text>"#,
                p + 4.0,
                label(y)
            );
        }
        let mid = (y0 + y1) / 2.0;
        let _ = writeln!(
            out,
            r#"<text x="{lx}" y="{mid}" text-anchor="middle" transform="rotate(-90 {lx} {mid})">{}</text>"#,
            escape(text)
        );
    }
    for (i, series) in chart.series.iter().enumerate() {
        let colour = PALETTE[series.colour % PALETTE.len()];
        let Some(scale) = (match series.axis {
            Axis::Left => &left,
            Axis::Right => &right,
        }) else {
            continue;
        };
        let dash = if series.axis == Axis::Right {
            r#" stroke-dasharray="6 4""#
        } else {
            ""
        };
        let points: Vec<String> = finite(&series)
            .into_iter()
            .map(|(x, y)| format!("{:.1},{:.1}", px(x), py(scale, y)))
            .collect();
        let _ = writeln!(
            out,
            r#"<polyline points="{}" fill="none" stroke="{colour}" stroke-width="2"{dash}/>"#,
            points.join(" ")
        );
        if points.len() <= MAX_DATA_TICKS * 4 {
            for p in &points {
                let (cx, cy) = p.split_once(',').unwrap_or(("0", "0"));
                let _ = writeln!(
                    out,
                    r#"<circle cx="{cx}" cy="{cy}" r="3" fill="{colour}"/>"#
                );
            }
        }
        let ly = y0 + 14.0 + 16.0 * i as f64;
        let _ = writeln!(
            out,
            r#"<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="{colour}" stroke-width="2"{dash}/><text x="{}" y="{}">{}</text>"#,
            x0 + 10.0,
            ly - 4.0,
            x0 + 34.0,
            ly - 4.0,
            x0 + 40.0,
            ly,
            escape(&series.name)
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_steps_and_labels() {
        assert_eq!(nice_step(1.0), 0.2);
        assert_eq!(nice_step(47.0), 10.0);
        assert_eq!(nice_step(3000.0), 1000.0);
        assert_eq!(label(0.25), "0.25");
        assert_eq!(label(4098.0), "4098");
        assert_eq!(label(52_000.0), "52k");
    }

    #[test]
    fn svg_has_one_polyline_per_series_and_skips_non_finite_points() {
        let chart = Chart {
            title: "culling <rate>".into(),
            x_label: "views".into(),
            x_log: true,
            left_label: "%".into(),
            right_label: "bytes".into(),
            series: vec![
                Series {
                    name: "P=300".into(),
                    points: vec![(6.0, 30.0), (66.0, 35.0), (1026.0, f64::INFINITY)],
                    axis: Axis::Left,
                    colour: 0,
                },
                Series {
                    name: "size".into(),
                    points: vec![(6.0, 100.0), (66.0, 1000.0)],
                    axis: Axis::Right,
                    colour: 0,
                },
            ],
        };
        let text = svg(&[chart.clone(), chart]);
        assert_eq!(text.matches("<polyline").count(), 4);
        assert_eq!(text.matches("stroke-dasharray").count(), 4);
        assert!(text.contains("culling &lt;rate&gt;"));
        assert!(!text.contains("inf") && !text.contains("NaN"));
        // Two points of the first series drawn: the non-finite one is gone.
        let first = text.lines().find(|l| l.starts_with("<polyline")).unwrap();
        assert_eq!(first.matches(',').count(), 2);
    }
}
