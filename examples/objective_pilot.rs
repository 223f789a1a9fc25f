//! The pilot behind the fit's objective (docs/ggx.md): at 6 points of the isotropic table,
//! fits with the L3 (paper), L1 and χ² objectives, and the published table's look-up, each
//! judged by the median relative error of its exact LTC line integral against the GGX truth on
//! 300 random line lights (seed 5, not a report's seed). Needs the anchors for the published
//! column. Run: `cargo run --release --example objective_pilot`.

use linelight::input::ltc::fit::{fit_iso_with, Objective};
use linelight::input::ltc::ggx::Ggx;
use linelight::input::ltc::table;
use linelight::input::scene::{Config, Material, Roughness};
use linelight::input::target::Target;
use linelight::reference::reference;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
fn main() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let mut all: Vec<Vec<f64>> = vec![vec![]; 4];
    for (a, t) in [(10usize, 20usize), (25, 40), (40, 30), (15, 55), (50, 50), (30, 10)] {
        let (alpha, ct) = table::entry_point(64, a, t);
        let view = [(1.0 - ct * ct).sqrt(), 0.0, ct];
        let g = Ggx {
            ax: alpha,
            ay: alpha,
            view,
        };
        let start = table::ours().entries[a + 64 * t].params;
        let fits: Vec<_> = [Objective::L3, Objective::L1, Objective::Chi2]
            .iter()
            .map(|&o| fit_iso_with(&g, Some(start), o))
            .collect();
        let lines: Vec<([f64; 3], [f64; 3])> = (0..300)
            .map(|_| loop {
                let el = rng.random_range(-30.0f64..90.0).to_radians();
                let az = rng.random_range(0.0..std::f64::consts::TAU);
                let p0 = [el.cos() * az.cos(), el.cos() * az.sin(), el.sin()];
                let tv = [
                    rng.random_range(-1.0..1.0f64),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                ];
                let len = 10f64.powf(rng.random_range(-1.0..1.0));
                let p1 = [0, 1, 2].map(|k| p0[k] - 0.5 * len * tv[k]);
                let p2 = [0, 1, 2].map(|k| p0[k] + 0.5 * len * tv[k]);
                if p1[2] > 0.05 || p2[2] > 0.05 {
                    return (p1, p2);
                }
            })
            .collect();
        let errs: Vec<Vec<f64>> = lines
            .par_iter()
            .filter_map(|&(p1, p2)| {
                let c = Config {
                    id: "x".into(),
                    p1,
                    p2,
                    radius: None,
                    rect: None,
                    material: Material::ggx(Roughness::Iso(alpha), view, Some("published")).unwrap(),
                    texture: None,
                };
                let truth = reference(&c, Target::Line).unwrap().value;
                if truth.is_nan() || truth <= 0.0 {
                    return None;
                }
                let mut out = vec![];
                for f in &fits {
                    let l = Config {
                        material: Material::Ltc { minv: f.minv },
                        ..c.clone()
                    };
                    out.push((reference(&l, Target::Line).unwrap().value * f.magnitude - truth).abs() / truth);
                }
                let (fed, mag) = c.fed();
                out.push((reference(&fed, Target::Line).unwrap().value * mag - truth).abs() / truth);
                Some(out)
            })
            .collect();
        let med = |k: usize| {
            let mut v: Vec<f64> = errs.iter().map(|e| e[k]).collect();
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        println!(
            "a{a} t{t} alpha {alpha:.3} ct {ct:.3}: n {} L3 {:.4} L1 {:.4} chi2 {:.4} published {:.4}",
            errs.len(),
            med(0),
            med(1),
            med(2),
            med(3)
        );
        for e in &errs {
            for (v, x) in all.iter_mut().zip(e) {
                v.push(*x);
            }
        }
    }
    for v in &mut all {
        v.sort_by(f64::total_cmp);
    }
    println!(
        "all: L3 {:.4} L1 {:.4} chi2 {:.4} published {:.4}",
        all[0][all[0].len() / 2],
        all[1][all[1].len() / 2],
        all[2][all[2].len() / 2],
        all[3][all[3].len() / 2]
    );
}
