//! Seed 002's light textures: a scalar tint over a line or tube light, carried by a
//! configuration as `"texture": {"kind", "size", "texels", "origin"}` (docs/conventions.md,
//! docs/eval-format.md). This module reads and checks it and defines, once, what a texel lookup
//! means on the host: the references integrate it and the tests compare the kernels' routine
//! (`ll_texel_bilinear` in kernels/prelude.wgsl) against it.
//!
//! - `cylindrical`: texel (i, j) at index `j·nu + i`; u = l/L along the light from p1,
//!   v = φ/2π around it, φ measured from `origin` (a unit vector ⟂ ω_t), right-handed about
//!   ω_t. Bilinear between texel centres ((i+½)/nu, (j+½)/nv), clamped to the edge in u,
//!   wrapping in v. The end caps are untextured.
//! - `cubemap`: six square faces of n×n texels (`size` = [n, n]) in Vulkan's layer order +X,
//!   −X, +Y, −Y, +Z, −Z, each row-major with s fastest, in the light's frame
//!   (X = origin, Y = ω_t × origin, Z = ω_t). A direction picks its face and (s, t) by
//!   Vulkan's cube-map face selection (ties to X, then Y); each face is filtered bilinearly
//!   between texel centres, clamped at the face's edges (no filtering across faces). The tint
//!   of a point of the light toward the shading point is the cube in that emission direction
//!   (from the point to the shading point), for the side and the caps alike.

use serde::{Deserialize, Serialize};

pub type Vec3 = [f64; 3];

/// A texture's side may have at most this many texels (limits.rs holds the total).
pub use crate::limits::{MAX_TEXELS, MAX_TEXTURE_SIDE};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TextureKind {
    Cylindrical,
    Cubemap,
}

impl TextureKind {
    /// `Scene.tex_kind` (kernels/README.md).
    pub fn code(self) -> u32 {
        match self {
            TextureKind::Cylindrical => 1,
            TextureKind::Cubemap => 2,
        }
    }
}

/// A light texture as a configuration carries it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Texture {
    pub kind: TextureKind,
    /// [nu, nv] (cylindrical) or [n, n] (cubemap: each face n×n).
    pub size: [u32; 2],
    pub texels: Vec<f64>,
    /// φ = 0 (cylindrical) or the frame's X axis (cubemap); absent: the first vector of the
    /// prelude's `buildOrthonormalBasis(ω_t)`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub origin: Option<Vec3>,
}

/// Listing 1.3's basis (Frisvad), in f64, as the prelude computes it in f32: its first vector
/// is a texture's default origin.
pub fn frisvad_b1(n: Vec3) -> Vec3 {
    if n[2] < -0.9999999 {
        return [0.0, -1.0, 0.0];
    }
    let a = 1.0 / (1.0 + n[2]);
    let b = -n[0] * n[1] * a;
    [1.0 - n[0] * n[0] * a, b, -n[0]]
}

fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

impl Texture {
    /// A texture of one value everywhere (a 1×1 cylindrical one).
    pub fn constant(c: f64) -> Texture {
        Texture {
            kind: TextureKind::Cylindrical,
            size: [1, 1],
            texels: vec![c],
            origin: None,
        }
    }

    /// How many texels `size` asks for.
    pub fn texel_count(&self) -> u64 {
        let [nu, nv] = self.size.map(u64::from);
        match self.kind {
            TextureKind::Cylindrical => nu * nv,
            TextureKind::Cubemap => 6 * nu * nv,
        }
    }

    /// Checks the texture against the light's unit tangent `dir`. The message names the field.
    pub fn check(&self, dir: Vec3) -> Result<(), String> {
        let [nu, nv] = self.size;
        if nu == 0 || nv == 0 || nu > MAX_TEXTURE_SIDE || nv > MAX_TEXTURE_SIDE {
            return Err(format!(
                "texture.size {:?}: each side must be 1 to {MAX_TEXTURE_SIDE} texels",
                self.size
            ));
        }
        if self.kind == TextureKind::Cubemap && nu != nv {
            return Err(format!(
                "texture.size {:?}: a cubemap's faces are square (n, n)",
                self.size
            ));
        }
        let want = self.texel_count();
        if want > MAX_TEXELS {
            return Err(format!(
                "texture.size {:?}: {want} texels, more than the {MAX_TEXELS} allowed",
                self.size
            ));
        }
        if self.texels.len() as u64 != want {
            let shape = match self.kind {
                TextureKind::Cylindrical => format!("{nu}×{nv}"),
                TextureKind::Cubemap => format!("6 faces × {nu}×{nv}"),
            };
            return Err(format!(
                "texture.texels: {} numbers, but size {:?} asks for {want} ({shape})",
                self.texels.len(),
                self.size
            ));
        }
        if let Some(i) = self.texels.iter().position(|t| !t.is_finite()) {
            return Err(format!("texture.texels[{i}] is not finite ({})", self.texels[i]));
        }
        if let Some(o) = self.origin {
            if !o.iter().all(|x| x.is_finite()) {
                return Err(format!("texture.origin {o:?} is not finite"));
            }
            let len = dot(o, o).sqrt();
            let along = dot(o, dir);
            if (len - 1.0).abs() > 1e-6 || along.abs() > 1e-6 {
                return Err(format!(
                    "texture.origin must be a unit vector perpendicular to p2 - p1 (|origin| = {len:.6}, origin·ω_t = {along:.2e})"
                ));
            }
        }
        Ok(())
    }

