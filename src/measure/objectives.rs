//! The objective comparison (seed 004's SW fit against our L1 table), measured
//! (`linelight objectives`): for each entry of the SW-fitted subset
//! (`data/ltc_ggx_aniso_sw_subset.csv`, `input::ltc::sw`) and the same entry of the L1 table
//! (`data/ltc_ggx_aniso.csv`), the line-light values users see and the lobe errors.
//!
//! Lines are drawn per entry from its own seeded stream, at the entry's own node (its lobe
//! exactly: no table look-up, no interpolation), in the roughness frame (αx = α_max,
//! αy = r·α_max, view at (θ, φ)), the shading point at the origin, the line's distance 1:
//! - `highlight`: the direction to the segment's nearest point within 5° of the view's mirror
//!   direction (uniform on that cap), the segment through it at a random tilt, length
//!   log-uniform in [0.1, 10], the foot inside the segment (so it is the nearest point);
//! - `natural`: cases/ggx.toml's geometry (elevation uniform in [−30°, 90°], azimuth, tilt
//!   uniform, length log-uniform in [0.1, 10], centre offset signed log-uniform in [0.01, 10]).
//!
//! Per line: the GGX truth T (`reference`, target `line`), and for each matrix M the exact LTC
//! line integral of M⁻¹ (the f64 reference of the `ltc` material) times the entry's magnitude,
//! which both fits share. Per entry: the relative L1 lobe error of each M on a 128² MIS grid
//! (finer than the 32² the L1 fit minimised) and the SW distance of each M on 4096 samples ×
//! 256 directions, the same samples and directions for both (common random numbers).

use crate::input::geometry::{inverse, DVec3};
use crate::input::ltc::aniso::{self, Entry, Fitted};
use crate::input::ltc::{fit, sw};
use crate::input::sampler::highlight_angle;
use crate::input::scene::{Config, Material, Roughness};
use crate::input::target::Target;
use crate::reference::reference;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// Where a line is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Region {
    Highlight,
    Natural,
}

impl Region {
    pub const ALL: [Region; 2] = [Region::Highlight, Region::Natural];
    pub fn name(self) -> &'static str {
        match self {
            Region::Highlight => "highlight",
            Region::Natural => "natural",
        }
    }
}

/// The half-angle (degrees) of the highlight's cap around the mirror direction.
pub const HIGHLIGHT_CAP: f64 = 5.0;
/// Grid of the L1 lobe error (per axis, two grids of n² samples).
pub const LOBE_GRID: usize = 128;
/// Samples and directions of the SW distance.
pub const SW_SAMPLES: usize = 4096;
pub const SW_DIRECTIONS: usize = 256;

/// One line at one entry.
#[derive(Clone, Debug)]
pub struct Line {
    pub entry: [usize; 4],
    pub region: Region,
    /// The angle (degrees) from the mirror direction to the segment's nearest point.
    pub highlight: f64,
    pub p1: [f64; 3],
    pub p2: [f64; 3],
    /// GGX truth and its error estimate.
    pub truth: f64,
    pub truth_error: f64,
    /// magnitude × the exact LTC line integral, for the L1-fitted and the SW-fitted M.
    pub l1: f64,
    pub sw: f64,
}

/// One entry's lobe errors.
#[derive(Clone, Debug)]
pub struct Lobe {
    pub entry: [usize; 4],
    /// (θ, φ, α_max, r).
    pub point: [f64; 4],
    /// Relative L1 lobe error of [L1-fitted, SW-fitted] M.
    pub l1_error: [f64; 2],
    /// SW distance of [L1-fitted, SW-fitted] M.
    pub sw_distance: [f64; 2],
}

pub struct Run {
    pub size: [usize; 4],
    pub lines_per_region: usize,
    pub lines: Vec<Line>,
    pub lobes: Vec<Lobe>,
    pub seconds: f64,
}

fn log_uniform(min: f64, max: f64, u: f64) -> f64 {
    (min.ln() + (max.ln() - min.ln()) * u).exp()
}

/// A segment through the point `w_po` (unit, distance 1) along a random direction ⟂ w_po.
fn segment(w_po: DVec3, tilt: f64, length: f64, center: f64) -> ([f64; 3], [f64; 3]) {
    let h = if w_po.x.abs() < 0.9 {
        DVec3::X.cross(w_po).normalize()
    } else {
        DVec3::Y.cross(w_po).normalize()
    };
    let v = w_po.cross(h);
    let w_t = h * tilt.cos() + v * tilt.sin();
    let half = 0.5 * length;
    let p1 = w_po + w_t * (center - half);
    let p2 = w_po + w_t * (center + half);
    (p1.to_array(), p2.to_array())
}

