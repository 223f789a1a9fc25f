//! Seeded sampler: case-file distributions → configurations, with the dimensionless
//! parameters each one was drawn from (the bin axes).
//!
//! Same seed, same configurations on every machine: ChaCha8 streams (one per material,
//! so adding a material changes no other), floats drawn from raw integers, and the
//! transcendental functions from `libm` (pure Rust) rather than the platform's libm.

use crate::input::case::texture::{Direction, Drawn, Shape, TextureSpec};
use crate::input::case::{Case, Dist, MaterialFamily, MaterialKind};
use crate::input::geometry::{mat, rows, v3, DMat3, DVec3};
use crate::input::scene::{Config, Material, Rect, Roughness, Vec3};
use rand::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The parameters a configuration was drawn from, and ones derived from it, by axis name.
///
/// The line axes say which term of Eq. 1.20 dominates and where each antiderivative cancels:
/// how far along the line the near and far ends reach (in units of the distance d of the
/// line), the angle the segment subtends, the height of the closest point of the line and the
/// tilt of the segment. The `_o` axes are the same in the configuration transformed by M⁻¹,
/// the diffuse configuration the LTC formulas actually integrate (equal to the plain ones for
/// the diffuse material).
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Axes {
    pub length: f64,
    pub center: f64,
    pub elevation: f64,
    pub tilt: f64,
    /// Lobe roughness; NaN for the diffuse material (such configurations fall in no alpha bin).
    pub alpha: f64,
    /// |l|/d of the end nearer the closest point of the line (0 when the segment spans it).
    pub reach_near: f64,
    /// |l|/d of the farther end.
    pub reach_far: f64,
    /// Angle between p1 and p2 seen from the shading point (radians).
    pub subtended: f64,
    /// Height of the closest point of the line over d: ω_po.z, in [−1, 1].
    pub height: f64,
    pub reach_near_o: f64,
    /// `reach_far` in the transformed configuration (also named `reach_o`).
    pub reach_o: f64,
    pub subtended_o: f64,
    pub height_o: f64,
    pub tilt_o: f64,
    pub radius: f64,
    /// 1 when an end cap (disk of radius R at an end point, normal along the segment) straddles
    /// the horizon or the LTC lobe's support plane (M⁻¹ row 3 · ω = 0), 0 when neither does;
    /// NaN without a radius. A point-light cap is all or nothing exactly there.
    pub cap_straddle: f64,
    pub width: f64,
    /// Angle (degrees) of the rectangle's normal from facing the shading point: 90 is edge-on.
    pub rect_angle: f64,
    /// `ggx`: the view's angle from the normal (degrees) and αy/αx; NaN otherwise.
    pub view_angle: f64,
    pub anisotropy: f64,
    /// `ggx`: the angle (degrees, 0 to 180) between the view's mirror direction (the view
    /// reflected about the normal) and the direction to the light's nearest point (the point
    /// of the segment nearest the shading point; for a tube or rectangle, of its axis). Small
    /// is the highlight a viewer sees. NaN for other materials.
    #[serde(default = "nan")]
    pub highlight: f64,
    /// A textured family's stripes: periods per light length (along) or per turn (around; a
    /// cubemap along: per half turn), as drawn and as the texels hold them
    /// (src/input/case/texture.rs). NaN for other patterns and untextured families.
    #[serde(default = "nan")]
    pub frequency: f64,
    /// A textured family's contrast (texels in [1 − c, 1 + c]); NaN without one.
    #[serde(default = "nan")]
    pub texture_contrast: f64,
    /// The line's distance over the light's length, d/L (1/`length`).
    #[serde(default = "nan")]
    pub distance_over_length: f64,
}

fn nan() -> f64 {
    f64::NAN
}

/// The angle (degrees) between the mirror direction of `view` (reflected about +z) and the
/// direction from the shading point to the point of segment p1–p2 nearest to it.
pub fn highlight_angle(view: Vec3, p1: Vec3, p2: Vec3) -> f64 {
    let (p1, p2) = (v3(p1), v3(p2));
    let e = p2 - p1;
    let t = (-p1.dot(e) / e.dot(e)).clamp(0.0, 1.0);
    let nearest = p1 + e * t;
    let mirror = DVec3::new(-view[0], -view[1], view[2]);
    libm::atan2(mirror.cross(nearest).length(), mirror.dot(nearest)).to_degrees()
}

impl Axes {
    pub fn get(&self, axis: &str) -> f64 {
        match axis {
            "length" => self.length,
            "center" => self.center,
            "elevation" => self.elevation,
            "tilt" => self.tilt,
            "alpha" => self.alpha,
            "reach_near" => self.reach_near,
            "reach_far" => self.reach_far,
            "subtended" => self.subtended,
            "height" => self.height,
            "reach_near_o" => self.reach_near_o,
            "reach_o" | "reach_far_o" => self.reach_o,
            "subtended_o" => self.subtended_o,
            "height_o" => self.height_o,
            "tilt_o" => self.tilt_o,
            "radius" => self.radius,
            "cap_straddle" => self.cap_straddle,
            "width" => self.width,
            "rect_angle" => self.rect_angle,
            "view_angle" => self.view_angle,
            "anisotropy" => self.anisotropy,
            "highlight" => self.highlight,
            "frequency" => self.frequency,
            "texture_contrast" => self.texture_contrast,
            "distance_over_length" => self.distance_over_length,
            _ => f64::NAN,
        }
    }

    /// The axes the region of a configuration is stated on (disagreements, claims).
    pub const REGION: [&'static str; 10] = [
        "reach_near_o",
        "reach_o",
        "subtended_o",
        "height_o",
        "tilt_o",
        "reach_near",
        "reach_far",
        "subtended",
        "height",
        "tilt",
    ];
}

/// The line axes of a segment: (reach of the near end, reach of the far end, subtended angle,
/// height of the closest point, tilt), lengths in units of the line's distance.
pub fn line_axes(p1: Vec3, p2: Vec3) -> (f64, f64, f64, f64, f64) {
    let (p1, p2) = (v3(p1), v3(p2));
    let t = (p2 - p1).normalize();
    let (l1, l2) = (p1.dot(t), p2.dot(t));
    let foot = p1 - t * l1;
    let d = foot.length();
    let near = if l1 * l2 <= 0.0 {
        0.0
    } else {
        l1.abs().min(l2.abs()) / d
    };
    let far = l1.abs().max(l2.abs()) / d;
    let subtended = libm::atan2(p1.cross(p2).length(), p1.dot(p2));
    (near, far, subtended, foot.z / d, t.z.abs())
}

#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Sample {
    pub config: Config,
    /// Index into the case's materials (families).
    pub material: usize,
    pub axes: Axes,
    /// The uniforms it was drawn from (`sample_from_units` maps them back).
    pub units: Vec<f64>,
    /// Empty for the case's natural sample. A top-up configuration (see [`top_up`]) lists the
    /// bins (axis index into `case.bins`, bin index) it was drawn for: it is counted in those
    /// bins only, never in a whole-material statistic.
    pub strata: Vec<(usize, usize)>,
}