    /// The origin used for a light of unit tangent `dir`: the given one, or the prelude's.
    pub fn origin_for(&self, dir: Vec3) -> Vec3 {
        self.origin.unwrap_or_else(|| frisvad_b1(dir))
    }

    /// The texture as an f32 kernel receives it: texels and origin rounded to f32.
    pub fn rounded_to_f32(&self) -> Texture {
        let r = |x: f64| x as f32 as f64;
        Texture {
            kind: self.kind,
            size: self.size,
            texels: self.texels.iter().map(|&t| r(t)).collect(),
            origin: self.origin.map(|o| o.map(r)),
        }
    }

    /// The face-local bilinear lookup: texels `base..base + nu·nv` as an nu×nv grid, at (u, v),
    /// clamped in u, and in v clamped (`wrap_v` false) or wrapping. The rule the kernels'
    /// `ll_texel_bilinear` implements.
    pub fn bilinear(&self, base: usize, u: f64, v: f64, wrap_v: bool) -> f64 {
        let [nu, nv] = self.size.map(|n| n as usize);
        let x = (u * nu as f64 - 0.5).clamp(0.0, (nu - 1) as f64);
        let i0 = (x.floor() as usize).min(nu - 1);
        let i1 = (i0 + 1).min(nu - 1);
        let a = x - i0 as f64;
        let (j0, j1, b) = if wrap_v {
            let y = (v - v.floor()) * nv as f64 - 0.5;
            let f = y.floor();
            let j0 = (f as i64).rem_euclid(nv as i64) as usize;
            (j0, (j0 + 1) % nv, y - f)
        } else {
            let y = (v * nv as f64 - 0.5).clamp(0.0, (nv - 1) as f64);
            let j0 = (y.floor() as usize).min(nv - 1);
            (j0, (j0 + 1).min(nv - 1), y - j0 as f64)
        };
        let t = |i: usize, j: usize| self.texels[base + j * nu + i];
        (1.0 - b) * ((1.0 - a) * t(i0, j0) + a * t(i1, j0)) + b * ((1.0 - a) * t(i0, j1) + a * t(i1, j1))
    }

    /// Cylindrical: the tint at u = l/L and v = φ/2π.
    pub fn cylindrical(&self, u: f64, v: f64) -> f64 {
        self.bilinear(0, u, v, true)
    }

    /// Cubemap: the tint in direction `w` given in the light's frame (X, Y, Z) (need not be
    /// unit): Vulkan's face selection, then the face's bilinear lookup clamped at its edges.
    pub fn cube(&self, w: Vec3) -> f64 {
        let (face, s, t) = cube_face(w);
        let n = self.size[0] as usize;
        self.bilinear(face * n * n, s, t, false)
    }

    /// The light's frame (X, Y, Z) = (origin, ω_t × origin, ω_t) for a unit tangent `dir`.
    pub fn frame(&self, dir: Vec3) -> [Vec3; 3] {
        let o = self.origin_for(dir);
        [o, cross(dir, o), dir]
    }
}

/// Vulkan's cube-map face selection (the spec's table "Cube map face selection"): the face
/// (0..6 = +X, −X, +Y, −Y, +Z, −Z) and (s, t) ∈ [0, 1]². Ties go to X, then Y.
pub fn cube_face(w: Vec3) -> (usize, f64, f64) {
    let [x, y, z] = w;
    let (ax, ay, az) = (x.abs(), y.abs(), z.abs());
    let (face, sc, tc, ma) = if ax >= ay && ax >= az {
        if x >= 0.0 {
            (0, -z, -y, ax)
        } else {
            (1, z, -y, ax)
        }
    } else if ay >= az {
        if y >= 0.0 {
            (2, x, z, ay)
        } else {
            (3, x, -z, ay)
        }
    } else if z >= 0.0 {
        (4, x, -y, az)
    } else {
        (5, -x, -y, az)
    };
    (face, 0.5 * (sc / ma + 1.0), 0.5 * (tc / ma + 1.0))
}

