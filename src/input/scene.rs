//! One configuration: a shading point at the origin (normal +z), a light segment and a
//! material. This is what `eval` reads, what the sampler makes and what every method and
//! reference is evaluated on (docs/conventions.md, docs/eval-format.md).

use crate::input::geometry::{mat, v3};
use serde::{Deserialize, Serialize};

pub use crate::input::texture::Texture;

pub type Vec3 = [f64; 3];
pub use crate::input::ltc::Mat3;

/// The spherical distribution D (the cosine-weighted BRDF).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase", try_from = "RawMaterial")]
pub enum Material {
    /// `D(ω) = max(0, ω.z)/π`.
    Diffuse,
    /// Linearly transformed cosine; `minv` is M⁻¹, row-major, `ω_o = M⁻¹·ω`.
    Ltc { minv: Mat3 },
    /// The GGX lobe of docs/conventions.md (height-correlated Smith; Schlick's F with `f0`, F = 1
    /// without). References integrate it; LTC methods are given `fed`: the LTC of `ltc` (a table
    /// look-up or an exact fit) in the frame rotated about z so that the view lies in the
    /// xz-plane, and its magnitude (Fresnel-weighted with `f0`: [`Material::fed_magnitude`]).
    Ggx {
        alpha: Roughness,
        view: Vec3,
        #[serde(skip_serializing_if = "Option::is_none")]
        f0: Option<f64>,
        #[serde(skip_serializing_if = "Option::is_none")]
        ltc: Option<String>,
        #[serde(skip)]
        fed: Fed,
    },
}

/// GGX roughness: one α, or (αx, αy) along the frame axes.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Roughness {
    Iso(f64),
    Aniso([f64; 2]),
}

impl Roughness {
    pub fn xy(self) -> [f64; 2] {
        match self {
            Roughness::Iso(a) => [a, a],
            Roughness::Aniso(a) => a,
        }
    }
}

/// The LTC an LTC method is fed for a `ggx` material (see `crate::input::ltc`).
pub type Fed = crate::input::ltc::Fed;

impl Material {
    /// A `ggx` material with its LTC fed from `ltc` (None: our table for isotropic
    /// roughness, an exact fit for anisotropic), F = 1. Checks α and the view (docs/conventions.md).
    pub fn ggx(alpha: Roughness, view: Vec3, ltc: Option<&str>) -> Result<Material, String> {
        Material::ggx_fresnel(alpha, view, None, ltc)
    }

    /// [`Material::ggx`] with Schlick's F0 (`None`: F = 1). `f0` must be finite and in [0, 1];
    /// a feed without a Fresnel channel (the published table) is refused for f0 < 1.
    pub fn ggx_fresnel(alpha: Roughness, view: Vec3, f0: Option<f64>, ltc: Option<&str>) -> Result<Material, String> {
        if let Some(f) = f0 {
            check_f0(f)?;
        }
        let a = alpha.xy();
        if !a.iter().all(|x| x.is_finite() && *x > 0.0 && *x <= 1.0) {
            return Err(format!("ggx alpha must be in (0, 1], got {a:?}"));
        }
        if !view.iter().all(|x| x.is_finite()) {
            return Err(format!("ggx view is not finite: {view:?}"));
        }
        let len = v3(view).length();
        if (len - 1.0).abs() > 1e-6 {
            return Err(format!("ggx view must be a unit vector (|view| = {len:.9})"));
        }
        if !(view[2] > 0.0) {
            return Err(format!(
                "ggx view must be above the surface (view.z = {} <= 0)",
                view[2]
            ));
        }
        let feed = match ltc {
            Some(name) => crate::input::ltc::Feed::parse(name)?,
            None if a[0] == a[1] => crate::input::ltc::Feed::Table,
            None => crate::input::ltc::Feed::Fit,
        };
        let fed = crate::input::ltc::feed(a, view, feed)?;
        if let Some(f) = f0.filter(|&f| f != 1.0) {
            if !fed.fresnel.is_finite() {
                return Err(format!(
                    "ggx f0 = {f}: ltc `{}` has no Fresnel channel (the published table stores M⁻¹ and the \
                     magnitude only), so its feed cannot weight the magnitude by F; use ltc = \"table\", \
                     \"table_f16\", \"fit\", \"aniso\" or \"aniso_f16\", or leave f0 out (F = 1)",
                    feed.name()
                ));
            }
        }
        Ok(Material::Ggx {
            alpha,
            view,
            f0,
            ltc: ltc.map(str::to_string),
            fed,
        })
    }

