//! A case file (`cases/*.toml`): the distributions, seed, materials, methods, bin axes,
//! comparisons and tolerances of one sweep (docs/statistics.md, "Sweeps"). Unknown keys are errors.

use crate::input::target::Target;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;

/// The checks of a case file's values beyond their types.
pub mod values;

/// A family's light texture as a case distribution.
pub mod texture;

/// A one-dimensional distribution of a dimensionless parameter.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(tag = "dist", rename_all = "snake_case", deny_unknown_fields)]
pub enum Dist {
    Fixed {
        value: f64,
    },
    Uniform {
        min: f64,
        max: f64,
    },
    LogUniform {
        min: f64,
        max: f64,
    },
    /// Magnitude log-uniform in [min, max], sign + or − with equal odds.
    SignedLogUniform {
        min: f64,
        max: f64,
    },
}

impl Dist {
    /// The smallest and largest value it can draw.
    pub fn bounds(&self) -> (f64, f64) {
        match *self {
            Dist::Fixed { value } => (value, value),
            Dist::Uniform { min, max } | Dist::LogUniform { min, max } => (min, max),
            Dist::SignedLogUniform { max, .. } => (-max, max),
        }
    }

    fn check(&self, name: &str) -> Result<(), String> {
        match *self {
            Dist::Fixed { value } if !value.is_finite() => Err(format!("{name}: value must be finite")),
            Dist::Uniform { min, max } if !(min.is_finite() && max.is_finite() && min <= max) => {
                Err(format!("{name}: need finite min <= max, got [{min}, {max}]"))
            }
            Dist::LogUniform { min, max } | Dist::SignedLogUniform { min, max }
                if !(min > 0.0 && max.is_finite() && min <= max) =>
            {
                Err(format!("{name}: log_uniform needs 0 < min <= max, got [{min}, {max}]"))
            }
            _ => Ok(()),
        }
    }
}

/// Where the segment is, in units of its distance d to the shading point.
/// The foot point p_o (closest point of the infinite line) is at distance `distance`,
/// `elevation` degrees above the horizon, `azimuth` degrees around the normal; the
/// tangent makes angle `tilt_angle` (degrees) with the horizontal direction in the plane
/// perpendicular to p_o; the segment has length `length`·d and its midpoint sits at
/// abscissa `center`·d from p_o along the tangent.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Geometry {
    #[serde(default = "one")]
    pub distance: Dist,
    pub elevation: Dist,
    #[serde(default = "full_turn")]
    pub azimuth: Dist,
    pub tilt_angle: Dist,
    pub length: Dist,
    pub center: Dist,
    /// Tube radius over d (targets cylinder, caps, tube).
    #[serde(default)]
    pub radius: Option<Dist>,
    /// Rectangle width over d, and the angle (degrees) of its normal about the tangent.
    #[serde(default)]
    pub rect_width: Option<Dist>,
    #[serde(default)]
    pub rect_angle: Option<Dist>,
    /// Sets p2's height above the surface (units of d) after the segment is built: end points
    /// on or just under the horizon (the stability suite).
    #[serde(default)]
    pub endpoint_height: Option<Dist>,
}

impl Geometry {
    fn check(&self, at: &str) -> Result<(), String> {
        for (name, d) in [
            ("distance", &self.distance),
            ("elevation", &self.elevation),
            ("azimuth", &self.azimuth),
            ("tilt_angle", &self.tilt_angle),
            ("length", &self.length),
            ("center", &self.center),
        ] {
            d.check(&format!("{at}.{name}"))?;
        }
        for (name, d) in [
            ("radius", &self.radius),
            ("rect_width", &self.rect_width),
            ("rect_angle", &self.rect_angle),
            ("endpoint_height", &self.endpoint_height),
        ] {
            if let Some(d) = d {
                d.check(&format!("{at}.{name}"))?;
            }
        }
        Ok(())
    }
}

fn one() -> Dist {
    Dist::Fixed { value: 1.0 }
}
fn full_turn() -> Dist {
    Dist::Uniform { min: 0.0, max: 360.0 }
}

