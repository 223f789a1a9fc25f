//! A render scene (`linelight render`, docs/render.md): a case file with a `[render]` table
//! instead of distributions. The camera and pixel geometry are docs/render.md's contract
//! ("Geometry"); every floor pixel becomes one configuration in the world's axes.

use crate::input::geometry::{v3, DVec3};
use crate::input::scene::{Config, Material, Rect, Roughness, Vec3};
use crate::limits::MAX_PIXELS;
use serde::Deserialize;
use std::path::Path;

/// The scene file as written. Unknown keys are errors.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    name: String,
    #[serde(default)]
    description: Option<String>,
    methods: Vec<String>,
    render: RawRender,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRender {
    width: u32,
    height: u32,
    camera: Camera,
    light: RawLight,
    material: RawMaterial,
    /// Floor points farther than this from the camera are background (cuts the grazing band).
    #[serde(default)]
    max_distance: Option<f64>,
    /// The failure the scene is built to show (its report says whether it is visible).
    #[serde(default)]
    failure: Option<Failure>,
}

/// The pinhole camera: up is +z.
#[derive(Clone, Debug, Deserialize, serde::Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Camera {
    pub position: Vec3,
    pub look_at: Vec3,
    pub fov_deg: f64,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLight {
    p1: Vec3,
    p2: Vec3,
    #[serde(default)]
    radius: Option<f64>,
    #[serde(default)]
    rect: Option<Rect>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaterial {
    kind: String,
    #[serde(default)]
    alpha: Option<Roughness>,
    #[serde(default)]
    alpha_ramp: Option<[f64; 2]>,
    #[serde(default)]
    minv: Option<[[f64; 3]; 3]>,
    #[serde(default)]
    ltc: Option<String>,
    #[serde(default)]
    f0: Option<f64>,
}

/// What the scene is built to show: `methods` should show it, `fixed` should not, and each
/// fixed method should have a smaller mean FLIP than each failing one.
#[derive(Clone, Debug, Deserialize, serde::Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Failure {
    pub what: String,
    pub methods: Vec<String>,
    #[serde(default)]
    pub fixed: Vec<String>,
    /// Whether "mean FLIP of each failing method > each fixed one's" is a claim: a run where
    /// it does not hold exits 3, as a stale sweep claim does. Otherwise it is only reported.
    #[serde(default)]
    pub claim: bool,
}

/// The floor's material: fixed, or a GGX roughness ramp across the image.
#[derive(Clone, Debug, PartialEq)]
pub enum FloorMaterial {
    Diffuse,
    Ltc {
        minv: [[f64; 3]; 3],
    },
    Ggx {
        alpha: Roughness,
        f0: Option<f64>,
        ltc: Option<String>,
    },
    GgxRamp {
        left: f64,
        right: f64,
        f0: Option<f64>,
        ltc: Option<String>,
    },
}

/// A checked scene.
#[derive(Clone, Debug)]
pub struct RenderScene {
    pub name: String,
    pub description: Option<String>,
    pub methods: Vec<String>,
    pub width: u32,
    pub height: u32,
    pub camera: Camera,
    pub p1: Vec3,
    pub p2: Vec3,
    pub radius: Option<f64>,
    pub rect: Option<Rect>,
    pub material: FloorMaterial,
    pub max_distance: Option<f64>,
    pub failure: Option<Failure>,
}

/// One floor pixel: where its ray meets the floor and the configuration it is.
#[derive(Clone, Debug)]
pub struct FloorPixel {
    pub x: u32,
    pub y: u32,
    /// The floor point s (z = 0).
    pub point: Vec3,
    /// The view's elevation above the floor, degrees.
    pub elevation_deg: f64,
    pub config: Config,
}

/// The view's elevation below which a floor pixel is in the grazing band (reported apart).
pub const GRAZING_DEG: f64 = 5.0;

/// `b − a`, normalised (as an array: configurations keep arrays).
fn unit_from(a: Vec3, b: Vec3) -> Vec3 {
    (v3(b) - v3(a)).normalize().to_array()
}

