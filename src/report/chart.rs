//! The speed-against-accuracy chart: every method's relative error (y, log scale) against its
//! cost (x, log scale), hand-written SVG like `svg.rs`, a pure function of its input.
//!
//! Each method is a vertical bar at its cost from its median error (filled marker) to its p99
//! error (hollow marker of the same colour and shape). Methods of one group with several
//! points (an integrator as its sample count grows) are joined in order of cost by a solid
//! curve through their medians and a dashed one through their p99s, and labelled with their
//! parameters only (`@16x32`); the legend names the group by colour. The Pareto front by p99
//! (the conservative choice: a method is only as good as its bad cases) is a grey step line,
//! and the labels of its members are bold.
//!
//! Values a log axis cannot show are kept on the chart, never dropped: an error of exactly 0
//! sits on the bottom edge as a ▼ (better than the scale), an error that is not a finite
//! non-negative number (NaN, ∞, negative) on the top edge as a ▲ (worse than anything on the
//! scale; such a method is never on the front). A point whose cost is not a positive finite
//! number has no x position: it is named in a note under the chart instead.

use crate::analyse::pareto::{pareto_front, valid_cost};
use crate::report::markup::{xml_escape as escape, Doc as _};

pub use crate::analyse::summary::ChartPoint;

/// Renders the chart as a standalone SVG document (about 900×600, taller when the legend
/// needs it). `x_label` names the cost axis, e.g. "cost (ns per evaluation)".
pub fn speed_accuracy_chart(title: &str, subtitle: &str, x_label: &str, points: &[ChartPoint]) -> String {
    Chart::new(points).render(title, subtitle, x_label)
}

// ---------------------------------------------------------------------------------------------
// Layout constants (pixels).

const WIDTH: f64 = 900.0;
const MIN_HEIGHT: f64 = 600.0;
const PLOT_LEFT: f64 = 72.0;
const PLOT_TOP: f64 = 62.0;
const LEGEND_WIDTH: f64 = 206.0;
const BOTTOM_MARGIN: f64 = 62.0;
const FONT: f64 = 11.0;
/// Distance of the off-scale markers (error 0, or not finite) from the frame.
const EDGE_INSET: f64 = 8.0;
/// Legend row pitch.
const ROW: f64 = 17.0;

/// Okabe–Ito, without its yellow (unreadable on white), black last; shapes change every cycle
/// so that colour and shape together stay distinct for 21 groups.
const PALETTE: [&str; 7] = [
    "#0072B2", "#E69F00", "#009E73", "#D55E00", "#CC79A7", "#56B4E9", "#000000",
];
const GRID: &str = "#e4e4e4";
const FRONT_STROKE: &str = "#555555";

#[derive(Clone, Copy, Debug, PartialEq)]
enum Shape {
    Circle,
    Square,
    Diamond,
}

const SHAPES: [Shape; 3] = [Shape::Circle, Shape::Square, Shape::Diamond];

/// Where an error value goes on the log y axis.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Level {
    /// A positive finite error: on the scale.
    OnScale(f64),
    /// Exactly zero: bottom edge.
    Zero,
    /// NaN, ±∞ or negative: top edge.
    Invalid,
}

impl Level {
    fn of(error: f64) -> Level {
        if error.is_finite() && error > 0.0 {
            Level::OnScale(error)
        } else if error == 0.0 {
            Level::Zero
        } else {
            Level::Invalid
        }
    }
}

/// A log10 axis mapping `[10^lo, 10^hi]` linearly in the exponent onto `[px_lo, px_hi]`
/// (`px_hi < px_lo` for a y axis, which grows upwards).
#[derive(Clone, Copy, Debug)]
struct LogAxis {
    lo: f64,
    hi: f64,
    px_lo: f64,
    px_hi: f64,
}

impl LogAxis {
    /// The axis on which `[min, max]` (positive, finite) fills `[px_lo, px_hi]` less `inset_lo`
    /// and `inset_hi` pixels at either end; a range narrower than a decade is widened to one.
    fn fit(min: f64, max: f64, px_lo: f64, px_hi: f64, inset_lo: f64, inset_hi: f64) -> LogAxis {
        let (mut a, mut b) = (min.log10(), max.log10());
        if b - a < 1.0 {
            let mid = 0.5 * (a + b);
            (a, b) = (mid - 0.5, mid + 0.5);
        }
        let len = (px_hi - px_lo).abs();
        let insets = (inset_lo + inset_hi).min(0.6 * len);
        let scale = insets / (inset_lo + inset_hi).max(1e-9);
        let per_px = (b - a) / (len - insets);
        LogAxis {
            lo: a - inset_lo * scale * per_px,
            hi: b + inset_hi * scale * per_px,
            px_lo,
            px_hi,
        }
    }

    /// Pixel of a positive value; values outside the range are clamped to its ends.
    fn px(&self, v: f64) -> f64 {
        let t = ((v.log10() - self.lo) / (self.hi - self.lo)).clamp(0.0, 1.0);
        self.px_lo + t * (self.px_hi - self.px_lo)
    }

    /// Pixels per decade.
    fn decade_px(&self) -> f64 {
        (self.px_hi - self.px_lo).abs() / (self.hi - self.lo)
    }

    /// Exponents k with 10^k inside the axis.
    fn decades(&self) -> std::ops::RangeInclusive<i32> {
        (self.lo.ceil() as i32)..=(self.hi.floor() as i32)
    }