    /// What an LTC method's result is multiplied by for a `ggx` material (None otherwise): the
    /// fed magnitude ∫D, or with `f0` < 1 the Fresnel-weighted `f0·magnitude + (1 − f0)·fresnel`
    /// = ∫D·F (seed 003 §2.3), from the feed's two channels. A table feed combines them in f32,
    /// as the shader does (`res *= F0 * schlick.x + (1.0 - F0) * schlick.y`); the exact fit in
    /// f64. f0 absent or 1 gives the magnitude itself, bit for bit.
    pub fn fed_magnitude(&self) -> Option<f64> {
        let Material::Ggx { fed, f0, .. } = self else {
            return None;
        };
        Some(match f0 {
            // An exact fit (the only feed with a fit error) is combined in f64.
            Some(f) if *f != 1.0 => fresnel_weighted(fed.magnitude, fed.fresnel, *f, fed.fit_l1.is_some()),
            _ => fed.magnitude,
        })
    }

    /// Schlick's F0 of a `ggx` material (1 when absent and for other materials: F = 1).
    pub fn f0(&self) -> f64 {
        match self {
            Material::Ggx { f0: Some(f), .. } => *f,
            _ => 1.0,
        }
    }
}

/// `f0·magnitude + (1 − f0)·fresnel` (∫D·F from the two channels), in f32 as a shader
/// computes it from its texture, or in f64 for an exact fit.
pub fn fresnel_weighted(magnitude: f64, fresnel: f64, f0: f64, exact: bool) -> f64 {
    if exact {
        f0 * magnitude + (1.0 - f0) * fresnel
    } else {
        let f = f0 as f32;
        f64::from(f * magnitude as f32 + (1.0 - f) * fresnel as f32)
    }
}

/// `f0` of a `ggx` material: Schlick's F0, a finite number in [0, 1].
pub fn check_f0(f0: f64) -> Result<(), String> {
    if f0.is_finite() && (0.0..=1.0).contains(&f0) {
        Ok(())
    } else {
        Err(format!(
            "ggx f0 must be a finite number in [0, 1] (Schlick's F0), got {f0}"
        ))
    }
}

/// The JSON form, read strictly: serde's internally tagged enums let unknown fields
/// through on unit variants, so the material is read flat and checked here.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaterial {
    kind: String,
    #[serde(default, deserialize_with = "mat3_opt")]
    minv: Option<Mat3>,
    #[serde(default)]
    alpha: Option<Roughness>,
    #[serde(default)]
    view: Option<Vec3>,
    #[serde(default)]
    f0: Option<f64>,
    #[serde(default)]
    ltc: Option<String>,
}

/// Reads `[x, y, z]` with a message that says how many numbers came (serde's own says
/// "trailing characters" for a fourth).
fn vec3<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec3, D::Error> {
    let v = Vec::<f64>::deserialize(d)?;
    <[f64; 3]>::try_from(v.as_slice())
        .map_err(|_| serde::de::Error::custom(format!("expected 3 numbers [x, y, z], got {}", v.len())))
}

fn mat3_opt<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<Mat3>, D::Error> {
    let rows = Vec::<Vec<f64>>::deserialize(d)?;
    let bad = || {
        serde::de::Error::custom(format!(
            "minv must be 3 rows of 3 numbers, got {} row(s) of {:?} numbers",
            rows.len(),
            rows.iter().map(Vec::len).collect::<Vec<_>>()
        ))
    };
    if rows.len() != 3 {
        return Err(bad());
    }
    let mut m = [[0.0; 3]; 3];
    for (row, r) in m.iter_mut().zip(&rows) {
        *row = <[f64; 3]>::try_from(r.as_slice()).map_err(|_| bad())?;
    }
    Ok(Some(m))
}

impl TryFrom<RawMaterial> for Material {
    type Error = String;
    fn try_from(raw: RawMaterial) -> Result<Material, String> {
        let ggx_fields = raw.alpha.is_some() || raw.view.is_some() || raw.ltc.is_some() || raw.f0.is_some();
        match (raw.kind.as_str(), raw.minv) {
            ("diffuse" | "ltc", _) if ggx_fields => Err(format!(
                "a {} material takes no `alpha`, `view`, `f0` or `ltc` (those are ggx fields)",
                raw.kind
            )),
            ("diffuse", None) => Ok(Material::Diffuse),
            ("diffuse", Some(_)) => Err("a diffuse material takes no `minv`".into()),
            ("ltc", Some(minv)) => Ok(Material::Ltc { minv }),
            ("ltc", None) => Err("an ltc material needs `minv` (3×3, row-major)".into()),
            ("ggx", Some(_)) => Err("a ggx material takes no `minv` (its LTC is fitted: see `ltc`)".into()),
            ("ggx", None) => match (raw.alpha, raw.view) {
                (Some(alpha), Some(view)) => Material::ggx_fresnel(alpha, view, raw.f0, raw.ltc.as_deref()),
                _ => Err("a ggx material needs `alpha` (a or [ax, ay]) and `view` ([vx, vy, vz])".into()),
            },
            (other, _) => Err(format!("unknown material kind `{other}` (diffuse, ltc, ggx)")),
        }
    }
}