impl RenderScene {
    pub fn load(path: &Path) -> anyhow::Result<RenderScene> {
        let text = crate::io::read_text(path, "scene file", crate::limits::MAX_TEXT_INPUT)?;
        Self::parse(&path.display().to_string(), &text)
    }

    /// Parses and checks a scene; every error names the file and the key.
    pub fn parse(at: &str, text: &str) -> anyhow::Result<RenderScene> {
        let raw: RawScene = toml::from_str(text).map_err(|e| anyhow::anyhow!("{at}: {e}"))?;
        let scene = Self::check(raw).map_err(|e| anyhow::anyhow!("{at}: {e}"))?;
        Ok(scene)
    }

    fn check(raw: RawScene) -> Result<RenderScene, String> {
        // The name becomes the output folder's name (as a case's does).
        let mut chars = raw.name.chars();
        let ok = chars.next().is_some_and(|c| c.is_ascii_alphanumeric())
            && chars.all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-'))
            && raw.name.len() <= crate::limits::MAX_NAME;
        if !ok {
            return Err(format!(
                "`name` = \"{}\": it becomes the output folder's name, so it must be 1–100 letters, digits, \
                 '.', '_' or '-', starting with a letter or digit",
                crate::input::names::clip(&raw.name)
            ));
        }
        if raw.methods.is_empty() {
            return Err("methods: name at least one method".into());
        }
        let r = raw.render;
        if r.width == 0 || r.height == 0 {
            return Err(format!(
                "render.width and render.height must be > 0, got {} × {}",
                r.width, r.height
            ));
        }
        if u64::from(r.width) * u64::from(r.height) > MAX_PIXELS {
            return Err(format!(
                "render: {} × {} pixels is more than {MAX_PIXELS}",
                r.width, r.height
            ));
        }
        let finite = |key: &str, v: &[f64]| -> Result<(), String> {
            if v.iter().all(|x| x.is_finite()) {
                Ok(())
            } else {
                Err(format!("{key} must be finite, got {v:?}"))
            }
        };
        let c = &r.camera;
        finite("render.camera.position", &c.position)?;
        finite("render.camera.look_at", &c.look_at)?;
        if !(c.fov_deg > 0.0 && c.fov_deg < 180.0) {
            return Err(format!("render.camera.fov_deg must be in (0, 180), got {}", c.fov_deg));
        }
        if !(c.position[2] > 0.0) {
            return Err(format!(
                "render.camera.position = {:?} is on or below the floor (z = {} <= 0): the camera must be above z = 0",
                c.position, c.position[2]
            ));
        }
        let f = v3(c.look_at) - v3(c.position);
        if f.length() == 0.0 {
            return Err("render.camera: look_at equals position (no view direction)".into());
        }
        let f = f.normalize();
        // f × z vanishes when f ∥ z: r is undefined.
        if f.cross(DVec3::Z).length() < 1e-9 {
            return Err(format!(
                "render.camera looks straight {} (look_at − position = {:?} is parallel to z): \
                 the camera's right vector f × z is undefined",
                if f.z < 0.0 { "down" } else { "up" },
                (v3(c.look_at) - v3(c.position)).to_array()
            ));
        }
        let l = &r.light;
        finite("render.light.p1", &l.p1)?;
        finite("render.light.p2", &l.p2)?;
        if l.p1 == l.p2 {
            return Err("render.light: p1 and p2 coincide".into());
        }
        if l.radius.is_some() && l.rect.is_some() {
            return Err("render.light: give radius (a tube) or rect (a rectangle), not both".into());
        }
        if let Some(rad) = l.radius {
            if !(rad > 0.0 && rad.is_finite()) {
                return Err(format!("render.light.radius must be > 0, got {rad}"));
            }
        }
        if let Some(rect) = &l.rect {
            if !(rect.width > 0.0 && rect.width.is_finite()) {
                return Err(format!("render.light.rect.width must be > 0, got {}", rect.width));
            }
            finite("render.light.rect.normal", &rect.normal)?;
        }
        if let Some(d) = r.max_distance {
            if !(d > 0.0) {
                return Err(format!("render.max_distance must be > 0, got {d}"));
            }
        }
        let m = &r.material;
        if m.f0.is_some() && m.kind != "ggx" {
            return Err(format!(
                "render.material.f0: Schlick's F0 is for a ggx material, not `{}`",
                m.kind
            ));
        }
        if let Some(f0) = m.f0 {
            crate::input::scene::check_f0(f0).map_err(|e| format!("render.material.f0: {e}"))?;
        }
        let material = match m.kind.as_str() {
            "diffuse" => {
                if m.alpha.is_some() || m.alpha_ramp.is_some() || m.minv.is_some() || m.ltc.is_some() {
                    return Err("render.material: a diffuse material takes no alpha, alpha_ramp, minv or ltc".into());
                }
                FloorMaterial::Diffuse
            }
            "ltc" => {
                let minv = m
                    .minv
                    .ok_or("render.material: an ltc material needs `minv` (3×3, row-major)")?;
                if m.alpha.is_some() || m.alpha_ramp.is_some() || m.ltc.is_some() {
                    return Err("render.material: an ltc material takes only `minv`".into());
                }
                FloorMaterial::Ltc { minv }
            }
            "ggx" => {
                if m.minv.is_some() {
                    return Err(
                        "render.material: a ggx material takes no `minv` (its LTC is fitted: see `ltc`)".into(),
                    );
                }
                let ok = |a: f64| a.is_finite() && a > 0.0 && a <= 1.0;
                if let Some(feed) = &m.ltc {
                    let feed = crate::input::ltc::Feed::parse(feed).map_err(|e| format!("render.material.ltc: {e}"))?;
                    use crate::input::ltc::Feed;
                    if m.f0.is_some_and(|f| f != 1.0) && matches!(feed, Feed::Published | Feed::PublishedF16) {
                        return Err(format!(
                            "render.material.f0: ltc = \"{}\" has no Fresnel channel (the published table stores \
                             M⁻¹ and the magnitude only); use ltc = \"table\", \"table_f16\", \"fit\", \"aniso\" \
                             or \"aniso_f16\" with f0, or leave f0 out",
                            feed.name()
                        ));
                    }
                }
                match (m.alpha, m.alpha_ramp) {
                    (Some(_), Some(_)) => {
                        return Err("render.material: give `alpha` or `alpha_ramp`, not both".into());
                    }
                    (None, None) => return Err(
                        "render.material: a ggx material needs `alpha` (a or [ax, ay]) or `alpha_ramp = [left, right]`"
                            .into(),
                    ),
                    (Some(alpha), None) => {
                        if !alpha.xy().iter().all(|&a| ok(a)) {
                            return Err(format!("render.material.alpha must be in (0, 1], got {:?}", alpha.xy()));
                        }
                        FloorMaterial::Ggx {
                            alpha,
                            f0: m.f0,
                            ltc: m.ltc.clone(),
                        }
                    }
                    (None, Some([left, right])) => {
                        if !(ok(left) && ok(right)) {
                            return Err(format!(
                                "render.material.alpha_ramp must be in (0, 1], got [{left}, {right}]"
                            ));
                        }
                        FloorMaterial::GgxRamp {
                            left,
                            right,
                            f0: m.f0,
                            ltc: m.ltc.clone(),
                        }
                    }
                }
            }
            other => return Err(format!("render.material.kind `{other}`: use diffuse, ltc or ggx")),
        };
        if let Some(fail) = &r.failure {
            for name in fail.methods.iter().chain(&fail.fixed) {
                if !raw.methods.contains(name) {
                    return Err(format!("render.failure names `{name}`, which is not in `methods`"));
                }
            }
        }
        Ok(RenderScene {
            name: raw.name,
            description: raw.description,
            methods: raw.methods,
            width: r.width,
            height: r.height,
            camera: r.camera,
            p1: l.p1,
            p2: l.p2,
            radius: l.radius,
            rect: l.rect.clone(),
            material,
            max_distance: r.max_distance,
            failure: r.failure,
        })
    }

