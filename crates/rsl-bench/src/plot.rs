//! Plots written directly as SVG: text is SVG text, so nothing depends on the fonts of the
//! machine that makes the plot (the viewer's default sans-serif draws it).

/// One series of points.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// `(x, y)` points, in order (lines join them in this order).
    pub points: Vec<(f64, f64)>,
    /// Join the points with a line.
    pub line: bool,
}

/// A plot: axes, series, horizontal reference lines.
#[derive(Clone, Debug, PartialEq)]
pub struct Plot {
    /// Title.
    pub title: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// Logarithmic x axis.
    pub x_log: bool,
    /// Logarithmic y axis.
    pub y_log: bool,
    /// The series.
    pub series: Vec<Series>,
    /// Dashed horizontal lines: `(y, label)`.
    pub references: Vec<(f64, String)>,
}

const W: f64 = 720.0;
const H: f64 = 460.0;
const LEFT: f64 = 78.0;
const RIGHT: f64 = 200.0;
const TOP: f64 = 40.0;
const BOTTOM: f64 = 56.0;
const COLOURS: [&str; 8] = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2"];

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// An axis: the data range mapped onto pixels, linearly or by logarithm.
struct Axis {
    lo: f64,
    hi: f64,
    log: bool,
}

impl Axis {
    fn new(values: impl Iterator<Item = f64>, log: bool) -> Self {
        let vals: Vec<f64> = values.filter(|v| v.is_finite() && (!log || *v > 0.0)).collect();
        let (mut lo, mut hi) = vals.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        if !lo.is_finite() {
            (lo, hi) = if log { (1.0, 10.0) } else { (0.0, 1.0) };
        }
        if log {
            lo = 10f64.powf(lo.log10().floor());
            hi = 10f64.powf(hi.log10().ceil());
            if hi <= lo {
                hi = lo * 10.0;
            }
        } else {
            if !log && lo > 0.0 {
                lo = 0.0;
            }
            if hi <= lo {
                hi = lo + 1.0;
            }
            hi *= 1.05;
        }
        Self { lo, hi, log }
    }

    /// Where `v` falls in [0, 1].
    fn unit(&self, v: f64) -> f64 {
        if self.log {
            (v.log10() - self.lo.log10()) / (self.hi.log10() - self.lo.log10())
        } else {
            (v - self.lo) / (self.hi - self.lo)
        }
    }

    /// Tick values: 1, 2, 5 × 10ᵏ on a log axis (fewer when the range is wide); about six
    /// round steps on a linear one.
    fn ticks(&self) -> Vec<f64> {
        if self.log {
            let decades = (self.hi / self.lo).log10().round() as i32;
            let steps: &[f64] = if decades > 3 { &[1.0] } else { &[1.0, 2.0, 5.0] };
            let mut t = Vec::new();
            let mut d = self.lo;
            while d <= self.hi * 1.0001 {
                for s in steps {
                    if d * s <= self.hi * 1.0001 {
                        t.push(d * s);
                    }
                }
                d *= 10.0;
            }
            t
        } else {
            let raw = (self.hi - self.lo) / 6.0;
            let mag = 10f64.powf(raw.log10().floor());
            let step = [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * mag).find(|s| *s >= raw).unwrap_or(mag * 10.0);
            let mut t = Vec::new();
            let mut v = (self.lo / step).ceil() * step;
            while v <= self.hi {
                t.push(v);
                v += step;
            }
            t
        }
    }
}

fn label(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e5 || v.abs() < 0.01 {
        format!("{v:.0e}")
    } else if v.fract() == 0.0 {
        format!("{v:.0}")
    } else {
        format!("{}", (v * 1000.0).round() / 1000.0)
    }
}

impl Plot {
    /// The axes spanning every point and reference line.
    fn axes(&self) -> (Axis, Axis) {
        let all = || self.series.iter().flat_map(|s| s.points.iter());
        let x = Axis::new(all().map(|p| p.0), self.x_log);
        let y = Axis::new(all().map(|p| p.1).chain(self.references.iter().map(|r| r.0)), self.y_log);
        (x, y)
    }