    /// Ticks as (value, labelled, is a decade): every decade and the 2…9 multiples between.
    /// Decades are labelled every 1, 2, 3, 5 or 10 decades so that labels are at least
    /// `min_gap` pixels apart; when fewer than three decades are on the axis the ×2 and ×5
    /// ticks are labelled as well.
    fn ticks(&self, min_gap: f64) -> Vec<(f64, bool, bool)> {
        let step = [1, 2, 3, 5, 10]
            .into_iter()
            .find(|s| *s as f64 * self.decade_px() >= min_gap)
            .unwrap_or(20);
        let few = self.decades().count() < 3;
        let mut out = Vec::new();
        for k in (self.lo.floor() as i32)..=(self.hi.ceil() as i32) {
            for m in 1..=9 {
                let v = m as f64 * 10f64.powi(k);
                let l = v.log10();
                if l < self.lo - 1e-9 || l > self.hi + 1e-9 {
                    continue;
                }
                let labelled = if m == 1 {
                    k.rem_euclid(step) == 0
                } else {
                    few && (m == 2 || m == 5)
                };
                out.push((v, labelled, m == 1));
            }
        }
        out
    }
}

/// Tick label of `m·10^k`: plain for 0.01 … 1000, else `1e-6`, `2e5`.
fn tick_label(v: f64) -> String {
    let k = v.log10().floor() as i32;
    let m = (v / 10f64.powi(k)).round() as i32;
    if (-2..=3).contains(&k) {
        let s = format!("{:.*}", (-k).max(0) as usize, v);
        s.trim_end_matches('.').to_string()
    } else {
        format!("{m}e{k}")
    }
}

/// Compact value for tooltips; never "NaN" or "inf".
fn value_text(v: f64) -> String {
    if v.is_nan() {
        "not a number".into()
    } else if v.is_infinite() {
        if v > 0.0 { "∞" } else { "−∞" }.into()
    } else if v == 0.0 {
        "0".into()
    } else if (1e-2..1e4).contains(&v.abs()) {
        format!("{}", (v * 1000.0).round() / 1000.0)
    } else {
        format!("{v:.2e}")
    }
}

/// Estimated rendered width of `text` (DejaVu/Helvetica-like sans-serif metrics).
fn text_width(text: &str, size: f64, bold: bool) -> f64 {
    text.chars().count() as f64 * size * if bold { 0.64 } else { 0.59 }
}

#[derive(Clone, Copy, Debug)]
struct Rect {
    x0: f64,
    y0: f64,
    x1: f64,
    y1: f64,
}

impl Rect {
    fn around(x: f64, y: f64, r: f64) -> Rect {
        Rect {
            x0: x - r,
            y0: y - r,
            x1: x + r,
            y1: y + r,
        }
    }

    fn overlap(&self, o: &Rect) -> f64 {
        let w = self.x1.min(o.x1) - self.x0.max(o.x0);
        let h = self.y1.min(o.y1) - self.y0.max(o.y0);
        if w > 0.0 && h > 0.0 {
            w * h
        } else {
            0.0
        }
    }

    fn inside(&self, o: &Rect) -> bool {
        self.x0 >= o.x0 && self.x1 <= o.x1 && self.y0 >= o.y0 && self.y1 <= o.y1
    }
}

/// A method's position and style, computed once.
struct Placed<'a> {
    point: &'a ChartPoint,
    group: usize,
    x: f64,
    median: (Level, f64),
    p99: (Level, f64),
    on_front: bool,
    text: String,
}

struct Group<'a> {
    name: &'a str,
    colour: &'static str,
    shape: Shape,
    /// Indices into `Chart::placed`, by cost.
    members: Vec<usize>,
}

struct Chart<'a> {
    height: f64,
    plot: Rect,
    x: LogAxis,
    y: LogAxis,
    groups: Vec<Group<'a>>,
    placed: Vec<Placed<'a>>,
    /// Points without a valid cost, not drawn.
    unplotted: Vec<&'a ChartPoint>,
    front: Vec<usize>,
    any_zero: bool,
    any_invalid: bool,
}