/// A material family to sample. LTC lobes are drawn as
/// `M⁻¹ = [[aspect/alpha, 0, -aspect/alpha·tan(peak)], [0, 1/alpha, 0], [shear, 0, 1]]`
/// (the isotropic-GGX sparsity, lobe peak `peak` degrees off the normal); `ltc_full`
/// then rotates it about the normal by `rotation` degrees (an anisotropic lobe turned
/// against the light, as in seed 004), which fills every entry.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialFamily {
    pub name: String,
    pub kind: MaterialKind,
    pub count: usize,
    /// This family's own geometry, in place of the case's (the stability suite's families).
    #[serde(default)]
    pub geometry: Option<Geometry>,
    #[serde(default)]
    pub alpha: Option<Dist>,
    #[serde(default)]
    pub aspect: Option<Dist>,
    #[serde(default)]
    pub peak: Option<Dist>,
    #[serde(default)]
    pub shear: Option<Dist>,
    #[serde(default)]
    pub rotation: Option<Dist>,
    /// `ggx`: the view's angle from the normal (degrees).
    #[serde(default)]
    pub view_angle: Option<Dist>,
    /// `ggx`: the view's azimuth against the roughness axes x, y (degrees; default 0).
    #[serde(default)]
    pub view_azimuth: Option<Dist>,
    /// `ggx`: αy/αx, with αx·αy = α² (default 1: isotropic).
    #[serde(default)]
    pub anisotropy: Option<Dist>,
    /// `ggx`: Schlick's F0, in [0, 1] (absent: F = 1, and nothing is drawn, so the family's
    /// other draws are as without it). A fixed value or a range.
    #[serde(default)]
    pub f0: Option<Dist>,
    /// `ggx`: where the LTC methods' M⁻¹ comes from (`table`, `table_f16`, `published`,
    /// `published_f16`, `fit`, `aniso`, `aniso_f16`; default `table`, or `fit` when
    /// anisotropic). See docs/ggx.md.
    #[serde(default)]
    pub ltc: Option<String>,
    /// A light texture drawn per configuration (`[materials.texture]`, src/input/case/texture.rs):
    /// absent, the light is untextured and nothing is drawn for it.
    #[serde(default)]
    pub texture: Option<texture::TextureSpec>,
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum MaterialKind {
    Diffuse,
    LtcSparse,
    LtcFull,
    /// The GGX lobe of docs/conventions.md; LTC methods are fed a fitted LTC (src/ltc).
    Ggx,
    /// An `ltc` material whose M⁻¹ is the fitted GGX LTC of a drawn (α, view, anisotropy) as
    /// the `ltc` feed gives it, in the frame where the view lies in the xz-plane: realistic
    /// matrices for cases that measure a formula against the LTC integral (docs/ggx.md).
    LtcGgx,
}

/// One bin axis: a derived parameter of each configuration and the bin edges.
#[derive(Clone, Debug, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct BinAxis {
    pub axis: String,
    pub edges: Vec<f64>,
    /// This axis's own `min_per_bin` (the case's when absent): a region the natural sample
    /// rarely reaches (the highlight) can be topped up while the others are not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_per_bin: Option<usize>,
}

impl BinAxis {
    /// The configurations each bin of this axis is topped up to.
    pub fn min_per_bin(&self, case_min: usize) -> usize {
        self.min_per_bin.unwrap_or(case_min)
    }

    /// Which bin holds `x` (the last bin includes its upper edge); None outside or for NaN.
    pub fn index(&self, x: f64) -> Option<usize> {
        bin_index(&self.edges, x)
    }
}

/// Which bin of `edges` holds `x` (the last bin includes its upper edge); None outside.
pub fn bin_index(edges: &[f64], x: f64) -> Option<usize> {
    if !(x >= edges[0] && x <= edges[edges.len() - 1]) {
        return None;
    }
    Some(
        edges
            .partition_point(|&e| e <= x)
            .saturating_sub(1)
            .min(edges.len() - 2),
    )
}

/// The worst-case search (src/measure/search.rs): which methods, and how hard to look.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SearchSpec {
    pub methods: Vec<String>,
    /// Starting points per family: its worst configurations in the random sample.
    #[serde(default = "default_restarts")]
    pub restarts: usize,
    /// Refinement steps, each one GPU dispatch of restarts × population candidates.
    #[serde(default = "default_steps")]
    pub steps: usize,
    #[serde(default = "default_population")]
    pub population: usize,
}

fn default_restarts() -> usize {
    8
}
fn default_steps() -> usize {
    20
}
fn default_population() -> usize {
    32
}

