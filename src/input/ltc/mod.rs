//! LTCs for the `ggx` material: the fitter (f64, Nelder–Mead), the look-up tables (ours and
//! the published one) and the feed, which turns a `ggx` configuration into what an LTC
//! method is given: the configuration rotated about z so the view lies in the xz-plane, M⁻¹
//! and the magnitude, as a shader samples them (docs/ggx.md).

pub mod aniso;
pub mod device;
pub mod fit;
pub mod ggx;
pub mod sw;
pub mod table;

/// A 3×3 matrix (`scene::Mat3` is this type: the scene builds on this module, not the reverse).
pub type Mat3 = [[f64; 3]; 3];
use crate::input::geometry;
use std::collections::HashMap;
use std::sync::Mutex;
use table::Storage;

/// Where a `ggx` material's LTC comes from (the material's `ltc` field).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Feed {
    /// Our table, bilinear, f32 texels (the default for isotropic roughness).
    Table,
    /// Our table, bilinear, binary16 texels (RGBA16F).
    TableF16,
    /// The published table (Heitz et al. 2016), bilinear, f32 texels.
    Published,
    /// The published table, binary16 texels.
    PublishedF16,
    /// An exact fit to this configuration's lobe (the default for anisotropic roughness).
    Fit,
    /// Our anisotropic table (seed 004, `data/ltc_ggx_aniso.csv`), quadrilinear, f32 texels,
    /// M inverted in f32: any roughness.
    Aniso,
    /// The anisotropic table with binary16 texels (RGBA16F).
    AnisoF16,
}

impl Feed {
    pub const ALL: [Feed; 7] = [
        Feed::Table,
        Feed::TableF16,
        Feed::Published,
        Feed::PublishedF16,
        Feed::Fit,
        Feed::Aniso,
        Feed::AnisoF16,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Feed::Table => "table",
            Feed::TableF16 => "table_f16",
            Feed::Published => "published",
            Feed::PublishedF16 => "published_f16",
            Feed::Fit => "fit",
            Feed::Aniso => "aniso",
            Feed::AnisoF16 => "aniso_f16",
        }
    }

    pub fn parse(s: &str) -> Result<Feed, String> {
        Feed::ALL.into_iter().find(|f| f.name() == s).ok_or_else(|| {
            let names: Vec<_> = Feed::ALL.iter().map(|f| f.name()).collect();
            format!("unknown ltc feed `{s}` ({})", names.join(", "))
        })
    }
}

/// What an LTC method is given for a `ggx` configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fed {
    /// M⁻¹ in the rotated frame (view in the xz-plane, vx ≥ 0), row-major.
    pub minv: Mat3,
    pub magnitude: f64,
    /// The Schlick term ∫D(1 − v·h)⁵ (∫D·F = F0·magnitude + (1 − F0)·fresnel); NaN if unknown.
    pub fresnel: f64,
    /// (cos φ, sin φ) of the view's azimuth: the rotation R_z(−φ) takes the configuration
    /// into the frame of `minv`.
    pub rotation: [f64; 2],
    /// For `Fit`: the fit's relative L1 lobe error.
    pub fit_l1: Option<f64>,
}

impl Fed {
    /// R_z(−φ)·p.
    pub fn rotate(&self, p: [f64; 3]) -> [f64; 3] {
        let [c, s] = self.rotation;
        [c * p[0] + s * p[1], -s * p[0] + c * p[1], p[2]]
    }

    /// M⁻¹ in the configuration's own frame: M⁻¹·R_z(−φ).
    pub fn minv_unrotated(&self) -> Mat3 {
        let [c, s] = self.rotation;
        let r = [[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]];
        geometry::mat_mul(&self.minv, &r)
    }
}

type Key = ([u64; 2], [u64; 3], Feed);

/// At most this many exact fits are cached. A sweep's configurations are continuous, so a
/// cache of every (α, view) it meets grows with the count (it was most of a 3M sweep's
/// memory): only the expensive per-configuration fits are kept, and the cache is emptied
/// when full. A fit is deterministic, so a miss recomputes the same value.
const CACHE_LIMIT: usize = 1 << 14;

fn cache() -> &'static Mutex<HashMap<Key, Fed>> {
    static C: std::sync::OnceLock<Mutex<HashMap<Key, Fed>>> = std::sync::OnceLock::new();
    C.get_or_init(|| Mutex::new(HashMap::new()))
}

/// Caches a fit, emptying the cache first when it holds `CACHE_LIMIT` of them.
fn remember(cache: &mut HashMap<Key, Fed>, key: Key, fed: Fed) {
    if cache.len() >= CACHE_LIMIT {
        cache.clear();
    }
    cache.insert(key, fed);
}