impl<'a> Chart<'a> {
    fn new(points: &'a [ChartPoint]) -> Chart<'a> {
        // Groups in order of first appearance.
        let mut groups: Vec<Group> = Vec::new();
        let group_of: Vec<usize> = points
            .iter()
            .map(|p| match groups.iter().position(|g| g.name == p.group) {
                Some(k) => k,
                None => {
                    let k = groups.len();
                    groups.push(Group {
                        name: &p.group,
                        colour: PALETTE[k % PALETTE.len()],
                        shape: SHAPES[(k / PALETTE.len()) % SHAPES.len()],
                        members: Vec::new(),
                    });
                    k
                }
            })
            .collect();
        let group_size = |k: usize| group_of.iter().filter(|g| **g == k).count();
        let front_all = pareto_front(points, true);
        let legend_rows = groups.len() as f64 + 10.0;
        let height = MIN_HEIGHT.max(PLOT_TOP + 24.0 + ROW * legend_rows + 24.0);
        let plot = Rect {
            x0: PLOT_LEFT,
            y0: PLOT_TOP,
            x1: WIDTH - LEGEND_WIDTH,
            y1: height - BOTTOM_MARGIN,
        };

        let text_of = |p: &ChartPoint, k: usize| -> String {
            match p.label.strip_prefix(p.group.as_str()) {
                Some(params) if group_size(k) > 1 && !params.is_empty() => params.to_string(),
                _ => p.label.clone(),
            }
        };

        // Axis ranges from the values a log axis can show.
        let costs: Vec<f64> = points.iter().map(|p| p.cost).filter(|c| valid_cost(*c)).collect();
        let errors: Vec<f64> = points
            .iter()
            .filter(|p| valid_cost(p.cost))
            .flat_map(|p| [p.median, p.p99])
            .filter(|e| e.is_finite() && *e > 0.0)
            .collect();
        let range = |v: &[f64], default: (f64, f64)| {
            if v.is_empty() {
                default
            } else {
                (
                    v.iter().copied().fold(f64::INFINITY, f64::min),
                    v.iter().copied().fold(0.0, f64::max),
                )
            }
        };
        let (cmin, cmax) = range(&costs, (1.0, 1000.0));
        let (emin, emax) = range(&errors, (1e-8, 1.0));
        // Room on the right for the label of the costliest point.
        let right_label = points
            .iter()
            .enumerate()
            .filter(|(_, p)| valid_cost(p.cost) && p.cost >= cmax)
            .map(|(i, p)| text_width(&text_of(p, group_of[i]), FONT, front_all.contains(&i)))
            .fold(0.0, f64::max);
        let x = LogAxis::fit(cmin, cmax, plot.x0, plot.x1, 22.0, (right_label + 18.0).max(28.0));
        let any_zero = points
            .iter()
            .any(|p| valid_cost(p.cost) && (p.median == 0.0 || p.p99 == 0.0));
        let any_invalid = points
            .iter()
            .any(|p| valid_cost(p.cost) && [p.median, p.p99].iter().any(|e| Level::of(*e) == Level::Invalid));
        let y = LogAxis::fit(
            emin,
            emax,
            plot.y1,
            plot.y0,
            if any_zero { 34.0 } else { 18.0 },
            if any_invalid { 34.0 } else { 18.0 },
        );
        let level_px = |e: f64| {
            let level = Level::of(e);
            let px = match level {
                Level::OnScale(v) => y.px(v),
                Level::Zero => plot.y1 - EDGE_INSET,
                Level::Invalid => plot.y0 + EDGE_INSET,
            };
            (level, px)
        };

        let mut placed = Vec::new();
        let mut unplotted = Vec::new();
        let mut front = Vec::new();
        for (i, p) in points.iter().enumerate() {
            if !valid_cost(p.cost) {
                unplotted.push(p);
                continue;
            }
            let on_front = front_all.contains(&i);
            if on_front {
                front.push(placed.len());
            }
            groups[group_of[i]].members.push(placed.len());
            placed.push(Placed {
                point: p,
                group: group_of[i],
                x: x.px(p.cost),
                median: level_px(p.median),
                p99: level_px(p.p99),
                on_front,
                text: text_of(p, group_of[i]),
            });
        }
        for g in &mut groups {
            g.members
                .sort_by(|a, b| placed[*a].point.cost.total_cmp(&placed[*b].point.cost));
        }
        front.sort_by(|a, b| {
            let (pa, pb) = (placed[*a].point, placed[*b].point);
            pa.cost.total_cmp(&pb.cost).then(pb.p99.total_cmp(&pa.p99))
        });
        Chart {
            height,
            plot,
            x,
            y,
            groups,
            placed,
            unplotted,
            front,
            any_zero,
            any_invalid,
        }
    }

    fn render(&self, title: &str, subtitle: &str, x_label: &str) -> String {
        let mut s = String::new();
        let (w, h) = (WIDTH, self.height);
        s.line(format_args!(r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="DejaVu Sans, Helvetica, Arial, sans-serif" font-size="{FONT}">"#));
        s.line(format_args!(r#"<rect width="100%" height="100%" fill="white"/>"#));
        s.line(format_args!(
            r##"<text x="{PLOT_LEFT}" y="24" font-size="16" font-weight="bold" fill="#111">{}</text>"##,
            escape(title)
        ));
        if !subtitle.is_empty() {
            s.line(format_args!(
                r##"<text x="{PLOT_LEFT}" y="43" font-size="12" fill="#555">{}</text>"##,
                escape(subtitle)
            ));
        }
        self.axes(&mut s, x_label);
        self.front_line(&mut s);
        self.curves(&mut s);
        for p in &self.placed {
            self.point(&mut s, p);
        }
        self.labels(&mut s);
        self.legend(&mut s);
        if self.placed.is_empty() {
            s.line(format_args!(r##"<text x="{:.1}" y="{:.1}" text-anchor="middle" font-size="13" fill="#777">no method with a cost to plot</text>"##, 0.5 * (self.plot.x0 + self.plot.x1), 0.5 * (self.plot.y0 + self.plot.y1)));
        }
        if !self.unplotted.is_empty() {
            let names: Vec<String> = self.unplotted.iter().map(|p| escape(&p.label)).collect();
            s.line(format_args!(r##"<text x="{PLOT_LEFT}" y="{:.1}" font-size="10" fill="#a00">Not plotted (cost is not a positive number): {}</text>"##, h - 8.0, names.join(", ")));
        }
        s.push_str("</svg>\n");
        s
    }

    /// Gridlines (at decades, and at the labelled ×2, ×5 ticks of a short axis), ticks, tick
    /// labels, frame and axis titles.
    fn axes(&self, s: &mut String, x_label: &str) {
        let p = self.plot;
        s.line(format_args!(r#"<g stroke="{GRID}" stroke-width="1">"#));
        for (v, labelled, decade) in self.x.ticks(40.0) {
            if decade || labelled {
                let x = self.x.px(v);
                s.line(format_args!(
                    r#"<line x1="{x:.1}" y1="{:.1}" x2="{x:.1}" y2="{:.1}"/>"#,
                    p.y0, p.y1
                ));
            }
        }
        for (v, labelled, decade) in self.y.ticks(22.0) {
            if decade || labelled {
                let y = self.y.px(v);
                s.line(format_args!(
                    r#"<line x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}"/>"#,
                    p.x0, p.x1
                ));
            }
        }
        s.push_str("</g>\n");
        // Edge bands for off-scale values, set off by a dotted line.
        if self.any_zero {
            let y = p.y1 - 2.0 * EDGE_INSET;
            s.line(format_args!(
                r##"<line x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#bbb" stroke-dasharray="1 3"/>"##,
                p.x0, p.x1
            ));
            s.line(format_args!(
                r##"<text x="{:.1}" y="{:.1}" text-anchor="end" fill="#444">0</text>"##,
                p.x0 - 7.0,
                p.y1 - EDGE_INSET + 4.0
            ));
        }
        if self.any_invalid {
            let y = p.y0 + 2.0 * EDGE_INSET;
            s.line(format_args!(
                r##"<line x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#bbb" stroke-dasharray="1 3"/>"##,
                p.x0, p.x1
            ));
            s.line(format_args!(
                r##"<text x="{:.1}" y="{:.1}" text-anchor="end" font-size="10" fill="#a00">not finite</text>"##,
                p.x0 - 7.0,
                p.y0 + EDGE_INSET + 4.0
            ));
        }
        s.line(format_args!(
            r##"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="none" stroke="#888"/>"##,
            p.x0,
            p.y0,
            p.x1 - p.x0,
            p.y1 - p.y0
        ));
        // Ticks and labels.
        s.line(format_args!(r##"<g stroke="#888">"##));
        for (v, _, decade) in self.x.ticks(40.0) {
            let x = self.x.px(v);
            let len = if decade { 5.0 } else { 3.0 };
            s.line(format_args!(
                r#"<line x1="{x:.1}" y1="{:.1}" x2="{x:.1}" y2="{:.1}"/>"#,
                p.y1,
                p.y1 + len
            ));
        }
        for (v, _, decade) in self.y.ticks(22.0) {
            let y = self.y.px(v);
            let len = if decade { 5.0 } else { 3.0 };
            s.line(format_args!(
                r#"<line x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}"/>"#,
                p.x0 - len,
                p.x0
            ));
        }
        s.push_str("</g>\n");
        s.line(format_args!(r##"<g fill="#333">"##));
        for (v, labelled, _) in self.x.ticks(40.0) {
            if labelled {
                s.line(format_args!(
                    r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
                    self.x.px(v),
                    p.y1 + 18.0,
                    tick_label(v)
                ));
            }
        }
        for (v, labelled, _) in self.y.ticks(22.0) {
            if labelled {
                s.line(format_args!(
                    r#"<text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"#,
                    p.x0 - 8.0,
                    self.y.px(v) + 4.0,
                    tick_label(v)
                ));
            }
        }
        s.push_str("</g>\n");
        s.line(format_args!(
            r##"<text x="{:.1}" y="{:.1}" text-anchor="middle" font-size="12" fill="#111">{}</text>"##,
            0.5 * (p.x0 + p.x1),
            p.y1 + 38.0,
            escape(x_label)
        ));
        let cy = 0.5 * (p.y0 + p.y1);
        s.line(format_args!(r##"<text x="18" y="{cy:.1}" text-anchor="middle" font-size="12" fill="#111" transform="rotate(-90 18 {cy:.1})">relative error, no floor, reference ≠ 0 (● median, ○ p99; lower is better)</text>"##));
    }

    /// The Pareto front by p99 as a step line: the best p99 attainable for a given cost.
    fn front_line(&self, s: &mut String) {
        let Some(&first) = self.front.first() else { return };
        let mut d = format!("M{:.1} {:.1}", self.placed[first].x, self.placed[first].p99.1);
        for &k in &self.front[1..] {
            d.put(format_args!(" H{:.1} V{:.1}", self.placed[k].x, self.placed[k].p99.1));
        }
        d.put(format_args!(" H{:.1}", self.plot.x1));
        s.line(format_args!(r#"<path d="{d}" fill="none" stroke="{FRONT_STROKE}" stroke-opacity="0.28" stroke-width="7" stroke-linejoin="round" stroke-linecap="round"/>"#));
        s.line(format_args!(
            r#"<path d="{d}" fill="none" stroke="{FRONT_STROKE}" stroke-width="1" stroke-linejoin="round"/>"#
        ));
    }

    /// Curves through the medians (solid) and p99s (dashed) of groups with several points,
    /// broken where a value is off the scale.
    fn curves(&self, s: &mut String) {
        for g in self.groups.iter().filter(|g| g.members.len() > 1) {
            for (p99, dash, width) in [(false, "", 1.6), (true, r#" stroke-dasharray="5 3""#, 1.2)] {
                let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
                for &k in &g.members {
                    let p = &self.placed[k];
                    let (level, y) = if p99 { p.p99 } else { p.median };
                    if matches!(level, Level::OnScale(_)) {
                        runs.last_mut().unwrap().push((p.x, y));
                    } else {
                        runs.push(Vec::new());
                    }
                }
                for run in runs.iter().filter(|r| r.len() > 1) {
                    let pts: Vec<String> = run.iter().map(|(x, y)| format!("{x:.1},{y:.1}")).collect();
                    s.line(format_args!(r#"<polyline points="{}" fill="none" stroke="{}" stroke-width="{width}" stroke-opacity="0.85"{dash}/>"#, pts.join(" "), g.colour));
                }
            }
        }
    }

    /// One method: spread line, p99 marker (hollow), median marker (filled), with a tooltip.
    fn point(&self, s: &mut String, p: &Placed) {
        let g = &self.groups[p.group];
        s.line(format_args!(
            "<g><title>{}: cost {} ns, median error {}, p99 error {}{}</title>",
            escape(&p.point.label),
            value_text(p.point.cost),
            value_text(p.point.median),
            value_text(p.point.p99),
            if p.on_front {
                " (on the Pareto front by p99)"
            } else {
                ""
            }
        ));
        s.line(format_args!(
            r#"<line x1="{x:.1}" y1="{:.1}" x2="{x:.1}" y2="{:.1}" stroke="{}" stroke-width="1.2"/>"#,
            p.median.1,
            p.p99.1,
            g.colour,
            x = p.x
        ));
        marker(s, g.shape, p.p99.0, p.x, p.p99.1, g.colour, false);
        marker(s, g.shape, p.median.0, p.x, p.median.1, g.colour, true);
        s.push_str("</g>\n");
    }

    /// Point labels, placed greedily (front members first, then by cost): to the right of the
    /// median marker if free, else nudged up or down, else to the left; a label moved away
    /// from its marker gets a thin leader line.
    fn labels(&self, s: &mut String) {
        const H: f64 = 12.0;
        let bounds = Rect {
            x0: self.plot.x0 + 2.0,
            y0: self.plot.y0 + 2.0,
            x1: self.plot.x1 - 2.0,
            y1: self.plot.y1 - 2.0,
        };
        // Obstacles: markers (solid) and spread lines (soft).
        let mut hard: Vec<Rect> = Vec::new();
        let mut soft: Vec<Rect> = Vec::new();
        for p in &self.placed {
            hard.push(Rect::around(p.x, p.median.1, 5.5));
            hard.push(Rect::around(p.x, p.p99.1, 5.5));
            let (y0, y1) = (p.median.1.min(p.p99.1), p.median.1.max(p.p99.1));
            soft.push(Rect {
                x0: p.x - 1.0,
                y0,
                x1: p.x + 1.0,
                y1,
            });
        }
        let mut order: Vec<usize> = (0..self.placed.len()).collect();
        order.sort_by(|a, b| {
            let (pa, pb) = (&self.placed[*a], &self.placed[*b]);
            pb.on_front
                .cmp(&pa.on_front)
                .then(pa.point.cost.total_cmp(&pb.point.cost))
        });
        let mut offsets: Vec<f64> = vec![0.0];
        for k in 1..=20 {
            offsets.extend([-6.0 * k as f64, 6.0 * k as f64]);
        }
        let mut taken: Vec<Rect> = Vec::new();
        let (mut out, mut leaders) = (String::new(), String::new());
        for i in order {
            let p = &self.placed[i];
            let width = text_width(&p.text, FONT, p.on_front);
            let (cx, cy) = (p.x, p.median.1);
            let mut best: Option<(f64, Rect, bool, f64)> = None;
            for left in [false, true] {
                for &dy in &offsets {
                    let x0 = if left { cx - 8.0 - width } else { cx + 8.0 };
                    let r = Rect {
                        x0,
                        y0: cy + dy - H / 2.0,
                        x1: x0 + width,
                        y1: cy + dy + H / 2.0,
                    };
                    if !r.inside(&bounds) {
                        continue;
                    }
                    let clash: f64 = taken.iter().chain(&hard).map(|o| r.overlap(o)).sum::<f64>()
                        + 0.1 * soft.iter().map(|o| r.overlap(o)).sum::<f64>();
                    let score = clash * 10.0 + dy.abs() + if left { 20.0 } else { 0.0 };
                    if best.is_none_or(|b| score < b.0) {
                        best = Some((score, r, left, dy));
                    }
                }
            }
            let Some((_, r, left, dy)) = best else { continue };
            taken.push(r);
            let (colour, weight) = if p.on_front {
                ("#000", r#" font-weight="bold""#)
            } else {
                ("#333", "")
            };
            if dy.abs() > 6.5 {
                let (lx, ex) = if left {
                    (r.x1 + 1.0, cx - 5.0)
                } else {
                    (r.x0 - 1.0, cx + 5.0)
                };
                leaders.line(format_args!(
                    r##"<line x1="{ex:.1}" y1="{cy:.1}" x2="{lx:.1}" y2="{:.1}" stroke="#999" stroke-width="0.7"/>"##,
                    cy + dy
                ));
            }
            let (tx, anchor) = if left { (r.x1, "end") } else { (r.x0, "start") };
            out.line(format_args!(
                r#"<text x="{tx:.1}" y="{:.1}" text-anchor="{anchor}" fill="{colour}"{weight}>{}</text>"#,
                cy + dy + 4.0,
                escape(&p.text)
            ));
        }
        s.push_str(&leaders);
        // A white halo keeps labels legible over gridlines and curves.
        s.line(format_args!(
            r#"<g stroke="white" stroke-width="3" stroke-linejoin="round" paint-order="stroke">"#
        ));
        s.push_str(&out);
        s.push_str("</g>\n");
    }

    /// Legend: one row per group, then the key to markers, curves and the front.
    fn legend(&self, s: &mut String) {
        let x0 = self.plot.x1 + 22.0;
        let mut y = self.plot.y0 + 4.0;
        s.line(format_args!(
            r##"<text x="{x0:.1}" y="{y:.1}" font-weight="bold" fill="#111">Methods</text>"##
        ));
        y += ROW;
        for g in &self.groups {
            let my = y - 4.0;
            if g.members.len() > 1 {
                s.line(format_args!(
                    r#"<line x1="{x0:.1}" y1="{my:.1}" x2="{:.1}" y2="{my:.1}" stroke="{}" stroke-width="1.6"/>"#,
                    x0 + 22.0,
                    g.colour
                ));
            }
            marker(s, g.shape, Level::OnScale(1.0), x0 + 11.0, my, g.colour, true);
            // A name too long for the column is set smaller rather than cut off.
            let room = WIDTH - (x0 + 30.0) - 6.0;
            let width = text_width(g.name, FONT, false);
            let squeeze = if width > room {
                format!(r#" font-size="{:.1}""#, (FONT * room / width).max(6.0))
            } else {
                String::new()
            };
            s.line(format_args!(
                r#"<text x="{:.1}" y="{y:.1}"{squeeze}>{}</text>"#,
                x0 + 30.0,
                escape(g.name)
            ));
            y += ROW;
        }
        y += 0.6 * ROW;
        s.line(format_args!(
            r##"<text x="{x0:.1}" y="{y:.1}" font-weight="bold" fill="#111">Key</text>"##
        ));
        y += ROW;
        let grey = "#555555";
        let text = |s: &mut String, y: f64, t: &str| {
            s.line(format_args!(r#"<text x="{:.1}" y="{y:.1}">{t}</text>"#, x0 + 30.0));
        };
        // Median and p99 with their spread.
        let my = y - 4.0;
        s.line(format_args!(
            r#"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="{grey}" stroke-width="1.2"/>"#,
            x0 + 11.0,
            my + ROW,
            x0 + 11.0,
            my
        ));
        marker(s, Shape::Circle, Level::OnScale(1.0), x0 + 11.0, my, grey, false);
        marker(s, Shape::Circle, Level::OnScale(1.0), x0 + 11.0, my + ROW, grey, true);
        text(s, y, "p99 relative error");
        text(s, y + ROW, "median relative error");
        y += 2.0 * ROW;
        let curves = if self.groups.iter().any(|g| g.members.len() > 1) {
            &[
                ("integrator: median", ""),
                ("integrator: p99", r#" stroke-dasharray="5 3""#),
            ][..]
        } else {
            &[]
        };
        for &(t, dash) in curves {
            let my = y - 4.0;
            s.line(format_args!(
                r#"<line x1="{x0:.1}" y1="{my:.1}" x2="{:.1}" y2="{my:.1}" stroke="{grey}" stroke-width="1.4"{dash}/>"#,
                x0 + 22.0
            ));
            text(s, y, t);
            y += ROW;
        }
        let my = y - 4.0;
        let d = format!(
            "M{x0:.1} {:.1} H{:.1} V{:.1} H{:.1}",
            my - 4.0,
            x0 + 11.0,
            my + 4.0,
            x0 + 22.0
        );
        s.line(format_args!(r#"<path d="{d}" fill="none" stroke="{FRONT_STROKE}" stroke-opacity="0.28" stroke-width="7" stroke-linejoin="round" stroke-linecap="round"/>"#));
        s.line(format_args!(
            r#"<path d="{d}" fill="none" stroke="{FRONT_STROKE}" stroke-width="1"/>"#
        ));
        s.line(format_args!(
            r##"<text x="{:.1}" y="{y:.1}" font-weight="bold" fill="#000">Pareto front by p99</text>"##,
            x0 + 30.0
        ));
        y += 0.85 * ROW;
        s.line(format_args!(
            r##"<text x="{:.1}" y="{y:.1}" font-size="10" fill="#555">(bold label: on the front)</text>"##,
            x0 + 30.0
        ));
        y += ROW;
        if self.any_zero {
            marker(s, Shape::Circle, Level::Zero, x0 + 11.0, y - 4.0, grey, true);
            text(s, y, "error 0 (bottom edge)");
            y += ROW;
        }
        if self.any_invalid {
            marker(s, Shape::Circle, Level::Invalid, x0 + 11.0, y - 4.0, grey, true);
            text(s, y, "error not finite (top edge)");
        }
    }
}

/// A marker centred on (x, y): the group's shape on the scale, a triangle pointing at the
/// edge for an off-scale error (▼ zero, ▲ not finite). Filled for the median, hollow (white
/// inside) for the p99.
fn marker(s: &mut String, shape: Shape, level: Level, x: f64, y: f64, colour: &str, filled: bool) {
    let paint = if filled {
        format!(r#"fill="{colour}" stroke="{colour}" stroke-width="1""#)
    } else {
        format!(r#"fill="white" stroke="{colour}" stroke-width="1.6""#)
    };
    let poly = |pts: &[(f64, f64)]| {
        let p: Vec<String> = pts
            .iter()
            .map(|(dx, dy)| format!("{:.1},{:.1}", x + dx, y + dy))
            .collect();
        format!(r#"<polygon points="{}" {paint}/>"#, p.join(" "))
    };
    let element = match (level, shape) {
        (Level::Zero, _) => poly(&[(-5.0, -4.0), (5.0, -4.0), (0.0, 5.0)]),
        (Level::Invalid, _) => poly(&[(-5.0, 4.0), (5.0, 4.0), (0.0, -5.0)]),
        (Level::OnScale(_), Shape::Circle) => format!(r#"<circle cx="{x:.1}" cy="{y:.1}" r="4" {paint}/>"#),
        (Level::OnScale(_), Shape::Square) => {
            format!(
                r#"<rect x="{:.1}" y="{:.1}" width="7" height="7" {paint}/>"#,
                x - 3.5,
                y - 3.5
            )
        }
        (Level::OnScale(_), Shape::Diamond) => poly(&[(0.0, -5.0), (5.0, 0.0), (0.0, 5.0), (-5.0, 0.0)]),
    };
    s.push_str(&element);
    s.push('\n');
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pt(label: &str, cost: f64, median: f64, p99: f64) -> ChartPoint {
        let group = label.split('@').next().unwrap().to_string();
        ChartPoint {
            label: label.into(),
            group,
            cost,
            median,
            p99,
        }
    }

    /// A chart shaped like a real sweep: closed forms, a published integrator, a convergent
    /// integrator family, a 2-D integrator family, an exact method and a broken one.
    fn sample() -> Vec<ChartPoint> {
        vec![
            pt("line.ltc2017", 41.0, 8.1e-7, 7.7e-4),
            pt("line.ltc2017_fwt", 40.0, 8.1e-7, 7.7e-4),
            pt("line.ltc2023", 33.0, 3.1e-5, 1.1e-1),
            pt("line.ltc2023_full", 36.0, 3.1e-5, 1.1e-1),
            pt("line.ltc2023_fix", 38.0, 9.0e-7, 8.0e-4),
            pt("line.numeric_paper", 820.0, 5.8e-4, 9.1e-2),
            pt("line.numeric@4", 70.0, 2.4e-4, 6.0e-2),
            pt("line.numeric@8", 125.0, 6.1e-6, 9.5e-3),
            pt("line.numeric@16", 240.0, 9.0e-7, 9.8e-5),
            pt("line.numeric@64", 930.0, 9.0e-7, 8.7e-6),
            pt("line.numeric@256", 3700.0, 9.0e-7, 3.0e-6),
            pt("cylinder.numeric_paper", 16000.0, 2.1e-3, 4.0e-2),
            pt("cylinder.numeric@4x8", 450.0, 3.0e-3, 2.0e-1),
            pt("cylinder.numeric@8x16", 1600.0, 1.2e-4, 1.5e-2),
            pt("cylinder.numeric@16x32", 6200.0, 2.0e-6, 3.5e-4),
            pt("cylinder.numeric@32x64", 24500.0, 9.5e-7, 4.0e-6),
            pt("cylinder.line", 45.0, 2.0e-3, 6.0e-2),
            pt("tube.line", 60.0, 4.0e-3, 2.5e-1),
            pt("caps.point", 12.0, 0.0, 3.0e-2),
            pt("rectangle.line", 52.0, 1.5e-2, f64::NAN),
        ]
    }

    /// Checks that `s` is well-formed enough to be XML: tags balanced and properly nested,
    /// attribute values quoted, no raw `<` or stray `&` in text. Returns the first problem.
    fn check_xml(s: &str) -> Result<(), String> {
        let mut stack: Vec<String> = Vec::new();
        let mut rest = s.trim_start();
        let mut roots = 0;
        while !rest.is_empty() {
            let Some(open) = rest.find('<') else {
                check_text(rest)?;
                break;
            };
            check_text(&rest[..open])?;
            if !rest[..open].trim().is_empty() && stack.is_empty() {
                return Err(format!("text outside the root: {:?}", &rest[..open]));
            }
            rest = &rest[open..];
            let close = rest.find('>').ok_or("unterminated tag")?;
            let tag = &rest[1..close];
            rest = &rest[close + 1..];
            if let Some(name) = tag.strip_prefix('/') {
                match stack.pop() {
                    Some(open) if open == name.trim() => {}
                    other => return Err(format!("</{name}> closes {other:?}")),
                }
                continue;
            }
            let self_closing = tag.ends_with('/');
            let body = tag.trim_end_matches('/');
            let name: String = body.chars().take_while(|c| !c.is_whitespace()).collect();
            if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == ':' || c == '-') {
                return Err(format!("bad tag name in <{tag}>"));
            }
            // Attributes: name="value" pairs, values free of < and raw &.
            let mut attrs = body[name.len()..].trim();
            while !attrs.is_empty() {
                let eq = attrs.find("=\"").ok_or(format!("unquoted attribute in <{tag}>"))?;
                let end = attrs[eq + 2..]
                    .find('"')
                    .ok_or(format!("unterminated attribute in <{tag}>"))?;
                check_text(&attrs[eq + 2..eq + 2 + end])?;
                attrs = attrs[eq + 2 + end + 1..].trim_start();
            }
            if stack.is_empty() {
                roots += 1;
            }
            if !self_closing {
                stack.push(name);
            }
        }
        match (stack.is_empty(), roots) {
            (true, 1) => Ok(()),
            (false, _) => Err(format!("unclosed: {stack:?}")),
            (true, n) => Err(format!("{n} root elements")),
        }
    }

    fn check_text(t: &str) -> Result<(), String> {
        if t.contains('<') || t.contains('>') {
            return Err(format!("raw < or > in {t:?}"));
        }
        for (k, _) in t.match_indices('&') {
            let entity = &t[k..t.len().min(k + 6)];
            if !["&amp;", "&lt;", "&gt;", "&quot;"]
                .iter()
                .any(|e| entity.starts_with(e))
            {
                return Err(format!("stray & in {t:?}"));
            }
        }
        Ok(())
    }

    #[test]
    fn xml_checker_rejects_broken_documents() {
        assert!(check_xml("<svg><g></g></svg>").is_ok());
        assert!(check_xml("<svg><g></svg>").is_err());
        assert!(check_xml("<svg><g/></svg></svg>").is_err());
        assert!(check_xml("<svg><text>a & b</text></svg>").is_err());
        assert!(check_xml("<svg><text>a < b</text></svg>").is_err());
        assert!(check_xml("<svg><rect x=1/></svg>").is_err());
        assert!(check_xml("<svg/><svg/>").is_err());
    }

    #[test]
    fn svg_is_well_formed_and_shows_every_label() {
        let mut points = sample();
        points.push(pt("odd<&>\"name\"", 7.0, 1e-3, 1e-2));
        let svg = speed_accuracy_chart(
            "Speed & accuracy <line>",
            "sub & title",
            "cost (ns) <per eval>",
            &points,
        );
        check_xml(&svg).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert_eq!(svg.matches("<svg").count(), 1);
        for p in &points {
            assert!(svg.contains(&escape(&p.label)), "label {} missing", p.label);
        }
        assert!(svg.contains("odd&lt;&amp;&gt;&quot;name&quot;"));
        assert!(!svg.contains("odd<"));
        assert!(svg.contains(r#"fill="white""#));
        // Integrator points are labelled by their parameters, single methods in full.
        assert!(svg.contains(">@16x32</text>"));
        assert!(svg.contains(">line.ltc2023</text>"));
    }

    #[test]
    fn front_labels_are_bold_and_others_are_not() {
        let points = sample();
        let svg = speed_accuracy_chart("t", "", "cost", &points);
        let front = pareto_front(&points, true);
        assert!(!front.is_empty());
        let label_line = |text: &str| {
            svg.lines()
                .find(|l| l.starts_with("<text") && l.ends_with(&format!(">{text}</text>")))
                .unwrap()
                .to_string()
        };
        for (i, p) in points.iter().enumerate() {
            let text = match p.label.split_once('@') {
                Some((_, params)) => format!("@{params}"),
                None => p.label.clone(),
            };
            let line = label_line(&escape(&text));
            assert_eq!(line.contains("font-weight=\"bold\""), front.contains(&i), "{line}");
        }
        assert!(svg.contains("Pareto front by p99"));
    }

    #[test]
    fn log_axis_is_monotone_with_equal_decades() {
        for (px_lo, px_hi) in [(100.0, 700.0), (540.0, 60.0)] {
            let axis = LogAxis::fit(3e-7, 2e-1, px_lo, px_hi, 20.0, 20.0);
            let sign = (px_hi - px_lo).signum();
            let mut last = f64::NEG_INFINITY;
            for k in 0..400 {
                let v = 3e-7 * 10f64.powf(k as f64 * 0.015);
                let px = sign * axis.px(v);
                assert!(px > last, "not monotone at {v}");
                last = px;
            }
            // The data sits inside the insets, on the right side of the axis.
            assert!((axis.px(3e-7) - (px_lo + 20.0 * sign)).abs() < 1e-9);
            assert!((axis.px(2e-1) - (px_hi - 20.0 * sign)).abs() < 1e-9);
            let decades: Vec<f64> = axis.decades().map(|k| axis.px(10f64.powi(k))).collect();
            assert_eq!(decades.len(), 6, "1e-6 … 1e-1");
            let step = decades[1] - decades[0];
            assert!(step.abs() > 10.0);
            for w in decades.windows(2) {
                assert!((w[1] - w[0] - step).abs() < 1e-9, "{decades:?}");
            }
            // 2·10^k sits log10(2) of a decade above 10^k.
            assert!((axis.px(2e-4) - axis.px(1e-4) - step * 2f64.log10()).abs() < 1e-9);
            let labelled: Vec<String> = axis
                .ticks(22.0)
                .iter()
                .filter(|t| t.1)
                .map(|t| tick_label(t.0))
                .collect();
            assert_eq!(labelled, ["1e-6", "1e-5", "1e-4", "1e-3", "0.01", "0.1"]);
        }
        // Less than a decade of data still gets a decade of axis and labelled ×2, ×5 ticks.
        let narrow = LogAxis::fit(30.0, 40.0, 0.0, 600.0, 0.0, 0.0);
        assert!(narrow.hi - narrow.lo >= 1.0 - 1e-12);
        assert!(narrow.ticks(40.0).iter().filter(|t| t.1).count() >= 2);
    }

    #[test]
    fn tick_labels() {
        let cases = [
            (1e-6, "1e-6"),
            (0.01, "0.01"),
            (0.1, "0.1"),
            (1.0, "1"),
            (20.0, "20"),
            (1000.0, "1000"),
        ];
        for (v, want) in cases {
            assert_eq!(tick_label(v), want);
        }
        assert_eq!(tick_label(5e4), "5e4");
        assert_eq!(tick_label(2e-3), "2e-3");
    }

    #[test]
    fn off_scale_values_never_produce_nan_coordinates() {
        let points = vec![
            pt("zero", 10.0, 0.0, 0.0),
            pt("nan", 20.0, f64::NAN, f64::NAN),
            pt("huge", 30.0, 1e-3, f64::INFINITY),
            pt("negative", 40.0, -1.0, 1e-2),
            pt("no-cost", f64::NAN, 1e-3, 1e-2),
            pt("zero-cost", 0.0, 1e-3, 1e-2),
            pt("endless-cost", f64::INFINITY, 1e-3, 1e-2),
            pt("fine@1", 50.0, 1e-4, 1e-3),
            pt("fine@2", 60.0, f64::NAN, 1e-4),
            pt("fine@3", 70.0, 1e-6, 0.0),
        ];
        for set in [&points[..], &points[..4], &points[4..7], &[]] {
            let svg = speed_accuracy_chart("t", "s", "cost", set);
            check_xml(&svg).unwrap();
            assert!(!svg.contains("NaN") && !svg.contains("inf"), "{svg}");
            for p in set {
                assert!(svg.contains(&p.label), "{} missing", p.label);
            }
        }
        // One point, or all points at one cost, still gives a finite chart.
        let svg = speed_accuracy_chart("t", "", "cost", &[pt("one", 5.0, 1e-3, 1e-3)]);
        assert!(!svg.contains("NaN") && !svg.contains("inf"));
    }

    /// Writes the sample chart to the temporary directory (`cargo test -- --ignored`).
    #[test]
    #[ignore]
    fn write_sample_chart() {
        let svg = speed_accuracy_chart(
            "Speed against accuracy: line, cylinder and tube methods",
            "GPU (llvmpipe), f32, 20000 configurations, diffuse",
            "cost (ns per evaluation)",
            &sample(),
        );
        let path = std::env::temp_dir().join("chart_sample.svg");
        crate::io::write_bytes(&path, svg.as_bytes()).unwrap();
        println!("{}", path.display());
    }
}