impl Material {
    /// M⁻¹ as the LTC methods use it: the identity for the diffuse material.
    pub fn minv(&self) -> Mat3 {
        match self {
            Material::Diffuse => [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            Material::Ltc { minv } => *minv,
            Material::Ggx { fed, .. } => fed.minv_unrotated(),
        }
    }

    /// The LTC fed to the methods for a `ggx` material.
    pub fn fed(&self) -> Option<&Fed> {
        match self {
            Material::Ggx { fed, .. } => Some(fed),
            _ => None,
        }
    }

    /// True when M⁻¹ has the isotropic-GGX sparsity `[[a,0,b],[0,c,0],[d,0,1]]`
    /// that the 2023 listing assumes.
    /// For `ggx`, of the M⁻¹ the methods are fed (in the rotated frame).
    pub fn is_sparse(&self) -> bool {
        let m = match self {
            Material::Ggx { fed, .. } => fed.minv,
            _ => self.minv(),
        };
        m[0][1] == 0.0 && m[1][0] == 0.0 && m[1][2] == 0.0 && m[2][1] == 0.0 && m[2][2] == 1.0
    }
}

/// A thin two-sided rectangle centred on the segment (target `rectangle`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rect {
    #[serde(deserialize_with = "vec3")]
    pub normal: Vec3,
    pub width: f64,
}

/// One explicit configuration, as in docs/eval-format.md.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    pub id: String,
    #[serde(deserialize_with = "vec3")]
    pub p1: Vec3,
    #[serde(deserialize_with = "vec3")]
    pub p2: Vec3,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rect: Option<Rect>,
    pub material: Material,
    /// Seed 002's light texture (src/input/texture.rs); None: a uniform emitter.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texture: Option<Texture>,
}

/// Why a configuration cannot be evaluated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Degenerate {
    #[error("a coordinate is not finite")]
    NotFinite,
    #[error("{0}")]
    NotRepresentable(String),
    #[error("p1 and p2 coincide: the segment has no length")]
    ZeroLength,
    #[error(
        "the shading point lies on the light segment (distance {0:.3e} from the line, relative to the segment's size)"
    )]
    PointOnLight(f64),
    #[error("the shading point lies inside the tube (distance to the axis {dist:.6e} <= radius {radius:.6e})")]
    InsideTube { dist: f64, radius: f64 },
    #[error("radius must be > 0, got {0}")]
    BadRadius(f64),
    #[error("rect.width must be > 0, got {0}")]
    BadWidth(f64),
    #[error("rect.normal must be a unit vector perpendicular to p2 - p1 (|n| = {len:.6}, n·ω_t = {dot:.2e})")]
    BadRectNormal { len: f64, dot: f64 },
    #[error("the shading point lies on the rectangle")]
    PointOnRectangle,
    #[error("minv is singular or not finite (det = {0:.3e})")]
    SingularMinv(f64),
    /// The message names the texture's field (`texture.texels`, `texture.origin`, ...).
    #[error("{0}")]
    BadTexture(String),
}

/// 2^60: lengths up to this (and down to its inverse) square without overflow or
/// underflow in f32 (f32 spans 2^±126 for normal numbers).
pub const F32_SCALE: f64 = 1_152_921_504_606_846_976.0;

impl Config {
    /// The segment lies wholly below the surface: both end points at z <= 0, so every point of
    /// it is in the closed lower half-space and `line_upper` is 0 whatever the material. (The
    /// segment only: a tube's radius or a rectangle's width is not looked at.)
    pub fn wholly_below(&self) -> bool {
        self.p1[2] <= 0.0 && self.p2[2] <= 0.0
    }

    /// The configuration as an f32 kernel receives it: every input number rounded to f32 as
    /// given (end points, radius, the rectangle's normal and width, M⁻¹, α, the view and f0),
    /// with nothing renormalised. Its reference is the best an f32 kernel could return; the gap to
    /// the exact reference is input rounding (docs/statistics.md). A `ggx` material keeps its
    /// fed LTC (references read only α and the view).
    pub fn rounded_to_f32(&self) -> Config {
        let r = |x: f64| x as f32 as f64;
        let r3 = |v: Vec3| v.map(r);
        let material = match &self.material {
            Material::Diffuse => Material::Diffuse,
            Material::Ltc { minv } => Material::Ltc { minv: minv.map(r3) },
            Material::Ggx {
                alpha,
                view,
                f0,
                ltc,
                fed,
            } => Material::Ggx {
                alpha: match *alpha {
                    Roughness::Iso(a) => Roughness::Iso(r(a)),
                    Roughness::Aniso(a) => Roughness::Aniso(a.map(r)),
                },
                view: r3(*view),
                f0: f0.map(r),
                ltc: ltc.clone(),
                fed: *fed,
            },
        };
        Config {
            id: self.id.clone(),
            p1: r3(self.p1),
            p2: r3(self.p2),
            radius: self.radius.map(r),
            rect: self.rect.as_ref().map(|rect| Rect {
                normal: r3(rect.normal),
                width: r(rect.width),
            }),
            material,
            texture: self.texture.as_ref().map(Texture::rounded_to_f32),
        }
    }