    /// The camera basis (f, r, u) of the contract.
    pub fn basis(&self) -> [Vec3; 3] {
        let f = (v3(self.camera.look_at) - v3(self.camera.position)).normalize();
        let r = f.cross(DVec3::Z).normalize();
        let u = r.cross(f);
        [f.to_array(), r.to_array(), u.to_array()]
    }

    /// The unit ray of pixel (x, y), y = 0 the top row.
    pub fn ray(&self, x: u32, y: u32) -> Vec3 {
        self.ray_in(&self.basis(), x, y)
    }

    /// [`ray`](Self::ray) with the camera basis computed once for the whole image.
    fn ray_in(&self, [f, r, u]: &[Vec3; 3], x: u32, y: u32) -> Vec3 {
        let (f, r, u) = (*f, *r, *u);
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        let t = (self.camera.fov_deg.to_radians() / 2.0).tan();
        let a = (2.0 * (f64::from(x) + 0.5) / w - 1.0) * t * w / h;
        let b = (1.0 - 2.0 * (f64::from(y) + 0.5) / h) * t;
        (v3(f) + a * v3(r) + b * v3(u)).normalize().to_array()
    }

    /// The material of the configuration at floor point `s`, pixel column `x`.
    fn material_at(&self, x: u32, s: Vec3) -> Result<Material, String> {
        let view = unit_from(s, self.camera.position);
        match &self.material {
            FloorMaterial::Diffuse => Ok(Material::Diffuse),
            FloorMaterial::Ltc { minv } => Ok(Material::Ltc { minv: *minv }),
            FloorMaterial::Ggx { alpha, f0, ltc } => Material::ggx_fresnel(*alpha, view, *f0, ltc.as_deref()),
            FloorMaterial::GgxRamp { left, right, f0, ltc } => {
                let a = left + (right - left) * (f64::from(x) + 0.5) / f64::from(self.width);
                Material::ggx_fresnel(Roughness::Iso(a), view, *f0, ltc.as_deref())
            }
        }
    }