    /// The points of `series` that can be drawn (finite, and positive on a log axis).
    fn drawable<'a>(&self, series: &'a Series) -> impl Iterator<Item = (f64, f64)> + 'a {
        let (x_log, y_log) = (self.x_log, self.y_log);
        series
            .points
            .iter()
            .copied()
            .filter(move |(a, b)| a.is_finite() && b.is_finite() && (!x_log || *a > 0.0) && (!y_log || *b > 0.0))
    }

    /// The plot as an SVG document.
    pub fn svg(&self) -> String {
        let (x, y) = self.axes();
        let (pw, ph) = (W - LEFT - RIGHT, H - TOP - BOTTOM);
        let px = |v: f64| LEFT + x.unit(v) * pw;
        let py = |v: f64| TOP + (1.0 - y.unit(v)) * ph;
        let mut s = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{W}\" height=\"{H}\" viewBox=\"0 0 {W} {H}\" \
             font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"{W}\" height=\"{H}\" fill=\"white\"/>\n\
             <text x=\"{}\" y=\"24\" text-anchor=\"middle\" font-size=\"15\">{}</text>\n",
            LEFT + pw / 2.0,
            escape(&self.title)
        );
        for t in x.ticks() {
            let p = px(t);
            s += &format!(
                "<line x1=\"{p:.1}\" y1=\"{TOP}\" x2=\"{p:.1}\" y2=\"{:.1}\" stroke=\"#e4e4e4\"/>\n<text x=\"{p:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>\n",
                TOP + ph,
                TOP + ph + 16.0,
                label(t)
            );
        }
        for t in y.ticks() {
            let p = py(t);
            s += &format!(
                "<line x1=\"{LEFT}\" y1=\"{p:.1}\" x2=\"{:.1}\" y2=\"{p:.1}\" stroke=\"#e4e4e4\"/>\n<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>\n",
                LEFT + pw,
                LEFT - 6.0,
                p + 4.0,
                label(t)
            );
        }
        s += &format!(
            "<rect x=\"{LEFT}\" y=\"{TOP}\" width=\"{pw}\" height=\"{ph}\" fill=\"none\" stroke=\"#444\"/>\n\
             <text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>\n\
             <text x=\"16\" y=\"{:.1}\" text-anchor=\"middle\" transform=\"rotate(-90 16 {:.1})\">{}</text>\n",
            LEFT + pw / 2.0,
            H - 14.0,
            escape(&self.x_label),
            TOP + ph / 2.0,
            TOP + ph / 2.0,
            escape(&self.y_label)
        );
        for (v, text) in &self.references {
            let p = py(*v);
            s += &format!(
                "<line x1=\"{LEFT}\" y1=\"{p:.1}\" x2=\"{:.1}\" y2=\"{p:.1}\" stroke=\"#777\" stroke-dasharray=\"5 4\"/>\n<text x=\"{:.1}\" y=\"{:.1}\" fill=\"#555\">{}</text>\n",
                LEFT + pw,
                LEFT + 6.0,
                p - 4.0,
                escape(text)
            );
        }
        for (k, series) in self.series.iter().enumerate() {
            let colour = COLOURS[k % COLOURS.len()];
            let pts: Vec<(f64, f64)> = self.drawable(series).map(|(a, b)| (px(a), py(b))).collect();
            if series.line && pts.len() > 1 {
                let path: Vec<String> = pts.iter().map(|(a, b)| format!("{a:.1},{b:.1}")).collect();
                s += &format!(
                    "<polyline points=\"{}\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"1.8\"/>\n",
                    path.join(" ")
                );
            }
            for (a, b) in &pts {
                s += &format!("<circle cx=\"{a:.1}\" cy=\"{b:.1}\" r=\"3.5\" fill=\"{colour}\"/>\n");
            }
            let ly = TOP + 14.0 + 18.0 * k as f64;
            s += &format!(
                "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"4\" fill=\"{colour}\"/>\n<text x=\"{:.1}\" y=\"{:.1}\">{}</text>\n",
                LEFT + pw + 14.0,
                ly - 4.0,
                LEFT + pw + 24.0,
                ly,
                escape(&series.name)
            );
        }
        s + "</svg>\n"
    }
}

