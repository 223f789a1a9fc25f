//! Isotropic GGX LTC look-up tables: ours (`data/ltc_ggx_iso.csv`, written by `linelight
//! fit`, format in docs/ggx.md) and the published one (Heitz et al. 2016, shipped under
//! `data/ltc_code/` with its licence), sampled as a shader samples a texture.
//!
//! Both use the published parameterisation: entry (a, t) of an N×N table has roughness
//! r = a/(N−1), α = max(r², MIN_ALPHA), and x = t/(N−1) with cos θ = 1 − x² (θ ≤ 1.57).
//! A shader looks up (u, v) = (sqrt α, sqrt(1 − cos θ)) with the half-texel scale and bias
//! of seed 003 and hardware bilinear filtering with clamp-to-edge. The texture holds M⁻¹
//! in the sparse form of docs/conventions.md [[a,0,b],[0,c,0],[d,0,1]] (the form the 2023 listing builds),
//! as (a, b, c, d) in one RGBA texture, and (magnitude, Fresnel) in a second.

use crate::input::geometry::Rows as M3;

/// The α of the roughness-0 column (the published table uses 1e-5).
pub const MIN_ALPHA: f64 = 1e-4;
/// The largest view angle fitted (the published code's 1.57).
pub const MAX_THETA: f64 = 1.57;

/// Texel precision of a look-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Storage {
    F32,
    /// RGBA16F / RG16F textures: every value rounded to binary16 before filtering.
    F16,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    /// M⁻¹, row-major, sparse `[[a,0,b],[0,c,0],[d,0,e]]`.
    pub minv: M3,
    pub magnitude: f64,
    pub fresnel: f64,
    /// Fit errors (ours only; NaN for the published table): relative L1 and the L3 objective.
    pub l1: f64,
    pub l3: f64,
    /// (m11, m22, m13) of the fit, to warm-start a refit.
    pub params: [f64; 3],
}

#[derive(Clone, Debug)]
pub struct Table {
    pub size: usize,
    /// Entry (a, t) at `a + size·t`.
    pub entries: Vec<Entry>,
    pub source: String,
}

/// α and cos θ of entry (a, t).
pub fn entry_point(size: usize, a: usize, t: usize) -> (f64, f64) {
    let r = a as f64 / (size - 1) as f64;
    let x = t as f64 / (size - 1) as f64;
    let ct = (1.0 - x * x).max(MAX_THETA.cos());
    ((r * r).max(MIN_ALPHA), ct)
}

fn f16_round(x: f64) -> f32 {
    half::f16::from_f64(x).to_f32()
}

impl Table {
    /// Entry (a, t) as a shader's two textures hold it: (a, b, c, d) of the sparse M⁻¹ with
    /// its last entry divided out, magnitude, Fresnel term, rounded to `storage` (the device
    /// tables, `device.rs`).
    pub(crate) fn texel(&self, a: usize, t: usize, storage: Storage) -> [f32; 6] {
        let e = &self.entries[a + self.size * t];
        let s = e.minv[2][2];
        let v = [
            e.minv[0][0] / s,
            e.minv[0][2] / s,
            e.minv[1][1] / s,
            e.minv[2][0] / s,
            e.magnitude,
            e.fresnel,
        ];
        v.map(|x| match storage {
            Storage::F32 => x as f32,
            Storage::F16 => f16_round(x),
        })
    }

    /// Bilinear look-up at (α, cos θ) as a shader does it, arithmetic in f32: M⁻¹ (in the
    /// sparse form with its last entry 1), magnitude, Fresnel term.
    pub fn sample(&self, alpha: f64, cos_theta: f64, storage: Storage) -> (M3, f64, f64) {
        let n = self.size as f32;
        let uv = [(alpha as f32).sqrt(), (1.0 - cos_theta as f32).max(0.0).sqrt()];
        // LUT_SCALE/LUT_BIAS of seed 003, then the texture unit's texel position uv·N − ½.
        let (scale, bias) = ((n - 1.0) / n, 0.5 / n);
        let pos = uv.map(|x| ((x * scale + bias) * n - 0.5).clamp(0.0, n - 1.0));
        let i = pos.map(|p| (p.floor() as usize).min(self.size - 1));
        let f = [pos[0] - i[0] as f32, pos[1] - i[1] as f32];
        let j = i.map(|k| (k + 1).min(self.size - 1));
        let (t00, t10, t01, t11) = (
            self.texel(i[0], i[1], storage),
            self.texel(j[0], i[1], storage),
            self.texel(i[0], j[1], storage),
            self.texel(j[0], j[1], storage),
        );
        let lerp = |a: f32, b: f32, t: f32| a + t * (b - a);
        let v: Vec<f64> = (0..6)
            .map(|k| lerp(lerp(t00[k], t10[k], f[0]), lerp(t01[k], t11[k], f[0]), f[1]) as f64)
            .collect();
        ([[v[0], 0.0, v[1]], [0.0, v[2], 0.0], [v[3], 0.0, 1.0]], v[4], v[5])
    }