    /// The light of `target` lies wholly below the surface: every point of the shape it
    /// integrates at z <= 0, so its surface view (`Target::upper`) is 0 whatever the material.
    /// For the line targets that is [`Config::wholly_below`]; a tube (side or caps) reaches
    /// `R·sqrt(1 − ω_t.z²)` above its axis, a rectangle `W/2·|ω_b.z|` above its centre line.
    pub fn shape_wholly_below(&self, target: crate::input::target::Target) -> bool {
        use crate::input::target::Target;
        let t = (v3(self.p2) - v3(self.p1)).normalize();
        let reach = match target {
            Target::Cylinder
            | Target::Caps
            | Target::Tube
            | Target::CylinderUpper
            | Target::CapsUpper
            | Target::TubeUpper => self.radius.map_or(0.0, |r| r * (1.0 - t.z * t.z).max(0.0).sqrt()),
            Target::Rectangle | Target::RectangleUpper => self.rect.as_ref().map_or(0.0, |rect| {
                let b = v3(rect.normal).cross(t).normalize_or_zero();
                0.5 * rect.width * b.z.abs()
            }),
            _ => 0.0,
        };
        self.p1[2].max(self.p2[2]) + reach <= 0.0
    }

    /// What an LTC method evaluates: for a `ggx` material, the configuration rotated about
    /// z into the frame of its fed M⁻¹, as an `ltc` material, and the magnitude the result
    /// is multiplied by (Fresnel-weighted with `f0`: [`Material::fed_magnitude`]); otherwise
    /// the configuration itself and 1.
    pub fn fed(&self) -> (std::borrow::Cow<'_, Config>, f64) {
        let Some(fed) = self.material.fed() else {
            return (std::borrow::Cow::Borrowed(self), 1.0);
        };
        let rect = self.rect.as_ref().map(|r| Rect {
            normal: fed.rotate(r.normal),
            width: r.width,
        });
        // A texture's origin is resolved in the configuration's own frame (its default is the
        // basis of ω_t there) and rotated with the rest.
        let texture = self.texture.as_ref().map(|t| Texture {
            origin: Some(fed.rotate(t.origin_for(self.tangent()))),
            ..t.clone()
        });
        let c = Config {
            id: self.id.clone(),
            p1: fed.rotate(self.p1),
            p2: fed.rotate(self.p2),
            radius: self.radius,
            rect,
            material: Material::Ltc { minv: fed.minv },
            texture,
        };
        let magnitude = self.material.fed_magnitude().unwrap_or(fed.magnitude);
        (std::borrow::Cow::Owned(c), magnitude)
    }

    /// The unit tangent ω_t = (p2 − p1)/L.
    pub fn tangent(&self) -> Vec3 {
        (v3(self.p2) - v3(self.p1)).normalize().to_array()
    }

    /// Distance from the shading point (origin) to the closest point of the segment.
    pub fn distance_to_segment(&self) -> f64 {
        let (p1, e) = (v3(self.p1), v3(self.p2) - v3(self.p1));
        let t = (-p1.dot(e) / e.dot(e)).clamp(0.0, 1.0);
        (p1 + t * e).length()
    }

    /// Distance from the shading point to the infinite line through the segment (`d` of Eq. 1.15).
    pub fn distance_to_line(&self) -> f64 {
        let e = v3(self.p2) - v3(self.p1);
        v3(self.p1).cross(e).length() / e.length()
    }

    /// Makes `rect.normal` the unit vector perpendicular to the segment that docs/conventions.md
    /// asks for, by removing its component along ω_t (the example in docs/eval-format.md has one). Returns
    /// how far the normal moved, or None when there is no rectangle or the normal is (nearly)
    /// parallel to the segment, which `validate` then rejects.
    pub fn orthonormalize_rect(&mut self) -> Option<f64> {
        let e = v3(self.p2) - v3(self.p1);
        let rect = self.rect.as_mut()?;
        let t = e.normalize();
        let n = v3(rect.normal);
        let perp = n - t * n.dot(t);
        let len = perp.length();
        if !(len > 1e-6 * n.length()) {
            return None;
        }
        let unit = perp * (1.0 / len);
        rect.normal = unit.to_array();
        Some((unit - n).length())
    }