/// The lines of one entry: `n` per region, from the entry's own stream.
pub fn draw_lines(view: [f64; 3], n: usize, seed: u64) -> Vec<(Region, [f64; 3], [f64; 3])> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::with_capacity(2 * n);
    let mirror = DVec3::new(-view[0], -view[1], view[2]);
    for _ in 0..n {
        // Uniform on the cap of half-angle HIGHLIGHT_CAP around the mirror direction.
        let cmin = HIGHLIGHT_CAP.to_radians().cos();
        let c = 1.0 - rng.random::<f64>() * (1.0 - cmin);
        let s = (1.0 - c * c).max(0.0).sqrt();
        let a = std::f64::consts::TAU * rng.random::<f64>();
        let u = if mirror.x.abs() < 0.9 {
            DVec3::X.cross(mirror).normalize()
        } else {
            DVec3::Y.cross(mirror).normalize()
        };
        let w = mirror.cross(u);
        let w_po = (mirror * c + u * (s * a.cos()) + w * (s * a.sin())).normalize();
        let tilt = std::f64::consts::PI * rng.random::<f64>();
        let length = log_uniform(0.1, 10.0, rng.random());
        // The foot strictly inside the segment: it is the nearest point.
        let center = 0.9 * length * (rng.random::<f64>() - 0.5);
        let (p1, p2) = segment(w_po, tilt, length, center);
        out.push((Region::Highlight, p1, p2));
    }
    for _ in 0..n {
        let elevation = (-30.0 + 120.0 * rng.random::<f64>()).to_radians();
        let azimuth = std::f64::consts::TAU * rng.random::<f64>();
        let tilt = std::f64::consts::PI * rng.random::<f64>();
        let length = log_uniform(0.1, 10.0, rng.random());
        let sign = if rng.random::<f64>() < 0.5 { -1.0 } else { 1.0 };
        let center = sign * log_uniform(0.01, 10.0, rng.random());
        // cases/ggx.toml's frame: h horizontal ⟂ w_po, v = w_po × h.
        let (ce, se) = (elevation.cos(), elevation.sin());
        let (ca, sa) = (azimuth.cos(), azimuth.sin());
        let w_po = DVec3::new(ce * ca, ce * sa, se);
        let h = DVec3::new(-sa, ca, 0.0);
        let v = w_po.cross(h);
        let w_t = h * tilt.cos() + v * tilt.sin();
        let half = 0.5 * length;
        let p1 = (w_po + w_t * (center - half)).to_array();
        let p2 = (w_po + w_t * (center + half)).to_array();
        out.push((Region::Natural, p1, p2));
    }
    out
}

/// magnitude × the exact `line` integral of the LTC of M.
fn ltc_line(m: &fit::M3, magnitude: f64, p1: [f64; 3], p2: [f64; 3]) -> f64 {
    let c = Config {
        id: String::new(),
        p1,
        p2,
        radius: None,
        rect: None,
        material: Material::Ltc { minv: inverse(m) },
        texture: None,
    };
    reference(&c, Target::Line).map_or(f64::NAN, |e| e.value * magnitude)
}

/// Measures every entry of `sw_entries` against the same entry of `table` (the L1 table).
pub fn measure(
    table: &aniso::AnisoTable,
    sw_entries: &[Fitted],
    lines_per_region: usize,
    progress: &(dyn Fn() + Sync),
) -> anyhow::Result<Run> {
    let start = std::time::Instant::now();
    let size = table.size;
    let per_entry: Vec<anyhow::Result<(Lobe, Vec<Line>)>> = sw_entries
        .par_iter()
        .map(|(i, sw_e)| {
            let i = *i;
            if (0..4).any(|k| i[k] >= size[k]) {
                anyhow::bail!("SW entry {i:?} is outside the {size:?} table");
            }
            let l1_e: &Entry = &table.entries[aniso::index(size, i)];
            let point = aniso::entry_point(size, i);
            let g = aniso::lobe(point);
            let ms = [l1_e.m, sw_e.m];
            let magnitude = l1_e.magnitude;
            let l1_error = ms.map(|m| fit::errors(&g, &fit::Ltc::new(m), magnitude, LOBE_GRID).1);
            let seed = sw::entry_seed(i) ^ 0x6c69_6e65;
            let sw_distance = ms.map(|m| sw::distance(&g, &m, SW_SAMPLES, SW_DIRECTIONS, seed));
            let alpha = if g.ax == g.ay {
                Roughness::Iso(g.ax)
            } else {
                Roughness::Aniso([g.ax, g.ay])
            };
            let material = Material::ggx(alpha, g.view, Some("aniso")).map_err(anyhow::Error::msg)?;
            let lines = draw_lines(g.view, lines_per_region, seed ^ 0x5eed)
                .into_iter()
                .map(|(region, p1, p2)| {
                    let c = Config {
                        id: String::new(),
                        p1,
                        p2,
                        radius: None,
                        rect: None,
                        material: material.clone(),
                        texture: None,
                    };
                    let t = reference(&c, Target::Line);
                    Line {
                        entry: i,
                        region,
                        highlight: highlight_angle(g.view, p1, p2),
                        p1,
                        p2,
                        truth: t.as_ref().map_or(f64::NAN, |e| e.value),
                        truth_error: t.as_ref().map_or(f64::NAN, |e| e.error),
                        l1: ltc_line(&ms[0], magnitude, p1, p2),
                        sw: ltc_line(&ms[1], sw_e.magnitude, p1, p2),
                    }
                })
                .collect();
            progress();
            Ok((
                Lobe {
                    entry: i,
                    point,
                    l1_error,
                    sw_distance,
                },
                lines,
            ))
        })
        .collect();
    let mut lobes = Vec::new();
    let mut lines = Vec::new();
    for r in per_entry {
        let (lobe, l) = r?;
        lobes.push(lobe);
        lines.extend(l);
    }
    Ok(Run {
        size,
        lines_per_region,
        lines,
        lobes,
        seconds: start.elapsed().as_secs_f64(),
    })
}