impl Sample {
    pub fn natural(&self) -> bool {
        self.strata.is_empty()
    }
}

/// A source of uniform numbers in [0, 1): the seeded stream when sampling, a stored vector
/// when replaying or searching. A configuration is a pure function of its uniforms.
trait Uniforms {
    fn unit(&mut self) -> f64;
}

struct Stream(ChaCha8Rng);

impl Uniforms for Stream {
    /// From 53 random bits: identical on every platform.
    fn unit(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// Replays stored uniforms, counting how many were taken.
struct Replay<'a> {
    units: &'a [f64],
    taken: usize,
}

impl Uniforms for Replay<'_> {
    fn unit(&mut self) -> f64 {
        let u = self.units.get(self.taken).copied().unwrap_or(0.5);
        self.taken += 1;
        u
    }
}

/// Records the uniforms another source hands out.
struct Recorder<'a> {
    inner: &'a mut dyn Uniforms,
    units: Vec<f64>,
}

impl Uniforms for Recorder<'_> {
    fn unit(&mut self) -> f64 {
        let u = self.inner.unit();
        self.units.push(u);
        u
    }
}

fn draw(source: &mut dyn Uniforms, d: &Dist) -> f64 {
    let u = source.unit();
    match *d {
        Dist::Fixed { value } => value,
        Dist::Uniform { min, max } => min + (max - min) * u,
        Dist::LogUniform { min, max } => log_uniform(min, max, u),
        Dist::SignedLogUniform { min, max } => {
            // The sign from the lower or upper half, the magnitude from the rest: one draw.
            let (sign, v) = if u < 0.5 { (-1.0, 2.0 * u) } else { (1.0, 2.0 * u - 1.0) };
            sign * log_uniform(min, max, v)
        }
    }
}

/// Absent parameters draw nothing, so adding one to a case changes no other's stream.
fn draw_opt(source: &mut dyn Uniforms, d: &Option<Dist>, default: f64) -> f64 {
    d.as_ref().map_or(default, |d| draw(source, d))
}

/// How one family's draws went: every degenerate draw is redrawn, counted here, and shown
/// in the report (`summary.json` `draws`, one line in the report header).
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Draws {
    pub family: String,
    /// Draws made, accepted and rejected.
    pub drawn: usize,
    pub rejected: usize,
    /// Why draws were rejected: the reason and how often.
    pub reasons: std::collections::BTreeMap<String, usize>,
}

impl Draws {
    pub fn rate(&self) -> f64 {
        if self.drawn == 0 {
            0.0
        } else {
            self.rejected as f64 / self.drawn as f64
        }
    }
}

/// Redraws allowed per family: 1 % of its count (and a few for tiny counts). Beyond that the
/// redraws would change the distribution the case asks for, so the case is refused.
pub fn redraw_limit(count: usize) -> usize {
    count / 100 + 10
}

/// The case parameters that make a configuration degenerate in a given way (for messages).
pub fn parameters_behind(d: &crate::input::scene::Degenerate) -> &'static str {
    use crate::input::scene::Degenerate as D;
    match d {
        D::NotFinite | D::NotRepresentable(_) | D::SingularMinv(_) => {
            "distance, length, center or the lobe's alpha, aspect, peak, shear"
        }
        D::ZeroLength => "length (or endpoint_height)",
        D::PointOnLight(_) => "distance, length, center or endpoint_height",
        D::InsideTube { .. } | D::BadRadius(_) => "radius",
        D::BadWidth(_) | D::PointOnRectangle => "rect_width or rect_angle",
        D::BadRectNormal { .. } => "rect_angle",
        D::BadTexture(_) => "texture",
    }
}

/// A rejection's reason without its numbers, so that equal reasons are counted together.
pub fn reason_of(d: &crate::input::scene::Degenerate) -> &'static str {
    use crate::input::scene::Degenerate as D;
    match d {
        D::NotFinite => "a coordinate not finite",
        D::NotRepresentable(_) => "not representable in f32",
        D::ZeroLength => "zero length",
        D::PointOnLight(_) => "shading point on the light",
        D::InsideTube { .. } => "shading point inside the tube",
        D::BadRadius(_) => "radius not > 0",
        D::BadWidth(_) => "width not > 0",
        D::BadRectNormal { .. } => "rect normal not perpendicular",
        D::PointOnRectangle => "shading point on the rectangle",
        D::SingularMinv(_) => "M⁻¹ singular",
        D::BadTexture(_) => "texture malformed",
    }
}

/// All configurations of a case, family after family, in a fixed order.
pub fn sample_case(case: &Case) -> Vec<Sample> {
    sample_case_counted(case).unwrap_or_else(|e| panic!("{e}")).0
}

/// All configurations of a case with each family's draw counts. Degenerate draws are
/// redrawn at most [`redraw_limit`] times per family; past that the case is refused with a
/// message naming the family, the reason and the parameters behind it.
pub fn sample_case_counted(case: &Case) -> Result<(Vec<Sample>, Vec<Draws>), String> {
    let mut stream = NaturalStream::new(case);
    let mut out = Vec::new();
    loop {
        let chunk = stream.next_chunk(1 << 16)?;
        if chunk.is_empty() {
            break;
        }
        out.extend(chunk);
    }
    Ok((out, stream.draws))
}

/// Configurations per block of the shard partition: shard i of n draws and evaluates the
/// blocks k ≡ i (mod n) of the natural sample's global order (family after family).
pub const SHARD_BLOCK: usize = 1024;

/// What a stream's key is made of: the case seed, the family, what the stream is for and,
/// for a top-up, its axis and bin.
const NATURAL_TAG: u64 = 0x6E61_7475_7261_6C00;
const TOPUP_TAG: u64 = 0x746F_7075_7000_0000;