/// Per face, the (unnormalised) axes whose ratios give (s, t): `sc = k_s·w / (k_a·w)`,
/// `tc = k_t·w / (k_a·w)` with k_a the face's outward axis, in frame coordinates. The planes
/// `k_s − c·k_a` through the origin are where a face's s equals c: the references cut there.
pub const CUBE_AXES: [([f64; 3], [f64; 3], [f64; 3]); 6] = [
    ([1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, -1.0, 0.0]),
    ([-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]),
    ([0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
    ([0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]),
    ([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]),
    ([0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]),
];

#[cfg(test)]
mod tests {
    use super::*;

    fn tex(kind: TextureKind, size: [u32; 2], texels: Vec<f64>) -> Texture {
        Texture {
            kind,
            size,
            texels,
            origin: None,
        }
    }

    #[test]
    fn bilinear_between_centres_clamps_u_and_wraps_v() {
        // 2×2: u fastest.
        let t = tex(TextureKind::Cylindrical, [2, 2], vec![0.0, 1.0, 10.0, 11.0]);
        // Texel centres give the texels.
        assert_eq!(t.cylindrical(0.25, 0.25), 0.0);
        assert_eq!(t.cylindrical(0.75, 0.25), 1.0);
        assert_eq!(t.cylindrical(0.75, 0.75), 11.0);
        // Clamped in u beyond the outer centres.
        assert_eq!(t.cylindrical(0.0, 0.25), 0.0);
        assert_eq!(t.cylindrical(1.0, 0.25), 1.0);
        assert_eq!(t.cylindrical(0.5, 0.25), 0.5);
        // Wrapping in v: v = 0 lies half-way between row 1 (v = 0.75 − 1) and row 0.
        assert_eq!(t.cylindrical(0.25, 0.0), 5.0);
        assert_eq!(t.cylindrical(0.25, 1.0), 5.0);
        assert_eq!(t.cylindrical(0.25, -0.75), 0.0);
    }

    #[test]
    fn cube_faces_follow_vulkan() {
        assert_eq!(cube_face([1.0, 0.0, 0.0]), (0, 0.5, 0.5));
        assert_eq!(cube_face([0.0, 0.0, -1.0]).0, 5);
        // +X: s grows towards −Z, t towards −Y.
        let (_, s, t) = cube_face([1.0, -0.5, -0.5]);
        assert_eq!((s, t), (0.75, 0.75));
        // +Y: s towards +X, t towards +Z.
        let (f, s, t) = cube_face([0.5, 1.0, 0.5]);
        assert_eq!((f, s, t), (2, 0.75, 0.75));
        for (face, (a, ks, kt)) in CUBE_AXES.iter().enumerate() {
            let w = [
                0.3 * ks[0] + 0.1 * kt[0] + a[0],
                0.3 * ks[1] + 0.1 * kt[1] + a[1],
                0.3 * ks[2] + 0.1 * kt[2] + a[2],
            ];
            let (f, s, t) = cube_face(w);
            assert_eq!(f, face);
            assert!((s - 0.65).abs() < 1e-15 && (t - 0.55).abs() < 1e-15, "{face}: {s} {t}");
        }
    }

    #[test]
    fn malformed_textures_name_the_field() {
        let dir = [0.0, 0.0, 1.0];
        let ok = tex(TextureKind::Cylindrical, [2, 3], vec![1.0; 6]);
        assert_eq!(ok.check(dir), Ok(()));
        let e = tex(TextureKind::Cylindrical, [2, 3], vec![1.0; 5])
            .check(dir)
            .unwrap_err();
        assert!(e.contains("texture.texels") && e.contains("6"), "{e}");
        let mut nan = ok.clone();
        nan.texels[4] = f64::NAN;
        assert!(nan.check(dir).unwrap_err().contains("texture.texels[4]"));
        let mut o = ok.clone();
        o.origin = Some([0.0, 0.6, 0.8]);
        assert!(o.check(dir).unwrap_err().contains("texture.origin"));
        o.origin = Some([0.0, 0.5, 0.0]);
        assert!(o.check(dir).unwrap_err().contains("texture.origin"));
        o.origin = Some([0.0, 1.0, 0.0]);
        assert_eq!(o.check(dir), Ok(()));
        let e = tex(TextureKind::Cubemap, [2, 3], vec![1.0; 36]).check(dir).unwrap_err();
        assert!(e.contains("texture.size"), "{e}");
        let e = tex(TextureKind::Cylindrical, [0, 3], vec![]).check(dir).unwrap_err();
        assert!(e.contains("texture.size"), "{e}");
        let e = tex(TextureKind::Cylindrical, [MAX_TEXTURE_SIDE + 1, 1], vec![])
            .check(dir)
            .unwrap_err();
        assert!(e.contains("texture.size"), "{e}");
        let e = serde_json::from_str::<Texture>(r#"{"kind":"spherical","size":[1,1],"texels":[1]}"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("spherical"), "{e}");
        // The default origin is the prelude's first basis vector, ⟂ ω_t.
        for d in [[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [0.0, 0.0, -1.0], [0.48, -0.6, -0.64]] {
            let b = frisvad_b1(d);
            assert!(
                dot(b, d).abs() < 1e-12 && (dot(b, b) - 1.0).abs() < 1e-12,
                "{d:?} {b:?}"
            );
        }
    }
}