/// The LTC fed for roughness (αx, αy) and a unit view with vz > 0. The 2D tables are
/// isotropic: an anisotropic roughness needs `Fit`, `Aniso` or `AnisoF16`. Exact fits are
/// cached per (α, view), at most [`CACHE_LIMIT`] of them; table look-ups are not cached.
pub fn feed(alpha: [f64; 2], view: [f64; 3], feed: Feed) -> Result<Fed, String> {
    let key = (alpha.map(f64::to_bits), view.map(f64::to_bits), feed);
    if feed == Feed::Fit {
        if let Some(f) = cache().lock().expect("cache").get(&key) {
            return Ok(*f);
        }
    }
    let phi = view[1].atan2(view[0]);
    let (s, c) = if view[0] == 0.0 && view[1] == 0.0 {
        (0.0, 1.0)
    } else {
        phi.sin_cos()
    };
    let rotation = [c, s];
    let iso = alpha[0] == alpha[1];
    let fed = match feed {
        Feed::Aniso | Feed::AnisoF16 => {
            let storage = if feed == Feed::AnisoF16 {
                Storage::F16
            } else {
                Storage::F32
            };
            feed_aniso(aniso::ours(), alpha, view, storage)
        }
        Feed::Table | Feed::TableF16 | Feed::Published | Feed::PublishedF16 => {
            if !iso {
                return Err(format!(
                    "ltc `{}` is an isotropic table; anisotropic alpha [{}, {}] needs ltc = \"fit\", \"aniso\" or \"aniso_f16\"",
                    feed.name(),
                    alpha[0],
                    alpha[1]
                ));
            }
            let table = match feed {
                Feed::Table | Feed::TableF16 => table::ours(),
                _ => table::published()?,
            };
            let storage = if matches!(feed, Feed::TableF16 | Feed::PublishedF16) {
                Storage::F16
            } else {
                Storage::F32
            };
            let (minv, magnitude, fresnel) = table.sample(alpha[0], view[2], storage);
            Fed {
                minv,
                magnitude,
                fresnel,
                rotation,
                fit_l1: None,
            }
        }
        Feed::Fit => {
            let vxy = view[0].hypot(view[1]);
            let f = if iso {
                let g = ggx::Ggx {
                    ax: alpha[0],
                    ay: alpha[0],
                    view: [vxy, 0.0, view[2]],
                };
                fit::fit_iso(&g, Some(nearest_params(alpha[0], view[2])))
            } else {
                // Fitted in the configuration's frame (the roughness axes are x and y),
                // then expressed in the rotated one.
                let g = ggx::Ggx {
                    ax: alpha[0],
                    ay: alpha[1],
                    view,
                };
                let mut f = fit::fit_general(&g);
                let r_inv = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]];
                f.minv = geometry::mat_mul(&f.minv, &r_inv);
                f
            };
            Fed {
                minv: f.minv,
                magnitude: f.magnitude,
                fresnel: f.fresnel,
                rotation,
                fit_l1: Some(f.l1),
            }
        }
    };
    if feed == Feed::Fit {
        remember(&mut cache().lock().expect("cache"), key, fed);
    }
    Ok(fed)
}

/// The feed of an anisotropic table `t` (ours for `Feed::Aniso`, or another resolution read
/// from a file by the resolution study): its look-up (`AnisoTable::sample`, in the roughness
/// frame) turned into the frame where the view lies in the xz-plane.
pub fn feed_aniso(t: &aniso::AnisoTable, alpha: [f64; 2], view: [f64; 3], storage: Storage) -> Fed {
    let (s, c) = if view[0] == 0.0 && view[1] == 0.0 {
        (0.0, 1.0)
    } else {
        view[1].atan2(view[0]).sin_cos()
    };
    let (minv, magnitude, fresnel) = t.sample(alpha, view, storage);
    // The look-up is in the roughness frame; the methods see the configuration turned by
    // R_z(−φ), so M⁻¹·R_z(φ).
    let r_inv = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]];
    Fed {
        minv: geometry::mat_mul(&minv, &r_inv),
        magnitude,
        fresnel,
        rotation: [c, s],
        fit_l1: None,
    }
}

/// The fitted parameters of our table's entry nearest (α, cos θ): the start of an exact fit.
fn nearest_params(alpha: f64, cos_theta: f64) -> [f64; 3] {
    let t = table::ours();
    let n = (t.size - 1) as f64;
    let a = (alpha.sqrt() * n).round().clamp(0.0, n) as usize;
    let x = (1.0 - cos_theta).max(0.0).sqrt();
    let i = (x * n).round().clamp(0.0, n) as usize;
    t.entries[a + t.size * i].params
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cache must not grow with a sweep's count: table look-ups are not cached, and the
    /// exact fits stay at most `CACHE_LIMIT`.
    #[test]
    fn the_feed_cache_is_bounded() {
        // (Other tests may cache fits meanwhile: look for these keys, not at the length.)
        let v = [0.3, 0.0, (1.0f64 - 0.09).sqrt()];
        for i in 0..1000 {
            let a = 0.05 + 0.9 * (i as f64 / 1000.0);
            feed([a, a], v, Feed::Table).expect("table");
            let key = ([a, a].map(f64::to_bits), v.map(f64::to_bits), Feed::Table);
            assert!(
                !cache().lock().expect("cache").contains_key(&key),
                "a table look-up was cached"
            );
        }
        // Filling past the limit empties it: the length never exceeds CACHE_LIMIT.
        let fed = feed([0.5, 0.5], [0.0, 0.0, 1.0], Feed::Table).expect("table");
        let mut c = HashMap::new();
        for i in 0..(2 * CACHE_LIMIT + 10) {
            remember(&mut c, ([i as u64, 0], [0, 0, 0], Feed::Fit), fed);
            assert!(c.len() <= CACHE_LIMIT);
        }
        assert_eq!(c.len(), 10);
    }
}