    /// Every pixel whose ray meets the floor (within `max_distance`), row by row; a pixel
    /// whose configuration is degenerate (the floor point on the light, inside the tube) is
    /// an error naming it: the scene must keep its light off the visible floor.
    pub fn floor_pixels(&self) -> Result<Vec<FloorPixel>, String> {
        let pos = self.camera.position;
        let basis = self.basis();
        let mut out = Vec::new();
        for y in 0..self.height {
            for x in 0..self.width {
                let d = self.ray_in(&basis, x, y);
                if !(d[2] < 0.0) {
                    continue;
                }
                let t = -pos[2] / d[2];
                if self.max_distance.is_some_and(|m| t > m) {
                    continue;
                }
                // Exactly on the floor: z is 0 by definition, not by rounding.
                let s = [pos[0] + t * d[0], pos[1] + t * d[1], 0.0];
                let view = unit_from(s, pos);
                let mut config = Config {
                    id: format!("{x}_{y}"),
                    p1: (v3(self.p1) - v3(s)).to_array(),
                    p2: (v3(self.p2) - v3(s)).to_array(),
                    radius: self.radius,
                    rect: self.rect.clone(),
                    material: self
                        .material_at(x, s)
                        .map_err(|e| format!("pixel {x}_{y}: material: {e}"))?,
                    texture: None,
                };
                config.orthonormalize_rect();
                config
                    .validate()
                    .map_err(|e| format!("pixel {x}_{y} (floor point {s:?}): {e}"))?;
                out.push(FloorPixel {
                    x,
                    y,
                    point: s,
                    elevation_deg: view[2].clamp(-1.0, 1.0).asin().to_degrees(),
                    config,
                });
            }
        }
        Ok(out)
    }
}