    /// Checks that the kernels can evaluate the configuration in f32: they square lengths,
    /// so the segment's scale max(|p1|, |p2|) must lie within [`F32_SCALE`]^±1, and M⁻¹'s
    /// entries, the radius and the width below it. (Every target is scale-free, so a
    /// configuration outside can be scaled by the user; it is refused, not silently NaN.)
    fn representable(&self) -> Result<(), Degenerate> {
        // hypot: |p| of coordinates near 1e308 is a number, not the overflow of their squares.
        let norm = |p: [f64; 3]| p[0].hypot(p[1]).hypot(p[2]);
        let scale = norm(self.p1).max(norm(self.p2));
        if !(1.0 / F32_SCALE..=F32_SCALE).contains(&scale) {
            let shown = if scale.is_finite() || scale.is_nan() {
                format!("{scale:e}")
            } else {
                format!("more than {:e}", f64::MAX)
            };
            return Err(Degenerate::NotRepresentable(format!(
                "the segment's size max(|p1|, |p2|) = {shown} is outside [{:e}, {F32_SCALE:e}], \
                 where its squares fit in f32: scale the configuration",
                1.0 / F32_SCALE
            )));
        }
        let big = |what: &str, v: f64| {
            (v.abs() > F32_SCALE).then(|| {
                Degenerate::NotRepresentable(format!(
                    "{what} = {v:e} exceeds {F32_SCALE:e}, where its square fits in f32"
                ))
            })
        };
        for row in self.material.minv() {
            for v in row {
                if let Some(e) = big("an entry of minv", v) {
                    return Err(e);
                }
            }
        }
        // A radius or width that f32 cannot tell from 0 beside the segment's size.
        let small = |what: &str, v: f64| {
            (v > 0.0 && v < scale / F32_SCALE).then(|| {
                Degenerate::NotRepresentable(format!(
                    "{what} = {v:e} is below the segment's size {scale:e} / {F32_SCALE:e}, which f32 cannot \
                     resolve"
                ))
            })
        };
        if let Some(e) = self
            .radius
            .and_then(|r| big("radius", r).or_else(|| small("radius", r)))
        {
            return Err(e);
        }
        if let Some(e) = self
            .rect
            .as_ref()
            .and_then(|r| big("rect.width", r.width).or_else(|| small("rect.width", r.width)))
        {
            return Err(e);
        }
        Ok(())
    }

    /// Checks the configuration is one the targets are defined on (docs/conventions.md):
    /// degenerate ones are reported, never silently evaluated.
    pub fn validate(&self) -> Result<(), Degenerate> {
        let mut all = [self.p1, self.p2].concat();
        all.extend(self.material.minv().concat());
        if let Some(r) = self.radius {
            all.push(r);
        }
        if let Some(rect) = &self.rect {
            all.extend(rect.normal);
            all.push(rect.width);
        }
        if all.iter().any(|v| !v.is_finite()) {
            return Err(Degenerate::NotFinite);
        }
        self.representable()?;
        let (p1, e) = (v3(self.p1), v3(self.p2) - v3(self.p1));
        let len = e.length();
        if len == 0.0 {
            return Err(Degenerate::ZeroLength);
        }
        // The line may pass through the origin outside the segment; only the segment matters
        // for the integrals, but d = 0 makes every line formula 0/0, so the reported size is
        // relative to the segment's own scale.
        let scale = v3(self.p1).length().max(v3(self.p2).length());
        let seg = self.distance_to_segment();
        if seg <= 1e-12 * scale {
            return Err(Degenerate::PointOnLight(seg / scale));
        }
        let det = mat(&self.material.minv()).determinant();
        if det == 0.0 || !det.is_finite() {
            return Err(Degenerate::SingularMinv(det));
        }
        if let Some(r) = self.radius {
            if r <= 0.0 {
                return Err(Degenerate::BadRadius(r));
            }
            // The tube (without caps) contains the origin when the origin is within R of
            // the axis and its projection falls inside the segment; the caps are disks of
            // radius R at the ends, covered by the same test on the segment distance.
            if seg <= r {
                return Err(Degenerate::InsideTube { dist: seg, radius: r });
            }
        }
        if let Some(rect) = &self.rect {
            if rect.width <= 0.0 {
                return Err(Degenerate::BadWidth(rect.width));
            }
            let n = v3(rect.normal);
            let (n_len, n_dot) = (n.length(), n.dot(e) / len);
            if (n_len - 1.0).abs() > 1e-6 || n_dot.abs() > 1e-6 {
                return Err(Degenerate::BadRectNormal { len: n_len, dot: n_dot });
            }
            // On the rectangle: in its plane, within its extent.
            let t = p1.dot(e) / (len * len);
            let b = n.cross(e);
            let s = p1.dot(b) / b.length();
            if p1.dot(n).abs() <= 1e-12 * scale && (-1.0..=0.0).contains(&t) && s.abs() <= rect.width / 2.0 {
                return Err(Degenerate::PointOnRectangle);
            }
        }
        if let Some(t) = &self.texture {
            if self.rect.is_some() {
                return Err(Degenerate::BadTexture(
                    "texture: a textured light is a line or a tube; this configuration also has a `rect`".into(),
                ));
            }
            t.check(self.tangent()).map_err(Degenerate::BadTexture)?;
        }
        Ok(())
    }
}