/// An RGB8 canvas for the PNG form of a plot.
struct Canvas {
    rgb: Vec<u8>,
    w: u32,
    h: u32,
}

impl Canvas {
    fn set(&mut self, x: i64, y: i64, c: [u8; 3]) {
        if x >= 0 && y >= 0 && (x as u32) < self.w && (y as u32) < self.h {
            let o = ((y as u32 * self.w + x as u32) * 3) as usize;
            self.rgb[o..o + 3].copy_from_slice(&c);
        }
    }

    /// A line `width` pixels thick; `dash` > 0 draws `dash` pixels on, `dash` off.
    fn line(&mut self, (x0, y0): (f64, f64), (x1, y1): (f64, f64), c: [u8; 3], width: i64, dash: usize) {
        let n = ((x1 - x0).abs().max((y1 - y0).abs()).ceil() as usize).max(1);
        for k in 0..=n {
            if dash > 0 && (k / dash) % 2 == 1 {
                continue;
            }
            let t = k as f64 / n as f64;
            let (x, y) = ((x0 + (x1 - x0) * t).round() as i64, (y0 + (y1 - y0) * t).round() as i64);
            for dy in 0..width {
                for dx in 0..width {
                    self.set(x + dx - width / 2, y + dy - width / 2, c);
                }
            }
        }
    }

    fn disc(&mut self, (x, y): (f64, f64), r: f64, c: [u8; 3]) {
        let ri = r.ceil() as i64;
        for dy in -ri..=ri {
            for dx in -ri..=ri {
                if (dx * dx + dy * dy) as f64 <= r * r {
                    self.set(x.round() as i64 + dx, y.round() as i64 + dy, c);
                }
            }
        }
    }

    /// Text in the 3×5 legend font at twice its size (8 pixels a character); `anchor` 0 is
    /// left, 1 centre, 2 right.
    fn text(&mut self, x: f64, y: f64, text: &str, anchor: u32, c: [u8; 3]) {
        let width = text.chars().count() as f64 * 8.0;
        let x = (x - width * f64::from(anchor) / 2.0).max(0.0);
        let text = text.to_uppercase();
        rsl_truth::metrics::draw_text(&mut self.rgb, (self.w, self.h), (x as u32, y.max(0.0) as u32), &text, 2, c);
    }
}

fn rgb_of(hex: &str) -> [u8; 3] {
    let v = |k: usize| u8::from_str_radix(&hex[k..k + 2], 16).unwrap_or(0);
    [v(1), v(3), v(5)]
}