/// A ChaCha8 key from words, through SplitMix64's mixing: unrelated keys for the natural
/// sample and each bin's top-ups of each family.
fn stream_key(words: &[u64]) -> [u8; 32] {
    fn mix(mut z: u64) -> u64 {
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    let mut h = 0x243F_6A88_85A3_08D3u64;
    for &w in words {
        h = mix(h.wrapping_add(0x9E37_79B9_7F4A_7C15) ^ w);
    }
    let mut key = [0u8; 32];
    for c in key.chunks_mut(8) {
        h = mix(h.wrapping_add(0x9E37_79B9_7F4A_7C15));
        c.copy_from_slice(&h.to_le_bytes());
    }
    key
}

/// Counter-based streams: the uniforms of configuration `index` are ChaCha8's stream number
/// `index` under `key`, a pure function of (key, index), so any shard draws any configuration
/// alone, and the same on every machine.
fn counter_stream(key: [u8; 32], index: u64) -> Stream {
    let mut rng = ChaCha8Rng::from_seed(key);
    rng.set_stream(index);
    Stream(rng)
}

/// Why one configuration's draws were refused too often (its last degenerate draw).
struct Refused {
    what: String,
    parameters: &'static str,
}

/// A configuration drawn (None past the redraw limit), its draws, and its last refusal.
type DrawnSample = (Option<Sample>, Draws, Option<Refused>);

/// One configuration drawn from its own stream, redrawn in that stream while degenerate (at
/// most `limit` times; `None` past that). Counts its draws in a [`Draws`] of its own.
fn draw_valid(source: &mut Stream, case: &Case, family: usize, id: String, limit: usize) -> DrawnSample {
    let mut draws = Draws::default();
    let mut last = None;
    while draws.rejected <= limit {
        let mut recorder = Recorder {
            inner: source,
            units: Vec::new(),
        };
        let s = sample_one(&mut recorder, case, family, id.clone());
        let units = recorder.units;
        draws.drawn += 1;
        match s.config.validate() {
            Ok(()) => return (Some(Sample { units, ..s }), draws, last),
            Err(d) => {
                draws.rejected += 1;
                *draws.reasons.entry(reason_of(&d).to_string()).or_default() += 1;
                last = Some(Refused {
                    what: d.to_string(),
                    parameters: parameters_behind(&d),
                });
            }
        }
    }
    (None, draws, last)
}

/// Configuration `index` of family `family`'s natural sample (redrawn in its own stream while
/// degenerate), with its draws.
fn natural_one(case: &Case, family: usize, index: usize) -> DrawnSample {
    let mut source = counter_stream(stream_key(&[case.seed, family as u64, NATURAL_TAG]), index as u64);
    let f = &case.materials[family];
    draw_valid(
        &mut source,
        case,
        family,
        format!("{}-{index}", f.name),
        redraw_limit(f.count),
    )
}

/// What topping up needs to know of one family's natural sample (or a shard's part of it):
/// its bin counts per axis and whether the family has values on the axis at all.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct FamilyCounts {
    pub members: usize,
    pub bins: Vec<Vec<usize>>,
    pub finite: Vec<bool>,
}

impl FamilyCounts {
    fn new(case: &Case) -> FamilyCounts {
        FamilyCounts {
            members: 0,
            bins: case.bins.iter().map(|b| vec![0; b.edges.len() - 1]).collect(),
            finite: vec![false; case.bins.len()],
        }
    }

    /// Marks the axes `s` has values on, without counting it.
    fn see(&mut self, case: &Case, s: &Sample) {
        for (a, b) in case.bins.iter().enumerate() {
            self.finite[a] |= s.axes.get(&b.axis).is_finite();
        }
    }

    fn count(&mut self, case: &Case, s: &Sample) {
        self.members += 1;
        self.see(case, s);
        for (a, b) in case.bins.iter().enumerate() {
            if let Some(k) = b.index(s.axes.get(&b.axis)) {
                self.bins[a][k] += 1;
            }
        }
    }

    /// Adds another part's counts (other configurations of the same family).
    pub fn merge(&mut self, o: &FamilyCounts) {
        self.members += o.members;
        for (a, b) in self.bins.iter_mut().zip(&o.bins) {
            for (x, y) in a.iter_mut().zip(b) {
                *x += y;
            }
        }
        for (a, b) in self.finite.iter_mut().zip(&o.finite) {
            *a |= b;
        }
    }
}

impl Draws {
    /// Adds another part's draws of the same family.
    pub fn merge(&mut self, o: &Draws) {
        self.drawn += o.drawn;
        self.rejected += o.rejected;
        for (k, v) in &o.reasons {
            *self.reasons.entry(k.clone()).or_default() += v;
        }
    }

    /// Refuses a family whose draws were degenerate more often than [`redraw_limit`] allows.
    pub fn check(&self, count: usize) -> Result<(), String> {
        if self.rejected <= redraw_limit(count) {
            return Ok(());
        }
        let reason = self
            .reasons
            .iter()
            .max_by_key(|(_, n)| **n)
            .map_or("", |(r, _)| r.as_str());
        Err(format!(
            "materials `{}`: {} of {} draws were degenerate (more than the {} redraws allowed for count {}, which \
             would change the distribution), most often: {reason}",
            self.family,
            self.rejected,
            self.drawn,
            redraw_limit(count),
            count
        ))
    }
}

/// The case's natural sample (or one shard's blocks of it), drawn a chunk at a time in the
/// global order of [`sample_case_counted`] (family after family). Every configuration comes
/// from its own counter-based stream (`counter_stream`), so a shard draws only its own
/// blocks, in parallel. Keeps each family's draw counts and bin counts (for the top-ups).
pub struct NaturalStream<'a> {
    case: &'a Case,
    /// (i, n): draw the blocks of [`SHARD_BLOCK`] whose number k has k mod n = i.
    shard: (usize, usize),
    /// The next global index to consider.
    next: usize,
    /// Global index of each family's first configuration, and the total at the end.
    starts: Vec<usize>,
    pub draws: Vec<Draws>,
    pub counts: Vec<FamilyCounts>,
}