/// What a kernel reads for one configuration, in f64: the members of the WGSL `Scene` in
/// `kernels/prelude.wgsl`, in its order. The GPU scene ([`GpuScene`]) is this rounded to f32;
/// the CPU evaluator (src/eval/interp) reads it as it is (f64) or rounded (f32), so both paths see
/// one definition. For a `ggx` configuration it is the fed one (`Config::fed`: rotated about
/// z so the view lies in the xz-plane, M⁻¹ the fed LTC) with the view and roughness in that
/// frame; `magnitude` is what an LTC method's result is multiplied by (1 otherwise).
#[derive(Clone, Debug, PartialEq)]
pub struct SceneInput {
    pub p1: Vec3,
    pub radius: f64,
    pub p2: Vec3,
    pub rect_width: f64,
    pub rect_normal: Vec3,
    pub flags: u32,
    /// Row-major, `ω_o = minv·ω`.
    pub minv: Mat3,
    /// `ggx`: the unit view direction v in the scene's frame; 0 otherwise.
    pub view: Vec3,
    /// `ggx`: the roughness along `tangent`; 0 otherwise.
    pub alpha_x: f64,
    /// `ggx`: the unit surface direction (⟂ +z) along which the roughness is `alpha_x`; it is
    /// `alpha_y` along `cross(+z, tangent)`. The material's x axis, rotated with the scene.
    pub tangent: Vec3,
    pub alpha_y: f64,
    /// Contract 3. A textured light: the unit vector ⟂ the light where φ = 0; 0 untextured.
    pub tex_origin: Vec3,
    /// `ggx`: Schlick's F0 (F = f0 + (1 − f0)(1 − v·h)⁵); 1, so F = 1, when the material has
    /// none and for other materials.
    pub f0: f64,
    /// 0 untextured, 1 cylindrical, 2 cubemap.
    pub tex_kind: u32,
    /// This scene's first texel in the harness's texel buffer.
    pub tex_offset: u32,
    /// Texels along u and v (a cubemap: the face size, twice).
    pub tex_nu: u32,
    pub tex_nv: u32,
    /// Host-side only, not a `Scene` member.
    pub magnitude: f64,
}

/// The `Scene` members in declaration order with their scalar components (kernels/prelude.wgsl):
/// the layout of [`SceneInput::flatten`].
pub const SCENE_MEMBERS: [(&str, usize); 17] = [
    ("p1", 3),
    ("radius", 1),
    ("p2", 3),
    ("rect_width", 1),
    ("rect_normal", 3),
    ("flags", 1),
    ("minv", 9),
    ("view", 3),
    ("alpha_x", 1),
    ("tangent", 3),
    ("alpha_y", 1),
    ("tex_origin", 3),
    ("f0", 1),
    ("tex_kind", 1),
    ("tex_offset", 1),
    ("tex_nu", 1),
    ("tex_nv", 1),
];

/// Scalar components of all `Scene` members.
pub const SCENE_COMPONENTS: usize = 37;
const _: () = {
    let (mut sum, mut i) = (0, 0);
    while i < SCENE_MEMBERS.len() {
        sum += SCENE_MEMBERS[i].1;
        i += 1;
    }
    assert!(sum == SCENE_COMPONENTS);
};

/// A member's first component in [`SceneInput::flatten`]'s layout and its count; None for a
/// name the contract does not have.
pub fn scene_member(name: &str) -> Option<(usize, usize)> {
    let mut off = 0;
    for (n, len) in SCENE_MEMBERS {
        if n == name {
            return Some((off, len));
        }
        off += len;
    }
    None
}

impl SceneInput {
    pub fn new(config: &Config) -> SceneInput {
        let (fed, magnitude) = config.fed();
        let c = fed.as_ref();
        let mut flags = 0;
        if matches!(c.material, Material::Ltc { .. }) {
            flags |= FLAG_LTC;
        }
        if c.radius.is_some() {
            flags |= FLAG_RADIUS;
        }
        if c.rect.is_some() {
            flags |= FLAG_RECT;
        }
        let (rect_normal, rect_width) = c.rect.as_ref().map(|r| (r.normal, r.width)).unwrap_or(([0.0; 3], 0.0));
        let (mut tex_origin, mut tex_kind, mut tex_size) = ([0.0; 3], 0, [0, 0]);
        if let Some(t) = &c.texture {
            tex_origin = t.origin_for(c.tangent());
            tex_kind = t.kind.code();
            tex_size = t.size;
        }
        let (mut view, mut tangent, mut alpha) = ([0.0; 3], [0.0; 3], [0.0; 2]);
        if let (Material::Ggx { alpha: a, view: v, .. }, Some(f)) = (&config.material, config.material.fed()) {
            flags |= FLAG_GGX;
            view = f.rotate(*v);
            tangent = f.rotate([1.0, 0.0, 0.0]);
            alpha = a.xy();
        }
        SceneInput {
            p1: c.p1,
            radius: c.radius.unwrap_or(0.0),
            p2: c.p2,
            rect_width,
            rect_normal,
            flags,
            minv: c.material.minv(),
            view,
            alpha_x: alpha[0],
            tangent,
            alpha_y: alpha[1],
            tex_origin,
            f0: config.material.f0(),
            tex_kind,
            // Set by whoever lays the texels out (`texel_buffer`).
            tex_offset: 0,
            tex_nu: tex_size[0],
            tex_nv: tex_size[1],
            magnitude,
        }
    }