impl Plot {
    /// The plot as RGB8 pixels (for PNG), drawn with the same layout as [`Plot::svg`] and the
    /// bitmap font of the error legends, so no system font is involved. Returns the pixels
    /// and the size.
    pub fn rgb(&self) -> (Vec<u8>, u32, u32) {
        // The legend's column widens to its longest name (8 pixels a character).
        let longest = self.series.iter().map(|s| s.name.chars().count()).max().unwrap_or(0) as f64;
        let (w, h) = ((W - RIGHT + RIGHT.max(34.0 + 8.0 * longest)) as u32, H as u32);
        let mut c = Canvas { rgb: vec![255; (w * h * 3) as usize], w, h };
        let (x, y) = self.axes();
        let (pw, ph) = (W - LEFT - RIGHT, H - TOP - BOTTOM);
        let px = |v: f64| LEFT + x.unit(v) * pw;
        let py = |v: f64| TOP + (1.0 - y.unit(v)) * ph;
        let (grid, ink, grey) = ([228, 228, 228], [40, 40, 40], [110, 110, 110]);
        for t in x.ticks() {
            c.line((px(t), TOP), (px(t), TOP + ph), grid, 1, 0);
            c.text(px(t), TOP + ph + 8.0, &label(t), 1, ink);
        }
        for t in y.ticks() {
            c.line((LEFT, py(t)), (LEFT + pw, py(t)), grid, 1, 0);
            c.text(LEFT - 6.0, py(t) - 5.0, &label(t), 2, ink);
        }
        for (a, b) in [((LEFT, TOP), (LEFT + pw, TOP)), ((LEFT, TOP + ph), (LEFT + pw, TOP + ph))] {
            c.line(a, b, ink, 1, 0);
        }
        for (a, b) in [((LEFT, TOP), (LEFT, TOP + ph)), ((LEFT + pw, TOP), (LEFT + pw, TOP + ph))] {
            c.line(a, b, ink, 1, 0);
        }
        c.text(LEFT + pw / 2.0, 6.0, &self.title, 1, ink);
        c.text(LEFT + pw / 2.0, H - 22.0, &self.x_label, 1, ink);
        c.text(8.0, TOP - 14.0, &self.y_label, 0, ink);
        for (v, text) in &self.references {
            c.line((LEFT, py(*v)), (LEFT + pw, py(*v)), grey, 1, 5);
            c.text(LEFT + 6.0, py(*v) - 14.0, text, 0, grey);
        }
        for (k, series) in self.series.iter().enumerate() {
            let colour = rgb_of(COLOURS[k % COLOURS.len()]);
            let pts: Vec<(f64, f64)> = self.drawable(series).map(|(a, b)| (px(a), py(b))).collect();
            if series.line {
                for pair in pts.windows(2) {
                    c.line(pair[0], pair[1], colour, 2, 0);
                }
            }
            for p in &pts {
                c.disc(*p, 3.5, colour);
            }
            let ly = TOP + 14.0 + 18.0 * k as f64;
            c.disc((LEFT + pw + 14.0, ly - 4.0), 4.0, colour);
            c.text(LEFT + pw + 24.0, ly - 9.0, &series.name, 0, ink);
        }
        (c.rgb, w, h)
    }
}

/// The points of `points` on the lower-left Pareto front (no other point is both cheaper
/// and more accurate), sorted by x.
pub fn pareto(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| points[a].0.total_cmp(&points[b].0).then(points[a].1.total_cmp(&points[b].1)));
    let mut best = f64::INFINITY;
    let mut front = Vec::new();
    for i in order {
        if points[i].1 < best {
            best = points[i].1;
            front.push(i);
        }
    }
    front
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_front_keeps_only_undominated_points() {
        let p = [(1.0, 0.5), (2.0, 0.6), (3.0, 0.2), (0.5, 0.9), (3.0, 0.1), (4.0, 0.1)];
        assert_eq!(pareto(&p), vec![3, 0, 4]);
    }

    #[test]
    fn plots_are_svg_with_every_series_and_escaped_text() {
        let plot = Plot {
            title: "error <vs> time".into(),
            x_label: "ms".into(),
            y_label: "%".into(),
            x_log: true,
            y_log: true,
            series: vec![
                Series { name: "a".into(), points: vec![(1.0, 10.0), (10.0, 1.0)], line: true },
                Series { name: "b".into(), points: vec![(5.0, 3.0)], line: false },
            ],
            references: vec![(0.5, "truth noise".into())],
        };
        let s = plot.svg();
        assert!(s.starts_with("<svg") && s.trim_end().ends_with("</svg>"));
        assert!(s.contains("error &lt;vs&gt; time"));
        assert_eq!(s.matches("<polyline").count(), 1);
        assert_eq!(s.matches("<circle").count(), 3 + 2, "three points and two legend marks");
        assert!(s.contains("truth noise"));
        // The same plot as pixels: the right size, the series colours present, and text
        // drawn in ink.
        let (rgb, w, h) = plot.rgb();
        assert_eq!((w, h, rgb.len()), (720, 460, 720 * 460 * 3), "short names fit the usual legend");
        let has = |c: [u8; 3]| rgb.chunks_exact(3).any(|p| p == c);
        assert!(has(rgb_of(COLOURS[0])) && has(rgb_of(COLOURS[1])) && has([40, 40, 40]));
        assert!(!has(rgb_of(COLOURS[2])), "no third series");
    }
}