    /// Our table: CSV, one entry per line after a header (docs/ggx.md).
    pub fn parse_ours(text: &str, source: &str) -> Result<Table, String> {
        let mut entries = Vec::new();
        let mut size = 0;
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') || line.starts_with("a,") {
                continue;
            }
            let f: Vec<&str> = line.split(',').collect();
            let num = |k: usize| -> Result<f64, String> {
                f.get(k)
                    .ok_or_else(|| format!("{source}:{}: {} fields, expected 15", i + 1, f.len()))?
                    .parse::<f64>()
                    .map_err(|e| format!("{source}:{}: field {}: {e}", i + 1, k + 1))
            };
            if f.len() != 15 {
                return Err(format!("{source}:{}: {} fields, expected 15", i + 1, f.len()));
            }
            let a = num(0)? as usize;
            entries.push(Entry {
                minv: [[num(4)?, 0.0, num(5)?], [0.0, num(6)?, 0.0], [num(7)?, 0.0, 1.0]],
                magnitude: num(8)?,
                fresnel: num(9)?,
                l1: num(10)?,
                l3: num(11)?,
                params: [num(12)?, num(13)?, num(14)?],
            });
            size = size.max(a + 1);
        }
        if size * size != entries.len() || size < 2 {
            return Err(format!("{source}: {} entries, not a square table", entries.len()));
        }
        Ok(Table {
            size,
            entries,
            source: source.into(),
        })
    }

    /// The CSV text of a table (inverse of `parse_ours`).
    pub fn to_csv(&self, header: &str) -> String {
        let mut s = String::new();
        for line in header.lines() {
            s.push_str(&format!("# {line}\n"));
        }
        s.push_str("a,t,alpha,cos_theta,m00,m02,m11,m20,magnitude,fresnel,fit_l1,fit_l3,p_m11,p_m22,p_m13\n");
        for t in 0..self.size {
            for a in 0..self.size {
                let e = &self.entries[a + self.size * t];
                let (alpha, ct) = entry_point(self.size, a, t);
                s.push_str(&format!(
                    "{a},{t},{alpha:e},{ct:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e}\n",
                    e.minv[0][0],
                    e.minv[0][2],
                    e.minv[1][1],
                    e.minv[2][0],
                    e.magnitude,
                    e.fresnel,
                    e.l1,
                    e.l3,
                    e.params[0],
                    e.params[1],
                    e.params[2]
                ));
            }
        }
        s
    }

    /// The published table from `ltc.inc` (tabMinv column-major 9-tuples, tabMagnitude).
    pub fn parse_published(text: &str, source: &str) -> Result<Table, String> {
        let section = |name: &str| -> Result<&str, String> {
            let start = text.find(name).ok_or_else(|| format!("{source}: no `{name}`"))?;
            let rest = &text[start..];
            let open = rest
                .find('{')
                .ok_or_else(|| format!("{source}: `{name}` has no body"))?;
            let close = rest
                .find("};")
                .ok_or_else(|| format!("{source}: `{name}` not closed"))?;
            Ok(&rest[open + 1..close])
        };
        let numbers = |body: &str| -> Result<Vec<f64>, String> {
            body.split(|c: char| c == ',' || c == '{' || c == '}' || c.is_whitespace())
                .filter(|s| !s.is_empty())
                .map(|s| {
                    s.trim_end_matches('f')
                        .parse::<f64>()
                        .map_err(|e| format!("{source}: `{s}`: {e}"))
                })
                .collect()
        };
        let minv = numbers(section("tabMinv[")?)?;
        let mag = numbers(section("tabMagnitude[")?)?;
        let size = 64;
        if minv.len() != 9 * size * size || mag.len() != size * size {
            return Err(format!(
                "{source}: expected 64×64 entries, got {} and {}",
                minv.len() / 9,
                mag.len()
            ));
        }
        let entries = (0..size * size)
            .map(|i| {
                let c = &minv[9 * i..9 * i + 9];
                // Column-major: c[3j + r] is row r of column j.
                let m = [[c[0], c[3], c[6]], [c[1], c[4], c[7]], [c[2], c[5], c[8]]];
                Entry {
                    minv: m,
                    magnitude: mag[i],
                    fresnel: f64::NAN,
                    l1: f64::NAN,
                    l3: f64::NAN,
                    params: [f64::NAN; 3],
                }
            })
            .collect();
        Ok(Table {
            size,
            entries,
            source: source.into(),
        })
    }
}

/// Our committed table, compiled in.
pub fn ours() -> &'static Table {
    static T: std::sync::OnceLock<Table> = std::sync::OnceLock::new();
    T.get_or_init(|| {
        Table::parse_ours(include_str!("../../../data/ltc_ggx_iso.csv"), "data/ltc_ggx_iso.csv")
            .expect("the committed table parses (tests check it)")
    })
}

/// The published table (`data/ltc_code/ltc.inc`, compiled in, so every clone and every
/// `cargo install` has it), or why it does not parse.
pub fn published() -> Result<&'static Table, String> {
    static T: std::sync::OnceLock<Result<Table, String>> = std::sync::OnceLock::new();
    T.get_or_init(|| Table::parse_published(include_str!("../../../data/ltc_code/ltc.inc"), "data/ltc_code/ltc.inc"))
        .as_ref()
        .map_err(Clone::clone)
}