impl<'a> NaturalStream<'a> {
    pub fn new(case: &'a Case) -> NaturalStream<'a> {
        NaturalStream::sharded(case, (0, 1))
    }

    /// Shard i of n of the natural sample.
    pub fn sharded(case: &'a Case, shard: (usize, usize)) -> NaturalStream<'a> {
        let mut starts = vec![0];
        for m in &case.materials {
            let last: usize = *starts.last().expect("not empty");
            starts.push(last.saturating_add(m.count));
        }
        let mut counts: Vec<FamilyCounts> = case.materials.iter().map(|_| FamilyCounts::new(case)).collect();
        // Which axes a family has values on is the family's: every shard reads it from the
        // family's first configuration (a member of the unsharded sample, so the same there).
        for (f, c) in counts.iter_mut().enumerate() {
            if case.materials[f].count > 0 {
                if let (Some(s), _, _) = natural_one(case, f, 0) {
                    c.see(case, &s);
                }
            }
        }
        NaturalStream {
            case,
            shard,
            next: 0,
            starts,
            draws: case
                .materials
                .iter()
                .map(|m| Draws {
                    family: m.name.clone(),
                    ..Draws::default()
                })
                .collect(),
            counts,
        }
    }

    /// The next at most `max` configurations; empty once every family is drawn.
    pub fn next_chunk(&mut self, max: usize) -> Result<Vec<Sample>, String> {
        Ok(self.next_indexed(max)?.into_iter().map(|(_, s)| s).collect())
    }

    /// The next at most `max` configurations of this shard with their global indices.
    pub fn next_indexed(&mut self, max: usize) -> Result<Vec<(usize, Sample)>, String> {
        use rayon::prelude::*;
        let case = self.case;
        let total = *self.starts.last().expect("not empty");
        let (i, n) = self.shard;
        let mut indices: Vec<usize> = Vec::new();
        while indices.len() < max && self.next < total {
            let block = self.next / SHARD_BLOCK;
            if block % n != i {
                self.next = (block + (i + n - block % n) % n).saturating_mul(SHARD_BLOCK);
                continue;
            }
            let end = ((block + 1) * SHARD_BLOCK)
                .min(total)
                .min(self.next + (max - indices.len()));
            indices.extend(self.next..end);
            self.next = end;
        }
        let starts = &self.starts;
        let drawn: Vec<(usize, usize, DrawnSample)> = indices
            .par_iter()
            .map(|&g| {
                let f = starts.partition_point(|&s| s <= g) - 1;
                (g, f, natural_one(case, f, g - starts[f]))
            })
            .collect();
        let mut out = Vec::with_capacity(drawn.len());
        for (g, f, (s, d, refused)) in drawn {
            let family = &case.materials[f];
            self.draws[f].merge(&d);
            if self.draws[f].rejected > redraw_limit(family.count) {
                let (what, parameters) = refused.map_or((String::new(), ""), |r| (r.what, r.parameters));
                let draws = &self.draws[f];
                return Err(format!(
                    "materials `{}`: {} of {} draws were degenerate (more than the {} redraws allowed for count {}, \
                     which would change the distribution), e.g. {what}; check {parameters}",
                    family.name,
                    draws.rejected,
                    draws.drawn,
                    redraw_limit(family.count),
                    family.count,
                ));
            }
            let s = s.expect("drawn within the redraw limit");
            self.counts[f].count(case, &s);
            out.push((g, s));
        }
        Ok(out)
    }

    /// Configurations of the natural sample (every shard's).
    pub fn total(&self) -> usize {
        *self.starts.last().expect("not empty")
    }
}

/// What topping up did for one family: how many draws it made, how many it kept, and the
/// bins still below the target when the budget ran out.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct TopUp {
    pub family: String,
    pub draws: usize,
    pub kept: usize,
    /// (axis, lo, hi, configurations reached) of each bin left below `min_per_bin`.
    pub thin: Vec<(String, f64, f64, usize)>,
}

/// A top-up configuration's name: top-up `j` of bin `bin` of axis `axis` in family `family`.
/// Ordered as the sweep measures them (family, axis, bin, then j).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize)]
pub struct TopUpKey {
    pub family: usize,
    pub axis: usize,
    pub bin: usize,
    pub j: usize,
}

/// Every bin of every family, numbered (family, axis, bin) in order: index into the dense
/// per-bin vectors of [`topup_needs`].
pub fn bin_ordinal(case: &Case, family: usize, axis: usize, bin: usize) -> usize {
    let per_family: usize = case.bins.iter().map(|b| b.edges.len() - 1).sum();
    let before: usize = case.bins[..axis].iter().map(|b| b.edges.len() - 1).sum();
    family * per_family + before + bin
}

/// How many top-ups each bin (by [`bin_ordinal`]) of each family asks for, from the natural
/// counts `counts` (the whole sample's, or a shard's: then an upper bound of the whole
/// sample's, since a shard's counts are at most the whole's): `min_per_bin` less the count,
/// on the axes the family has values on.
pub fn topup_needs(case: &Case, counts: &[FamilyCounts]) -> Vec<usize> {
    let mut out = Vec::new();
    for (f, family) in case.materials.iter().enumerate() {
        for (a, b) in case.bins.iter().enumerate() {
            let min = b.min_per_bin(case.min_per_bin);
            for k in 0..b.edges.len() - 1 {
                let c = &counts[f];
                out.push(if family.count == 0 || !c.finite[a] {
                    0
                } else {
                    min.saturating_sub(c.bins[a][k])
                });
            }
        }
    }
    out
}

/// The top-ups shard i of n draws: of each bin's needs `needs` (by [`bin_ordinal`]), the
/// numbers j with (ordinal + j) mod n = i.
pub fn topup_plan(case: &Case, needs: &[usize], (i, n): (usize, usize)) -> Vec<TopUpKey> {
    let mut out = Vec::new();
    for family in 0..case.materials.len() {
        for (axis, b) in case.bins.iter().enumerate() {
            for bin in 0..b.edges.len() - 1 {
                let o = bin_ordinal(case, family, axis, bin);
                let first = (i + n - o % n) % n;
                out.extend((first..needs[o]).step_by(n).map(|j| TopUpKey { family, axis, bin, j }));
            }
        }
    }
    out
}

/// Draws one top-up configuration may make: [`TOPUP_CAP_FACTOR`] times the family's top-up
/// budget (`topup_draws` × its count) shared by the `min_per_bin` configurations a bin may ask
/// for, so one bin's top-ups draw at most that many times the budget. Each top-up has its own
/// cap (so any shard draws it alone); a bin whose share of the budget would just fill it
/// (expected hits = min_per_bin) then misses a top-up with probability e⁻⁴ ≈ 2 %.
pub fn topup_cap(case: &Case, key: TopUpKey) -> usize {
    let min = case.bins[key.axis].min_per_bin(case.min_per_bin).max(1);
    (case.materials[key.family].count.saturating_mul(case.topup_draws) / min)
        .saturating_mul(TOPUP_CAP_FACTOR)
        .max(1)
}

/// See [`topup_cap`].
pub const TOPUP_CAP_FACTOR: usize = 4;

/// Top-up `key`: drawn from its own counter-based stream (keyed by the case seed, the family,
/// the axis and the bin; numbered by j) from the case's own distributions, redrawn until it
/// falls in its bin (rejection sampling: within the bin it follows the natural distribution
/// conditioned on the bin, no weights needed), at most [`topup_cap`] draws. It is counted in
/// that bin only (`strata`), never in a whole-material statistic. Returns the draws made and
/// the configuration, None when the draws ran out.
pub fn top_up_one(case: &Case, key: TopUpKey) -> (usize, Option<Sample>) {
    let TopUpKey { family, axis, bin, j } = key;
    let mut source = counter_stream(
        stream_key(&[case.seed, family as u64, TOPUP_TAG, axis as u64, bin as u64]),
        j as u64,
    );
    let b = &case.bins[axis];
    let name = &case.materials[family].name;
    let cap = topup_cap(case, key);
    for attempt in 1..=cap {
        let mut recorder = Recorder {
            inner: &mut source,
            units: Vec::new(),
        };
        let s = sample_one(&mut recorder, case, family, String::new());
        let units = recorder.units;
        if s.config.validate().is_err() || b.index(s.axes.get(&b.axis)) != Some(bin) {
            continue;
        }
        let mut s = Sample {
            units,
            strata: vec![(axis, bin)],
            ..s
        };
        s.config.id = format!("{name}-topup-{}-{bin}-{j}", b.axis);
        return (attempt, Some(s));
    }
    (cap, None)
}

/// What topping up did, per family with configurations: the draws of the top-ups `done`
/// ((key, draws made, whether it was kept), those the run keeps) and the bins left thin.
pub fn topup_reports(case: &Case, counts: &[FamilyCounts], done: &[(TopUpKey, usize, bool)]) -> Vec<TopUp> {
    let mut reports = Vec::new();
    for (f, family) in case.materials.iter().enumerate() {
        if family.count == 0 {
            continue;
        }
        let mut report = TopUp {
            family: family.name.clone(),
            ..TopUp::default()
        };
        let mine = done.iter().filter(|(k, _, _)| k.family == f);
        for (_, draws, kept) in mine.clone() {
            report.draws += draws;
            report.kept += usize::from(*kept);
        }
        for (a, b) in case.bins.iter().enumerate() {
            if !counts[f].finite[a] {
                continue;
            }
            let min = b.min_per_bin(case.min_per_bin);
            for k in 0..b.edges.len() - 1 {
                let kept = mine
                    .clone()
                    .filter(|(key, _, kept)| *kept && key.axis == a && key.bin == k)
                    .count();
                let reached = counts[f].bins[a][k] + kept;
                if reached < min {
                    report.thin.push((b.axis.clone(), b.edges[k], b.edges[k + 1], reached));
                }
            }
        }
        reports.push(report);
    }
    reports
}

/// Tops up every bin of every axis that the natural sample leaves below `case.min_per_bin`
/// ([`top_up_one`] for each top-up the bin needs), in the sweep's order.
pub fn top_up(case: &Case, natural: &[Sample]) -> (Vec<Sample>, Vec<TopUp>) {
    let mut counts: Vec<FamilyCounts> = case.materials.iter().map(|_| FamilyCounts::new(case)).collect();
    for s in natural {
        counts[s.material].count(case, s);
    }
    top_up_counted(case, &counts)
}

/// [`top_up`] from the natural sample's counts alone (a streamed sweep keeps no sample).
pub fn top_up_counted(case: &Case, counts: &[FamilyCounts]) -> (Vec<Sample>, Vec<TopUp>) {
    let drawn = draw_topups(case, &topup_needs(case, counts), (0, 1));
    let done: Vec<(TopUpKey, usize, bool)> = drawn.iter().map(|(k, d, s)| (*k, *d, s.is_some())).collect();
    let reports = topup_reports(case, counts, &done);
    (drawn.into_iter().filter_map(|(_, _, s)| s).collect(), reports)
}

/// The top-ups of shard i of n's share of `needs` ([`topup_plan`]), drawn in parallel: (key,
/// draws made, the configuration or None). A bin whose top-up 0 exhausts its draws is out of
/// reach: its other top-ups are not drawn (every part draws top-up 0 of every bin it needs to
/// know this, and keeps it only when it is its share), so such a bin costs one cap of draws.
pub fn draw_topups(case: &Case, needs: &[usize], shard: (usize, usize)) -> Vec<(TopUpKey, usize, Option<Sample>)> {
    use rayon::prelude::*;
    let firsts: Vec<TopUpKey> = topup_plan(case, &needs.iter().map(|&n| n.min(1)).collect::<Vec<_>>(), (0, 1));
    let probes: Vec<(TopUpKey, (usize, Option<Sample>))> =
        firsts.into_par_iter().map(|k| (k, top_up_one(case, k))).collect();
    let reachable = |k: &TopUpKey| {
        probes
            .iter()
            .find(|(p, _)| (p.family, p.axis, p.bin) == (k.family, k.axis, k.bin))
            .is_some_and(|(_, (_, s))| s.is_some())
    };
    let plan: Vec<TopUpKey> = topup_plan(case, needs, shard)
        .into_iter()
        .filter(|k| k.j == 0 || reachable(k))
        .collect();
    plan.into_par_iter()
        .map(|k| {
            let (draws, s) = match probes.iter().find(|(p, _)| k.j == 0 && *p == k) {
                Some((_, (d, s))) => (*d, s.clone()),
                None => top_up_one(case, k),
            };
            (k, draws, s)
        })
        .collect()
}

/// The configuration a vector of uniforms stands for in a family (the search moves in these);
/// None when it is degenerate.
pub fn sample_from_units(case: &Case, family: usize, units: &[f64], id: String) -> Option<Sample> {
    let mut replay = Replay { units, taken: 0 };
    let s = sample_one(&mut replay, case, family, id);
    s.config.validate().ok()?;
    Some(Sample {
        units: units[..replay.taken.min(units.len())].to_vec(),
        ..s
    })
}

fn log_uniform(min: f64, max: f64, u: f64) -> f64 {
    libm::exp(libm::log(min) + (libm::log(max) - libm::log(min)) * u)
}

fn deg(x: f64) -> f64 {
    x * std::f64::consts::PI / 180.0
}

fn sample_one(source: &mut dyn Uniforms, case: &Case, material: usize, id: String) -> Sample {
    let family = &case.materials[material];
    let g = case.geometry_of(family);
    let d = draw(source, &g.distance);
    let elevation = draw(source, &g.elevation);
    let azimuth = deg(draw(source, &g.azimuth));
    let tilt_angle = deg(draw(source, &g.tilt_angle));
    let length_over_d = draw(source, &g.length);
    let center = draw(source, &g.center);
    let radius = g.radius.as_ref().map(|r| draw(source, r) * d);
    let rect_width = g.rect_width.as_ref().map(|w| draw(source, w) * d);
    let rect_angle_deg = draw_opt(source, &g.rect_angle, 0.0);
    let rect_angle = deg(rect_angle_deg);
    let endpoint_height = g.endpoint_height.as_ref().map(|h| draw(source, h) * d);

    // Foot point p_o, horizontal direction h ⟂ p_o and v = ω_po × h complete the frame.
    let (ce, se) = (libm::cos(deg(elevation)), libm::sin(deg(elevation)));
    let (ca, sa) = (libm::cos(azimuth), libm::sin(azimuth));
    let w_po = DVec3::new(ce * ca, ce * sa, se);
    let h = DVec3::new(-sa, ca, 0.0);
    let v = w_po.cross(h);
    let w_t = h * libm::cos(tilt_angle) + v * libm::sin(tilt_angle);
    let p_o = w_po * d;
    let half = 0.5 * length_over_d * d;
    let p1 = p_o + w_t * (center * d - half);
    let mut p2 = p_o + w_t * (center * d + half);
    if let Some(z) = endpoint_height {
        p2.z = z;
    }
    // What was drawn, as the final segment has it (the end point may have moved).
    let w_t = (p2 - p1).normalize();
    let length_over_d = (p2 - p1).length() / d;

    let rect = rect_width.map(|width| {
        // The normal turns about the tangent: 0° faces the shading point, 90° is edge-on.
        let u = w_po;
        let b = w_t.cross(u);
        Rect {
            normal: (u * libm::cos(rect_angle) + b * libm::sin(rect_angle)).to_array(),
            width,
        }
    });

    let (material_value, alpha, view_angle, anisotropy) = sample_material(source, family);
    let highlight = match &material_value {
        Material::Ggx { view, .. } => highlight_angle(*view, p1.to_array(), p2.to_array()),
        _ => f64::NAN,
    };
    let minv = material_value.minv();
    let (p1o, p2o) = (mat(&minv) * p1, mat(&minv) * p2);
    let (p1, p2) = (p1.to_array(), p2.to_array());
    let (reach_near, reach_far, subtended, height, _) = line_axes(p1, p2);
    let (reach_near_o, reach_o, subtended_o, height_o, tilt_o) = line_axes(p1o.to_array(), p2o.to_array());
    // Drawn last and only for a textured family, so an untextured family draws what it always drew.
    let texture = family.texture.as_ref().map(|t| {
        let drawn = sample_texture(source, t);
        (t.texture(&drawn), drawn)
    });
    let (frequency, texture_contrast) = texture
        .as_ref()
        .map_or((f64::NAN, f64::NAN), |(_, d)| (d.frequency, d.contrast));

    Sample {
        config: Config {
            id,
            p1,
            p2,
            radius,
            rect,
            material: material_value,
            texture: texture.map(|(t, _)| t),
        },
        material,
        units: Vec::new(),
        strata: Vec::new(),
        axes: Axes {
            length: length_over_d,
            center,
            elevation,
            tilt: w_t.z.abs(),
            alpha,
            reach_near,
            reach_far,
            subtended,
            height,
            reach_near_o,
            reach_o,
            subtended_o,
            height_o,
            tilt_o,
            radius: radius.map_or(f64::NAN, |r| r / d),
            cap_straddle: radius.map_or(f64::NAN, |r| {
                let crosses = |m: Vec3, p: Vec3| {
                    let m = v3(m).normalize();
                    let c = m.dot(w_t);
                    m.dot(v3(p)).abs() < r * (1.0 - c * c).max(0.0).sqrt()
                };
                let any = [[0.0, 0.0, 1.0], minv[2]]
                    .into_iter()
                    .any(|m| crosses(m, p1) || crosses(m, p2));
                if any {
                    1.0
                } else {
                    0.0
                }
            }),
            width: rect_width.map_or(f64::NAN, |w| w / d),
            rect_angle: if rect_width.is_some() { rect_angle_deg } else { f64::NAN },
            view_angle,
            anisotropy,
            highlight,
            frequency,
            texture_contrast,
            distance_over_length: 1.0 / length_over_d,
        },
    }
}

/// The values a family's texture pattern is made from, drawn in a fixed order: `frequency`
/// (stripes), `contrast` (all but constant), the phase (stripes, a gradient around), the box or
/// cap (step). What a pattern does not use is not drawn (NaN), so a family's draws per
/// configuration are fixed by its pattern.
fn sample_texture(source: &mut dyn Uniforms, spec: &TextureSpec) -> Drawn {
    let p = &spec.pattern;
    let frequency = draw_opt(source, &p.frequency, f64::NAN);
    let contrast = draw_opt(source, &p.contrast, f64::NAN);
    let phase = match (p.shape, p.direction) {
        (Shape::Stripes, _) | (Shape::Gradient, Some(Direction::Around)) => source.unit(),
        _ => f64::NAN,
    };
    let step = if p.shape == Shape::Step {
        let (u0, v0) = (source.unit(), source.unit());
        let (wu, wv) = (0.1 + 0.4 * source.unit(), 0.1 + 0.4 * source.unit());
        [u0, v0, wu, wv]
    } else {
        [f64::NAN; 4]
    };
    Drawn {
        frequency,
        contrast,
        phase,
        step,
    }
}

/// The material, its α, and for `ggx` its view angle (degrees) and anisotropy (else NaN).
fn sample_material(source: &mut dyn Uniforms, family: &MaterialFamily) -> (Material, f64, f64, f64) {
    match family.kind {
        MaterialKind::Diffuse => (Material::Diffuse, f64::NAN, f64::NAN, f64::NAN),
        MaterialKind::Ggx | MaterialKind::LtcGgx => {
            let alpha = draw_opt(source, &family.alpha, 1.0);
            let theta = draw_opt(source, &family.view_angle, 45.0);
            let phi = deg(draw_opt(source, &family.view_azimuth, 0.0));
            let k = draw_opt(source, &family.anisotropy, 1.0);
            let roughness = if k == 1.0 {
                Roughness::Iso(alpha)
            } else {
                // αx·αy = α², αy/αx = k, each kept in (0, 1].
                let s = libm::sqrt(k);
                Roughness::Aniso([(alpha / s).min(1.0), (alpha * s).min(1.0)])
            };
            let (st, ct) = (libm::sin(deg(theta)), libm::cos(deg(theta)));
            let view = [st * libm::cos(phi), st * libm::sin(phi), ct];
            // Drawn last and only when given, so a family without f0 draws what it always drew.
            let f0 = family.f0.as_ref().map(|d| draw(source, d));
            let material = Material::ggx_fresnel(roughness, view, f0, family.ltc.as_deref()).unwrap_or_else(|e| {
                panic!(
                    "materials `{}`: {e} (the case check admits only valid ones)",
                    family.name
                )
            });
            let material = match (&family.kind, material.fed()) {
                (MaterialKind::LtcGgx, Some(fed)) => Material::Ltc { minv: fed.minv },
                _ => material,
            };
            (material, alpha, theta, k)
        }
        MaterialKind::LtcSparse | MaterialKind::LtcFull => {
            let alpha = draw_opt(source, &family.alpha, 1.0);
            let aspect = draw_opt(source, &family.aspect, 1.0);
            let peak = deg(draw_opt(source, &family.peak, 0.0));
            let shear = draw_opt(source, &family.shear, 0.0);
            let a = aspect / alpha;
            let sparse = [
                [a, 0.0, -a * libm::tan(peak)],
                [0.0, 1.0 / alpha, 0.0],
                [shear, 0.0, 1.0],
            ];
            let minv = if family.kind == MaterialKind::LtcFull {
                let r = deg(draw_opt(source, &family.rotation, 0.0));
                let (c, s) = (libm::cos(r), libm::sin(r));
                // M⁻¹·R_z(r): the lobe turned by r about the normal.
                // From libm's sine and cosine, not glam's rotation (std's), so the same seed
                // gives the same matrix on every machine.
                let rz = DMat3::from_cols(DVec3::new(c, s, 0.0), DVec3::new(-s, c, 0.0), DVec3::Z);
                rows(mat(&sparse) * rz)
            } else {
                sparse
            };
            (Material::Ltc { minv }, alpha, f64::NAN, f64::NAN)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::case::Case;

    fn case() -> Case {
        Case::parse(
            "t.toml",
            r#"
name = "t"
title = "t"
seed = 42
methods = ["line.ltc2023"]
[geometry]
elevation = { dist = "uniform", min = -20.0, max = 90.0 }
tilt_angle = { dist = "uniform", min = 0.0, max = 180.0 }
length = { dist = "log_uniform", min = 0.1, max = 10.0 }
center = { dist = "uniform", min = -2.0, max = 2.0 }
radius = { dist = "log_uniform", min = 0.001, max = 0.5 }
[[materials]]
name = "diffuse"
kind = "diffuse"
count = 50
[[materials]]
name = "aniso"
kind = "ltc_full"
count = 50
alpha = { dist = "log_uniform", min = 0.05, max = 1.0 }
peak = { dist = "uniform", min = -40.0, max = 40.0 }
shear = { dist = "uniform", min = -0.3, max = 0.3 }
rotation = { dist = "uniform", min = 0.0, max = 180.0 }
"#,
        )
        .unwrap()
    }

    #[test]
    fn highlight_is_the_angle_from_the_mirror_direction_to_the_nearest_point() {
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
        let up = [0.0, 0.0, 1.0];
        // The segment passes through the mirror direction: its nearest point lies on it.
        assert!(close(highlight_angle(up, [-1.0, 0.0, 1.0], [1.0, 0.0, 1.0]), 0.0));
        // The nearest point is an end point (p1, clamped): 45° from the zenith.
        assert!(close(highlight_angle(up, [1.0, 0.0, 1.0], [2.0, 0.0, 1.0]), 45.0));
        // In the surface: 90°; below it, past 90°.
        assert!(close(highlight_angle(up, [1.0, -1.0, 0.0], [1.0, 1.0, 0.0]), 90.0));
        assert!(close(highlight_angle(up, [1.0, -1.0, -1.0], [1.0, 1.0, -1.0]), 135.0));
        // A view 30° from the normal mirrors to (−sin 30°, 0, cos 30°); a segment across that
        // direction at distance 2 has its nearest point on it, one 30° further round does not.
        let v = [0.5, 0.0, 0.75f64.sqrt()];
        let m = [-0.5, 0.0, 0.75f64.sqrt()];
        let p = |s: f64, y: f64| [2.0 * m[0], y, 2.0 * m[2] * s];
        assert!(close(highlight_angle(v, p(1.0, -1.0), p(1.0, 1.0)), 0.0));
        assert!(close(highlight_angle(v, [0.0, -1.0, 2.0], [0.0, 1.0, 2.0]), 30.0));
    }

    #[test]
    fn sampled_highlight_follows_the_view() {
        let c = Case::parse(
            "t.toml",
            r#"
name = "t"
title = "t"
seed = 3
methods = ["line.ltc2017"]
[geometry]
elevation = { dist = "uniform", min = -20.0, max = 90.0 }
tilt_angle = { dist = "uniform", min = 0.0, max = 180.0 }
length = { dist = "log_uniform", min = 0.1, max = 10.0 }
center = { dist = "uniform", min = -2.0, max = 2.0 }
[[materials]]
name = "g"
kind = "ggx"
count = 40
alpha = { dist = "fixed", value = 0.3 }
view_angle = { dist = "uniform", min = 0.0, max = 80.0 }
[[materials]]
name = "d"
kind = "diffuse"
count = 10
"#,
        )
        .unwrap();
        for s in sample_case(&c) {
            match &s.config.material {
                Material::Ggx { view, .. } => {
                    let h = highlight_angle(*view, s.config.p1, s.config.p2);
                    assert_eq!(s.axes.highlight, h);
                    assert!((0.0..=180.0).contains(&h));
                }
                _ => assert!(s.axes.highlight.is_nan()),
            }
        }
    }

    #[test]
    fn an_axis_with_its_own_minimum_is_topped_up_alone() {
        let text = r#"
name = "t"
title = "t"
seed = 4
min_per_bin = 0
methods = ["line.ltc2017"]
[geometry]
elevation = { dist = "uniform", min = -20.0, max = 90.0 }
tilt_angle = { dist = "uniform", min = 0.0, max = 180.0 }
length = { dist = "log_uniform", min = 0.1, max = 10.0 }
center = { dist = "uniform", min = -2.0, max = 2.0 }
[[materials]]
name = "d"
kind = "diffuse"
count = 100
[[bins]]
axis = "length"
edges = [0.1, 0.2, 10.0]
[[bins]]
axis = "elevation"
edges = [-20.0, -19.0, 90.0]
min_per_bin = 30
"#;
        let c = Case::parse("t.toml", text).unwrap();
        let natural = sample_case(&c);
        let (extra, reports) = top_up(&c, &natural);
        // Only the thin elevation bin [-20, -19) asked for configurations, and got them.
        assert!(!extra.is_empty());
        assert!(extra.iter().all(|s| s.strata.iter().all(|&(a, k)| (a, k) == (1, 0))));
        let in_bin = natural.iter().filter(|s| s.axes.elevation < -19.0).count() + extra.len();
        assert_eq!(in_bin, 30, "{reports:?}");
    }

    #[test]
    fn wholly_below_means_both_end_points_at_or_under_the_surface() {
        let config = |z1: f64, z2: f64| Config {
            id: String::new(),
            p1: [1.0, 0.0, z1],
            p2: [2.0, 0.5, z2],
            radius: None,
            rect: None,
            material: Material::Diffuse,
            texture: None,
        };
        assert!(config(-1.0, -0.5).wholly_below());
        assert!(config(0.0, -0.5).wholly_below());
        assert!(!config(-1.0, 1e-9).wholly_below());
        assert!(!config(0.5, 0.5).wholly_below());
    }

    #[test]
    fn a_shape_is_wholly_below_when_all_of_it_is() {
        use crate::input::scene::Rect;
        use crate::input::target::Target;
        // A horizontal tube of radius 0.3 whose axis is 0.2 below the surface: both end points
        // are below, but its top reaches 0.1 above, so neither the tube nor its caps are
        // wholly below; 0.4 down they are. A vertical tube reaches no higher than its ends.
        let tube = |z: f64, p2: [f64; 3]| Config {
            id: String::new(),
            p1: [1.0, 0.0, z],
            p2,
            radius: Some(0.3),
            rect: None,
            material: Material::Diffuse,
            texture: None,
        };
        let high = tube(-0.2, [2.0, 0.0, -0.2]);
        assert!(high.wholly_below());
        for t in [Target::Cylinder, Target::Caps, Target::Tube, Target::CylinderUpper] {
            assert!(!high.shape_wholly_below(t), "{t}");
            assert!(tube(-0.4, [2.0, 0.0, -0.4]).shape_wholly_below(t), "{t}");
        }
        // The line targets look at the segment only.
        assert!(high.shape_wholly_below(Target::Line));
        assert!(tube(-0.2, [1.0, 0.0, -1.0]).shape_wholly_below(Target::Tube));
        // A rectangle of width 0.6 standing upright (normal along y) reaches 0.3 above its
        // centre line; lying flat (normal along z) no higher than it.
        let rect = |normal: [f64; 3]| Config {
            rect: Some(Rect { normal, width: 0.6 }),
            radius: None,
            ..tube(-0.2, [2.0, 0.0, -0.2])
        };
        assert!(!rect([0.0, 1.0, 0.0]).shape_wholly_below(Target::Rectangle));
        assert!(rect([0.0, 0.0, 1.0]).shape_wholly_below(Target::RectangleUpper));
    }

    #[test]
    fn same_seed_same_configurations() {
        let a = sample_case(&case());
        let b = sample_case(&case());
        assert_eq!(a.len(), 100);
        assert!(a.iter().zip(&b).all(|(x, y)| x.config == y.config));
        // Golden values: fixed by the seed on every machine (ChaCha8 counter-based streams,
        // one per configuration, and pure-Rust libm); a change here changes every committed
        // report's configurations (it did once, when drawing became per configuration).
        let p1 = a[0].config.p1;
        assert_eq!(p1, [0.15592164478914472, 1.6580960184549083, 0.3027449941094007]);
        assert_eq!(
            a[60].config.material.minv()[2],
            [-0.221263434764892, 0.14731366161759063, 1.0]
        );
        let mut other = case();
        other.seed = 43;
        assert_ne!(sample_case(&other)[0].config.p1, p1);
    }

    #[test]
    fn shards_draw_their_own_blocks_of_the_same_sample() {
        // 2100 per family: blocks of SHARD_BLOCK straddle the family boundary.
        let mut c = case();
        for m in &mut c.materials {
            m.count = 2100;
        }
        let whole = sample_case(&c);
        let n = 3;
        let mut seen = vec![false; whole.len()];
        let mut counts: Vec<FamilyCounts> = c.materials.iter().map(|_| FamilyCounts::new(&c)).collect();
        let mut draws: Vec<Draws> = c.materials.iter().map(|_| Draws::default()).collect();
        for i in 0..n {
            let mut stream = NaturalStream::sharded(&c, (i, n));
            loop {
                let chunk = stream.next_indexed(1000).unwrap();
                if chunk.is_empty() {
                    break;
                }
                for (g, s) in chunk {
                    assert_eq!((g / SHARD_BLOCK) % n, i);
                    assert!(!seen[g], "{g} drawn twice");
                    seen[g] = true;
                    assert_eq!(s.config, whole[g].config, "configuration {g}");
                    assert_eq!(s.units, whole[g].units);
                }
            }
            for (a, b) in counts.iter_mut().zip(&stream.counts) {
                a.merge(b);
            }
            for (a, b) in draws.iter_mut().zip(&stream.draws) {
                a.merge(b);
            }
        }
        assert!(seen.iter().all(|&x| x));
        // The shards' counts add up to the whole sample's, so the top-ups they call for do.
        let mut whole_counts: Vec<FamilyCounts> = c.materials.iter().map(|_| FamilyCounts::new(&c)).collect();
        for s in &whole {
            whole_counts[s.material].count(&c, s);
        }
        for (a, b) in counts.iter().zip(&whole_counts) {
            assert_eq!((a.members, &a.bins, &a.finite), (b.members, &b.bins, &b.finite));
        }
        let (_, whole_draws) = sample_case_counted(&c).unwrap();
        for (a, b) in draws.iter().zip(&whole_draws) {
            assert_eq!((a.drawn, a.rejected, &a.reasons), (b.drawn, b.rejected, &b.reasons));
        }
    }

    /// Bins on `length` (these edges) and on `elevation` (a thin first bin): two families of
    /// bins for the top-up tests.
    fn two_axis_bins(length_edges: &str) -> Vec<crate::input::case::BinAxis> {
        Case::parse(
            "b.toml",
            &format!(
                r#"
name = "b"
title = "b"
seed = 1
methods = ["line.ltc2017"]
[geometry]
elevation = {{ dist = "uniform", min = -20.0, max = 90.0 }}
tilt_angle = {{ dist = "uniform", min = 0.0, max = 180.0 }}
length = {{ dist = "log_uniform", min = 0.1, max = 10.0 }}
center = {{ dist = "uniform", min = -2.0, max = 2.0 }}
[[materials]]
name = "d"
kind = "diffuse"
count = 10
[[bins]]
axis = "length"
edges = [{length_edges}]
[[bins]]
axis = "elevation"
edges = [-20.0, -19.0, 0.0, 90.0]
"#
            ),
        )
        .unwrap()
        .bins
    }

    #[test]
    fn top_ups_are_shared_out_once_and_drawn_alone() {
        let mut c = case();
        c.bins = two_axis_bins("0.1, 0.2, 1.0, 10.0");
        // Two families of six bins each.
        assert_eq!(bin_ordinal(&c, 1, 1, 2), 11);
        let needs: Vec<usize> = (0..12).map(|o| o % 7).collect();
        let whole = topup_plan(&c, &needs, (0, 1));
        assert_eq!(whole.len(), needs.iter().sum::<usize>());
        let mut shared: Vec<TopUpKey> = (0..4).flat_map(|i| topup_plan(&c, &needs, (i, 4))).collect();
        shared.sort();
        assert_eq!(shared, whole);
        // A top-up is a function of its key: drawn twice, or among others, the same.
        for &k in whole.iter().step_by(5) {
            let (a, b) = (top_up_one(&c, k), top_up_one(&c, k));
            assert_eq!(a.0, b.0);
            assert_eq!(a.1.map(|s| s.config), b.1.map(|s| s.config));
        }
    }

    /// The draw runs on all threads (each configuration and each top-up from its own stream):
    /// the same samples, draws and top-ups as drawing them one after another on one thread.
    #[test]
    fn the_parallel_draw_is_the_serial_one() {
        let mut c = case();
        c.min_per_bin = 12;
        c.bins = two_axis_bins("0.1, 0.12, 1.0, 10.0");
        for m in &mut c.materials {
            m.count = 300;
        }
        let (natural, draws) = sample_case_counted(&c).unwrap();
        let (topups, _) = top_up(&c, &natural);
        // One thread: configuration after configuration, then top-up after top-up.
        let mut g = 0;
        for (f, m) in c.materials.iter().enumerate() {
            let (mut drawn, mut rejected) = (0, 0);
            for i in 0..m.count {
                let (s, d, _) = natural_one(&c, f, i);
                let s = s.unwrap();
                assert_eq!((&s.config, &s.units), (&natural[g].config, &natural[g].units), "{g}");
                (drawn, rejected) = (drawn + d.drawn, rejected + d.rejected);
                g += 1;
            }
            assert_eq!((drawn, rejected), (draws[f].drawn, draws[f].rejected), "{}", m.name);
        }
        assert_eq!(g, natural.len());
        let mut counts: Vec<FamilyCounts> = c.materials.iter().map(|_| FamilyCounts::new(&c)).collect();
        for s in &natural {
            counts[s.material].count(&c, s);
        }
        let mut serial = Vec::new();
        let mut reachable = false;
        for k in topup_plan(&c, &topup_needs(&c, &counts), (0, 1)) {
            if k.j > 0 && !reachable {
                continue;
            }
            let (_, s) = top_up_one(&c, k);
            if k.j == 0 {
                reachable = s.is_some();
            }
            serial.extend(s);
        }
        assert!(serial.len() > 20, "the case has top-ups: {}", serial.len());
        assert_eq!(topups.len(), serial.len());
        for (a, b) in topups.iter().zip(&serial) {
            assert_eq!((&a.config, &a.units, &a.strata), (&b.config, &b.units, &b.strata));
        }
    }

    #[test]
    fn a_configuration_is_a_function_of_its_uniforms() {
        let case = case();
        for s in sample_case(&case).iter().step_by(7) {
            let again = sample_from_units(&case, s.material, &s.units, s.config.id.clone()).unwrap();
            assert_eq!(again.config, s.config);
        }
    }

    #[test]
    fn drawn_parameters_are_what_the_geometry_says() {
        for s in sample_case(&case()) {
            let c = &s.config;
            // Distance to the line is the fixed d = 1, length and tilt as drawn.
            assert!((c.distance_to_line() - 1.0).abs() < 1e-12);
            let e = v3(c.p2) - v3(c.p1);
            assert!((e.length() - s.axes.length).abs() < 1e-12 * s.axes.length.max(1.0));
            assert!((e.normalize().z.abs() - s.axes.tilt).abs() < 1e-12);
            assert!(c.radius.unwrap() < 1.0);
            if matches!(c.material, Material::Ltc { .. }) {
                assert!(!c.material.is_sparse());
            }
        }
    }
}