/// A validity map: every method's error binned over two axes at once.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Map {
    pub x: BinAxis,
    pub y: BinAxis,
    /// The methods drawn (default: all).
    #[serde(default)]
    pub methods: Vec<String>,
}

impl Map {
    pub fn shows(&self, label: &str) -> bool {
        self.methods.is_empty() || self.methods.iter().any(|m| m == label)
    }
}

/// Thresholds a method must meet for the verdict, on each material's whole sample
/// (relative error of the f32 result; `nan` counts NaN and ±inf together).
#[derive(Clone, Debug, Default, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct Tolerance {
    pub median: Option<f64>,
    pub p99: Option<f64>,
    pub max: Option<f64>,
    #[serde(default)]
    pub nan: Option<u64>,
    /// Most configurations with a reference of exactly 0 the method may light.
    #[serde(default)]
    pub false_light: Option<u64>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Case {
    pub name: String,
    pub title: String,
    pub seed: u64,
    /// Retired: findings are `[[claims]]` now. Present only to say so.
    #[serde(default)]
    pub notes: Option<String>,
    /// Findings computed from the run: expectation plus explanation (src/analyse/claims.rs).
    #[serde(default)]
    pub claims: Vec<ClaimSpec>,
    pub methods: Vec<String>,
    /// Every bin of every axis gets at least this many configurations: the natural sample,
    /// topped up by rejection sampling where it is thinner (src/input/sampler.rs, `top_up`).
    #[serde(default = "default_min_per_bin")]
    pub min_per_bin: usize,
    /// The top-up budget, as a multiple of the family's count: each bin's top-ups draw at most
    /// `sampler::TOPUP_CAP_FACTOR` times it (`sampler::topup_cap`).
    #[serde(default = "default_topup_draws")]
    pub topup_draws: usize,
    /// The disagreement search between compared pairs (on by default when `compare` is set).
    #[serde(default)]
    pub disagreements: Option<DisagreeSpec>,
    /// The geometry of every family that does not bring its own.
    #[serde(default)]
    pub geometry: Option<Geometry>,
    pub materials: Vec<MaterialFamily>,
    #[serde(default)]
    pub bins: Vec<BinAxis>,
    /// Two-dimensional validity maps (tables and SVG heat maps of the p99 error).
    #[serde(default)]
    pub maps: Vec<Map>,
    #[serde(default)]
    pub search: Option<SearchSpec>,
    /// Pairs of methods whose results are compared configuration by configuration.
    #[serde(default, deserialize_with = "pairs")]
    pub compare: Vec<[String; 2]>,
    #[serde(default)]
    pub tolerances: BTreeMap<String, Tolerance>,
    /// Absolute floor of the relative error's denominator, per target, in units where d = 1.
    #[serde(default)]
    pub error_floor: BTreeMap<String, f64>,
    /// What a user of the scene accepts: the "What to ship" answer judges every method against
    /// it ([`Case::budget`] gives the default when absent).
    #[serde(default)]
    pub budget: Option<Budget>,
    /// Opt-in: the report's "Any conforming driver" section (docs/envelope.md).
    #[serde(default)]
    pub envelope: Option<EnvelopeSpec>,
}

/// `envelope = { sample = N [, gate = true] [, max_past_budget = S] }`: each method's envelope
/// on N configurations spread over those it applies to (the attribution's spread subset, at
/// most 2048). The gate checks are opt-in (docs/envelope.md, "In the gate"): `gate = true`
/// fails the sweep when a GPU value leaves its envelope; `max_past_budget` when more than that
/// share of a method's envelopes reach past the budget.
#[derive(Clone, Debug, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct EnvelopeSpec {
    pub sample: usize,
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub gate: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_past_budget: Option<f64>,
}

/// What a user of the scene would accept (docs/statistics.md, "What to ship"): a method meets
/// it in a region when an upper confidence bound of the `quantile` of the `statistic` is at most
/// `value`, over at least `min_count` configurations, judged against `target`.
#[derive(Clone, Debug, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct Budget {
    /// The statistic: only `relative_error` for now (of the f32 result; docs/statistics.md).
    #[serde(default = "default_statistic")]
    pub statistic: String,
    /// A fraction strictly between 0 and 1: 0.99 is p99.
    pub quantile: f64,
    /// The most the bound of that quantile may be.
    pub value: f64,
    /// The target every method is judged against; a method whose target's surface-clipped view
    /// is this one (`line` for `line_upper`) is judged in that view. Absent: the case's first
    /// method's target, clipped to the surface where it can be (`line` → `line_upper`).
    #[serde(default)]
    pub target: Option<crate::input::target::Target>,
    /// The fewest configurations a region (a bin, or the whole material) needs to be judged.
    #[serde(default = "default_min_count")]
    pub min_count: usize,
    /// Whether the cheapest method that meets the budget is the answer (true), or the most
    /// accurate one (false: ranked by the bound).
    #[serde(default = "default_cost_matters")]
    pub cost_matters: bool,
}