    /// A `Scene` member by its WGSL name, flattened as the evaluator lays values out
    /// (matrices column by column); None for a name the contract does not have.
    pub fn member(&self, name: &str) -> Option<Vec<f64>> {
        let (off, len) = scene_member(name)?;
        let mut all = [0.0; SCENE_COMPONENTS];
        self.flatten(&mut all);
        Some(all[off..off + len].to_vec())
    }

    /// Every member's components in [`SCENE_MEMBERS`] order (matrices column by column), as
    /// [`SceneInput::member`] gives them one by one, without allocating: the compiled
    /// evaluator fills each configuration's scene from it.
    pub fn flatten(&self, out: &mut [f64; SCENE_COMPONENTS]) {
        let mut k = 0;
        let mut put = |x: f64| {
            out[k] = x;
            k += 1;
        };
        self.p1.iter().for_each(|&x| put(x));
        put(self.radius);
        self.p2.iter().for_each(|&x| put(x));
        put(self.rect_width);
        self.rect_normal.iter().for_each(|&x| put(x));
        put(f64::from(self.flags));
        for j in 0..3 {
            for i in 0..3 {
                put(self.minv[i][j]);
            }
        }
        self.view.iter().for_each(|&x| put(x));
        put(self.alpha_x);
        self.tangent.iter().for_each(|&x| put(x));
        put(self.alpha_y);
        self.tex_origin.iter().for_each(|&x| put(x));
        put(self.f0);
        put(f64::from(self.tex_kind));
        put(f64::from(self.tex_offset));
        put(f64::from(self.tex_nu));
        put(f64::from(self.tex_nv));
    }
}

/// The configuration as a compute kernel reads it: std430 layout of the WGSL `Scene`
/// in `kernels/prelude.wgsl` (160 bytes). `minv` is stored column-major as WGSL's
/// `mat3x3<f32>` is, each column padded to 16 bytes. Members are only ever added at the
/// end (the first 96 bytes are contract 1, before the ggx members; the first 128 contract 2,
/// before Fresnel and textures), so a kernel written to an older contract reads what it
/// always read (tests/scene_contract.rs).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuScene {
    pub p1: [f32; 3],
    pub radius: f32,
    pub p2: [f32; 3],
    pub rect_width: f32,
    pub rect_normal: [f32; 3],
    pub flags: u32,
    pub minv_cols: [[f32; 4]; 3],
    pub view: [f32; 3],
    pub alpha_x: f32,
    pub tangent: [f32; 3],
    pub alpha_y: f32,
    pub tex_origin: [f32; 3],
    pub f0: f32,
    pub tex_kind: u32,
    pub tex_offset: u32,
    pub tex_nu: u32,
    pub tex_nv: u32,
}

/// The kernel contract's version: which `Scene` members exist (kernels/README.md). 1: the
/// geometry and M⁻¹ (96 bytes); 2: + the ggx view and roughness (128); 3: + `tex_origin`, `f0`,
/// `tex_kind`, `tex_offset`, `tex_nu`, `tex_nv` (160).
pub const SCENE_CONTRACT: u32 = 3;

pub const FLAG_LTC: u32 = 1;
pub const FLAG_RADIUS: u32 = 2;
pub const FLAG_RECT: u32 = 4;
/// A `ggx` configuration: `view`, `alpha_x`, `tangent` and `alpha_y` are set, and M⁻¹ is the
/// fed LTC. Host-side, `minv_cols[0][3]` (padding the kernel never reads) holds the magnitude
/// the runner multiplies an LTC method's result by in f32, which is what a shader's
/// `method(scene) * magnitude` computes.
pub const FLAG_GGX: u32 = 8;

impl GpuScene {
    /// The factor an LTC method's result is multiplied by (the fed magnitude; 1 for other
    /// materials). A `minv: ggx` kernel evaluates the GGX lobe itself and is not scaled.
    pub fn magnitude(&self) -> f32 {
        if self.flags & FLAG_GGX != 0 {
            self.minv_cols[0][3]
        } else {
            1.0
        }
    }
}