/// The statistic of every budget for now.
pub const BUDGET_STATISTIC: &str = "relative_error";

fn default_statistic() -> String {
    BUDGET_STATISTIC.to_string()
}
fn default_min_count() -> usize {
    crate::limits::MIN_JUDGED
}
fn default_cost_matters() -> bool {
    true
}

impl Default for Budget {
    /// The budget of a case without `[budget]`: p99 relative error at most 1e-2 (an 8-bit
    /// channel's step on a bright light), at least 300 configurations per region, cost matters.
    fn default() -> Self {
        Budget {
            statistic: default_statistic(),
            quantile: 0.99,
            value: 1e-2,
            target: None,
            min_count: default_min_count(),
            cost_matters: default_cost_matters(),
        }
    }
}

/// `compare` entries are pairs: a third name is an error, not dropped.
fn pairs<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<[String; 2]>, D::Error> {
    let lists = Vec::<Vec<String>>::deserialize(d)?;
    lists
        .into_iter()
        .enumerate()
        .map(|(i, l)| {
            <[String; 2]>::try_from(l.clone()).map_err(|_| {
                serde::de::Error::custom(format!(
                    "compare[{i}] = {l:?}: each entry names exactly two methods, got {}",
                    l.len()
                ))
            })
        })
        .collect()
}

/// Derived parameters a bin axis can name (`src/input/sampler.rs`, `Axes`).
pub const AXES: &[&str] = &[
    "length",
    "center",
    "elevation",
    "tilt",
    "alpha",
    "reach_near",
    "reach_far",
    "subtended",
    "height",
    "reach_near_o",
    "reach_o",
    "reach_far_o",
    "subtended_o",
    "height_o",
    "tilt_o",
    "radius",
    "cap_straddle",
    "width",
    "rect_angle",
    "view_angle",
    "anisotropy",
    "highlight",
    "frequency",
    "texture_contrast",
    "distance_over_length",
];

/// A finding: an expectation over the run's analysis and the explanation that holds while it
/// does (src/analyse/claims.rs). The text's `{expression}` placeholders are filled in from the run.
#[derive(Clone, Debug, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct ClaimSpec {
    pub id: String,
    /// A boolean expression over the analysis, e.g.
    /// `p99("line.ltc2023", "diffuse") > 100 * p99("line.ltc2017", "diffuse")`.
    pub expect: String,
    /// Markdown; `{expression}` is replaced by the expression's value in this run.
    pub text: String,
}

/// The disagreement search between compared pairs (src/measure/search.rs).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DisagreeSpec {
    /// Starting points per pair, direction and family: the sample's largest error ratios.
    #[serde(default = "default_disagree_restarts")]
    pub restarts: usize,
    #[serde(default = "default_disagree_steps")]
    pub steps: usize,
    #[serde(default = "default_disagree_population")]
    pub population: usize,
    /// The smallest error the ratio err_A / max(err_B, epsilon) divides by.
    #[serde(default = "default_epsilon")]
    pub epsilon: f64,
}

impl Default for DisagreeSpec {
    fn default() -> Self {
        DisagreeSpec {
            restarts: default_disagree_restarts(),
            steps: default_disagree_steps(),
            population: default_disagree_population(),
            epsilon: default_epsilon(),
        }
    }
}

fn default_disagree_restarts() -> usize {
    4
}
fn default_disagree_steps() -> usize {
    12
}
fn default_disagree_population() -> usize {
    24
}
/// One unit in the last place of f32 at 1: below it an f32 result is as exact as f32 allows.
fn default_epsilon() -> f64 {
    f32::EPSILON as f64
}
fn default_min_per_bin() -> usize {
    500
}
fn default_topup_draws() -> usize {
    50
}