impl From<&SceneInput> for GpuScene {
    fn from(s: &SceneInput) -> Self {
        let f = |v: Vec3| [v[0] as f32, v[1] as f32, v[2] as f32];
        let m = s.minv;
        let mut scene = GpuScene {
            p1: f(s.p1),
            radius: s.radius as f32,
            p2: f(s.p2),
            rect_width: s.rect_width as f32,
            rect_normal: f(s.rect_normal),
            flags: s.flags,
            minv_cols: [0, 1, 2].map(|j| [m[0][j] as f32, m[1][j] as f32, m[2][j] as f32, 0.0]),
            view: f(s.view),
            alpha_x: s.alpha_x as f32,
            tangent: f(s.tangent),
            alpha_y: s.alpha_y as f32,
            tex_origin: f(s.tex_origin),
            f0: s.f0 as f32,
            tex_kind: s.tex_kind,
            tex_offset: s.tex_offset,
            tex_nu: s.tex_nu,
            tex_nv: s.tex_nv,
        };
        if s.flags & FLAG_GGX != 0 {
            scene.minv_cols[0][3] = s.magnitude as f32;
        }
        scene
    }
}

/// The GPU scenes of `configs` and the texel buffer their textures are laid out in, one after
/// another in order, each scene's `tex_offset` its first texel (empty when none is textured).
/// Texels are rounded to f32 as the kernel reads them.
pub fn gpu_scenes(configs: &[Config]) -> (Vec<GpuScene>, Vec<f32>) {
    let mut texels = Vec::new();
    let scenes = configs
        .iter()
        .map(|c| {
            let mut s = GpuScene::from(c);
            if let Some(t) = &c.texture {
                s.tex_offset = u32::try_from(texels.len()).unwrap_or(u32::MAX);
                texels.extend(t.texels.iter().map(|&x| x as f32));
            }
            s
        })
        .collect();
    (scenes, texels)
}

impl From<&Config> for GpuScene {
    fn from(c: &Config) -> Self {
        GpuScene::from(&SceneInput::new(c))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn base() -> Config {
        Config {
            id: "c".into(),
            p1: [0.3, -0.2, 1.0],
            p2: [0.9, 0.4, 1.6],
            radius: None,
            rect: None,
            material: Material::Diffuse,
            texture: None,
        }
    }

    #[test]
    fn parses_design_example_and_rejects_unknown_fields() {
        let s = r#"{"id": "c1", "p1": [0.3, -0.2, 1.0], "p2": [0.9, 0.4, 1.6], "radius": 0.01,
            "rect": {"normal": [0.0, 0.0, -1.0], "width": 0.02},
            "material": {"kind": "ltc", "minv": [[0.5, 0, 0.1], [0, 0.6, 0], [-0.2, 0, 1]]}}"#;
        let c: Config = serde_json::from_str(s).unwrap();
        assert_eq!(c.radius, Some(0.01));
        assert!(c.material.is_sparse());
        let bad = s.replace("\"radius\"", "\"radios\"");
        let err = serde_json::from_str::<Config>(&bad).unwrap_err().to_string();
        assert!(err.contains("radios"), "{err}");
        let bad_mat = r#"{"id":"c","p1":[0,0,1],"p2":[1,0,1],"material":{"kind":"diffuse","roughness":1}}"#;
        assert!(serde_json::from_str::<Config>(bad_mat).is_err());
    }

    #[test]
    fn degenerate_configurations_are_named() {
        let mut c = base();
        assert_eq!(c.validate(), Ok(()));
        c.p2 = c.p1;
        assert_eq!(c.validate(), Err(Degenerate::ZeroLength));
        let mut c = base();
        c.p1 = [-1.0, 0.0, 0.0];
        c.p2 = [1.0, 0.0, 0.0];
        assert!(matches!(c.validate(), Err(Degenerate::PointOnLight(_))));
        // The line passes through the origin, but not the segment: allowed.
        c.p1 = [1.0, 0.0, 0.0];
        c.p2 = [2.0, 0.0, 0.0];
        assert_eq!(c.validate(), Ok(()));
        let mut c = base();
        c.radius = Some(2.0);
        assert!(matches!(c.validate(), Err(Degenerate::InsideTube { .. })));
        let mut c = base();
        c.material = Material::Ltc {
            minv: [[1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
        };
        assert!(matches!(c.validate(), Err(Degenerate::SingularMinv(_))));
    }

    #[test]
    fn gpu_layout_is_160_bytes_column_major() {
        assert_eq!(std::mem::size_of::<GpuScene>(), 160);
        // The contract's first 96 bytes are where they were before the ggx members.
        assert_eq!(std::mem::offset_of!(GpuScene, minv_cols), 48);
        assert_eq!(std::mem::offset_of!(GpuScene, view), 96);
        assert_eq!(std::mem::offset_of!(GpuScene, tangent), 112);
        // Contract 3 starts where contract 2 ended.
        assert_eq!(std::mem::offset_of!(GpuScene, tex_origin), 128);
        assert_eq!(std::mem::offset_of!(GpuScene, f0), 140);
        assert_eq!(std::mem::offset_of!(GpuScene, tex_nv), 156);
        let mut c = base();
        c.material = Material::Ltc {
            minv: [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]],
        };
        let g = GpuScene::from(&c);
        assert_eq!(g.minv_cols[0][..3], [1.0, 4.0, 7.0]);
        assert_eq!(g.flags, FLAG_LTC);
    }
}