impl Case {
    pub fn load(path: &Path) -> anyhow::Result<Case> {
        let bytes = crate::io::read_bounded(path, "case file", crate::limits::MAX_TEXT_INPUT)?;
        let text = String::from_utf8(bytes)
            .map_err(|e| anyhow::anyhow!("cannot read case file {}: not UTF-8 text ({e})", path.display()))?;
        Case::parse(&path.display().to_string(), &text)
    }

    pub fn parse(path: &str, text: &str) -> anyhow::Result<Case> {
        // A byte-order mark (some editors write one) is not part of the TOML.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let case: Case = toml::from_str(text).map_err(|e| {
            // toml's message carries the line, column and a caret under the offending key.
            anyhow::anyhow!("{path}: malformed case file:\n{e}")
        })?;
        case.check().map_err(|e| anyhow::anyhow!("{path}: {e}"))?;
        values::check(&case).map_err(|e| anyhow::anyhow!("{path}: {e}"))?;
        Ok(case)
    }

    fn check(&self) -> Result<(), String> {
        if self.notes.is_some() {
            return Err(
                "`notes` is retired: findings are computed from the run now. Write each one as a \
                        [[claims]] entry with `id`, `expect` (an expression over the analysis) and `text` \
                        (see docs/claims.md)"
                    .into(),
            );
        }
        let mut ids: Vec<&str> = self.claims.iter().map(|c| c.id.as_str()).collect();
        ids.sort();
        if let Some(w) = ids.windows(2).find(|w| w[0] == w[1]) {
            return Err(format!("claims: id `{}` appears twice", w[0]));
        }
        if let Some(g) = &self.geometry {
            g.check("geometry")?;
        }
        if self.materials.is_empty() {
            return Err("no [[materials]]".into());
        }
        if let Some(e) = &self.envelope {
            if e.sample == 0 || e.sample > 2048 {
                return Err(format!(
                    "envelope: sample = {} (configurations per method, from 1 to 2048: the spread subset's size)",
                    e.sample
                ));
            }
            if let Some(s) = e.max_past_budget {
                if !(0.0..=1.0).contains(&s) {
                    return Err(format!(
                        "envelope: max_past_budget = {s} (a share of the envelopes, from 0 to 1)"
                    ));
                }
            }
        }
        for m in &self.materials {
            let name = format!("materials `{}`", m.name);
            match (&m.geometry, &self.geometry) {
                (Some(g), _) => g.check(&format!("{name}.geometry"))?,
                (None, Some(_)) => {}
                (None, None) => return Err(format!("{name}: no [geometry] for the case and none of its own")),
            }
            if m.count == 0 {
                return Err(format!("{name}: count must be > 0"));
            }
            let lobe = [
                ("alpha", &m.alpha),
                ("aspect", &m.aspect),
                ("peak", &m.peak),
                ("shear", &m.shear),
            ];
            let ggx_keys = [
                ("view_angle", &m.view_angle),
                ("view_azimuth", &m.view_azimuth),
                ("anisotropy", &m.anisotropy),
            ];
            let ggx = matches!(m.kind, MaterialKind::Ggx | MaterialKind::LtcGgx);
            if !ggx && (ggx_keys.iter().any(|(_, d)| d.is_some()) || m.ltc.is_some() || m.f0.is_some()) {
                return Err(format!(
                    "{name}: view_angle, view_azimuth, anisotropy, f0 and ltc are for kind = \"ggx\" or \"ltc_ggx\""
                ));
            }
            match m.kind {
                MaterialKind::Ggx | MaterialKind::LtcGgx => {
                    if lobe[1..].iter().any(|(_, d)| d.is_some()) || m.rotation.is_some() {
                        return Err(format!(
                            "{name}: a ggx material takes alpha, view_angle, view_azimuth, anisotropy and ltc \
                             (aspect, peak, shear and rotation are for synthetic LTC lobes)"
                        ));
                    }
                    let alpha = m
                        .alpha
                        .as_ref()
                        .ok_or_else(|| format!("{name}: a ggx material needs `alpha`"))?;
                    alpha.check(&format!("{name}.alpha"))?;
                    let (lo, hi) = alpha.bounds();
                    if !(lo > 0.0 && hi <= 1.0) {
                        return Err(format!(
                            "{name}.alpha: GGX roughness must be in (0, 1], got [{lo}, {hi}]"
                        ));
                    }
                    let view = m
                        .view_angle
                        .as_ref()
                        .ok_or_else(|| format!("{name}: a ggx material needs `view_angle` (degrees)"))?;
                    view.check(&format!("{name}.view_angle"))?;
                    let (lo, hi) = view.bounds();
                    if !(lo >= 0.0 && hi < 90.0) {
                        return Err(format!("{name}.view_angle: degrees in [0, 90), got [{lo}, {hi}]"));
                    }
                    for (key, d) in ggx_keys {
                        if let Some(d) = d {
                            d.check(&format!("{name}.{key}"))?;
                        }
                    }
                    if let Some(f0) = &m.f0 {
                        if m.kind == MaterialKind::LtcGgx {
                            return Err(format!(
                                "{name}.f0: an ltc_ggx material is an LTC (no Fresnel term); f0 is for kind = \"ggx\""
                            ));
                        }
                        f0.check(&format!("{name}.f0"))?;
                        let (lo, hi) = f0.bounds();
                        if !(lo >= 0.0 && hi <= 1.0) {
                            return Err(format!("{name}.f0: Schlick's F0 must be in [0, 1], got [{lo}, {hi}]"));
                        }
                    }
                    if let Some(feed) = &m.ltc {
                        let feed = crate::input::ltc::Feed::parse(feed).map_err(|e| format!("{name}.ltc: {e}"))?;
                        let fresnel = m.f0.as_ref().is_some_and(|d| d.bounds() != (1.0, 1.0));
                        if fresnel
                            && matches!(
                                feed,
                                crate::input::ltc::Feed::Published | crate::input::ltc::Feed::PublishedF16
                            )
                        {
                            return Err(format!(
                                "{name}.f0: ltc = \"{}\" has no Fresnel channel (the published table stores M⁻¹ and \
                                 the magnitude only); use ltc = \"table\", \"table_f16\", \"fit\", \"aniso\" or \
                                 \"aniso_f16\" with f0, or leave f0 out",
                                feed.name()
                            ));
                        }
                        let aniso = m.anisotropy.as_ref().is_some_and(|d| d.bounds() != (1.0, 1.0));
                        use crate::input::ltc::Feed;
                        if aniso && !matches!(feed, Feed::Fit | Feed::Aniso | Feed::AnisoF16) {
                            return Err(format!(
                                "{name}.ltc: `{}` is an isotropic table; an anisotropic ggx material needs \
                                 ltc = \"fit\", \"aniso\" or \"aniso_f16\"",
                                feed.name()
                            ));
                        }
                        if matches!(
                            feed,
                            crate::input::ltc::Feed::Published | crate::input::ltc::Feed::PublishedF16
                        ) {
                            crate::input::ltc::table::published().map_err(|e| format!("{name}.ltc: {e}"))?;
                        }
                    }
                }
                MaterialKind::Diffuse => {
                    if lobe.iter().any(|(_, d)| d.is_some()) || m.rotation.is_some() {
                        return Err(format!("{name}: a diffuse material takes no lobe parameters"));
                    }
                }
                MaterialKind::LtcSparse | MaterialKind::LtcFull => {
                    let alpha = m
                        .alpha
                        .as_ref()
                        .ok_or_else(|| format!("{name}: an LTC material needs `alpha`"))?;
                    let (Dist::Fixed { value: lowest }
                    | Dist::Uniform { min: lowest, .. }
                    | Dist::LogUniform { min: lowest, .. }
                    | Dist::SignedLogUniform { min: lowest, .. }) = *alpha;
                    if lowest <= 0.0 {
                        return Err(format!("{name}: alpha must be > 0"));
                    }
                    for (key, d) in lobe {
                        if let Some(d) = d {
                            d.check(&format!("{name}.{key}"))?;
                        }
                    }
                    if m.kind == MaterialKind::LtcSparse && m.rotation.is_some() {
                        return Err(format!("{name}: `rotation` makes M⁻¹ full: use kind = \"ltc_full\""));
                    }
                }
            }
        }
        // Names, duplicates and the values' ranges: `crate::input::case::values`.
        if self.methods.is_empty() {
            return Err("no methods".into());
        }
        for b in self.bins.iter().chain(self.maps.iter().flat_map(|m| [&m.x, &m.y])) {
            if !AXES.contains(&b.axis.as_str()) {
                return Err(format!("unknown bin axis `{}` (one of {})", b.axis, AXES.join(", ")));
            }
            if b.edges.len() < 2 || b.edges.windows(2).any(|w| !(w[0] < w[1])) {
                return Err(format!(
                    "bins `{}`: edges must be at least two increasing numbers",
                    b.axis
                ));
            }
        }
        for m in self
            .maps
            .iter()
            .flat_map(|m| &m.methods)
            .chain(self.search.iter().flat_map(|s| &s.methods))
        {
            if !self.methods.contains(m) {
                return Err(format!("maps or search name `{m}`, which is not in `methods`"));
            }
        }
        for pair in &self.compare {
            for m in pair {
                if !self.methods.contains(m) {
                    return Err(format!("compare names `{m}`, which is not in `methods`"));
                }
            }
        }
        for m in self.tolerances.keys() {
            if !self.methods.contains(m) {
                return Err(format!("tolerances name `{m}`, which is not in `methods`"));
            }
        }
        for t in self.error_floor.keys() {
            if Target::from_name(t).is_none() {
                return Err(format!("error_floor names unknown target `{t}`"));
            }
        }
        Ok(())
    }

    /// The case's `[budget]`, or the default one (docs/statistics.md).
    pub fn budget(&self) -> Budget {
        self.budget.clone().unwrap_or_default()
    }

    /// The geometry a family is drawn from.
    pub fn geometry_of<'a>(&'a self, family: &'a MaterialFamily) -> &'a Geometry {
        family
            .geometry
            .as_ref()
            .or(self.geometry.as_ref())
            .expect("checked: every family has a geometry")
    }

    /// The relative-error floor for a target (docs/statistics.md), in units where the line's distance
    /// d = 1; documented in the report.
    pub fn floor(&self, target: Target) -> f64 {
        self.error_floor.get(target.name()).copied().unwrap_or(1e-6)
    }

    /// The floor for one configuration: `line` and `line_upper` scale as 1/d, the other
    /// targets are scale-invariant, so a configuration at distance d gets floor/d for lines.
    pub fn floor_for(&self, target: Target, config: &crate::input::scene::Config) -> f64 {
        match target {
            Target::Line | Target::LineUpper | Target::LineIsotropic | Target::LineSum | Target::LineIsotropicSum => {
                self.floor(target) / config.distance_to_line()
            }
            _ => self.floor(target),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"
name = "t"
title = "t"
seed = 1
methods = ["line.ltc2023"]
[geometry]
elevation = { dist = "uniform", min = 0.0, max = 90.0 }
tilt_angle = { dist = "uniform", min = 0.0, max = 180.0 }
length = { dist = "log_uniform", min = 0.1, max = 10.0 }
center = { dist = "fixed", value = 0.0 }
[[materials]]
name = "diffuse"
kind = "diffuse"
count = 10
"#;

    #[test]
    fn minimal_case_parses() {
        let c = Case::parse("t.toml", MINIMAL).unwrap();
        assert_eq!(c.geometry.as_ref().unwrap().distance, Dist::Fixed { value: 1.0 });
        assert_eq!(c.materials[0].kind, MaterialKind::Diffuse);
    }

    #[test]
    fn unknown_field_is_an_error_with_its_line() {
        let bad = MINIMAL.replace("count = 10", "count = 10\nroughness = 0.5");
        let e = Case::parse("t.toml", &bad).unwrap_err().to_string();
        assert!(
            e.contains("t.toml") && e.contains("roughness") && e.contains("line 15"),
            "{e}"
        );
    }

    #[test]
    fn malformed_and_inconsistent_cases_are_rejected() {
        let e = Case::parse("t.toml", "name = \"x\"\nseed = ").unwrap_err().to_string();
        assert!(e.contains("malformed") && e.contains("line 2"), "{e}");
        let bad = MINIMAL.replace("min = 0.1, max = 10.0", "min = 0.0, max = 10.0");
        assert!(Case::parse("t.toml", &bad)
            .unwrap_err()
            .to_string()
            .contains("geometry.length"));
        let bad = MINIMAL.replace("kind = \"diffuse\"", "kind = \"ltc_sparse\"");
        assert!(Case::parse("t.toml", &bad).unwrap_err().to_string().contains("alpha"));
        let bad = format!("{MINIMAL}\n[[bins]]\naxis = \"nope\"\nedges = [0, 1]\n");
        assert!(Case::parse("t.toml", &bad)
            .unwrap_err()
            .to_string()
            .contains("unknown bin axis"));
    }
}
