//! The committed anisotropic LTC table (seed 004, `data/ltc_ggx_aniso.csv`) against fits
//! made here: a few entries are refitted (the suite never refits the table), the symmetry
//! post-processing of Eq. 16 is checked, and the shader-style look-up is checked to hand
//! every configuration that the table's symmetries fold onto a node the node's own lobe.

use linelight::input::ltc::aniso::{self, entry_point, index, lobe, Origin};
use linelight::input::ltc::fit::{self, Ltc};
use linelight::input::ltc::ggx::Ggx;
use linelight::input::ltc::table::Storage;
use linelight::input::ltc::{feed, Feed};
use std::f64::consts::{FRAC_PI_2, PI};

/// What the committed fit output holds: the 8⁴ table when it is complete, otherwise the
/// checkpoint of its unfinished run (`data/ltc_ggx_aniso.checkpoint.csv`, committed beside the
/// earlier 8×5×5×4 table that the feeds read until the run is finished and the table committed).
fn committed_fits() -> Vec<aniso::Fitted> {
    let t = aniso::ours();
    if t.size == aniso::SIZE {
        return aniso::chains(t.size)
            .into_iter()
            .flat_map(|[a, b, d]| (0..t.size[2]).map(move |c| [a, b, c, d]))
            .map(|i| (i, t.entries[index(t.size, i)].clone()))
            .collect();
    }
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/data/ltc_ggx_aniso.checkpoint.csv");
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| {
        panic!(
            "the table is {:?}, not 8⁴, and its run's checkpoint {path}: {e}",
            t.size
        )
    });
    let c = aniso::Checkpoint::parse(&text, path).unwrap();
    assert_eq!(c.size, aniso::SIZE);
    c.entries
}

#[test]
fn a_refitted_chain_matches_the_committed_fits() {
    let fits = committed_fits();
    // The committed chain with the most oblique view (the last such in the file), refitted
    // whole: warm-started from its roughest entry as the table's fit does.
    let &(last, _) = fits.iter().max_by_key(|(i, _)| (i[0], i[1], i[3])).unwrap();
    let chain = [last[0], last[1], last[3]];
    let refit = aniso::fit_chain(aniso::SIZE, chain);
    assert_eq!(refit.len(), aniso::SIZE[2]);
    for (i, e) in refit {
        let committed = &fits
            .iter()
            .find(|(j, _)| *j == i)
            .expect("whole chains are committed")
            .1;
        assert_eq!(committed.origin, Origin::Fit, "{i:?}");
        // The same code on the same inputs: the same bits.
        assert_eq!(&e, committed, "{i:?}");
    }
}

/// The table's warm starts (the neighbour's optimum plus one cold guess, instead of three cold
/// guesses) are what make 8⁴ entries affordable; along one sharp, anisotropic, oblique chain
/// they must not lose fit quality: the chain's summed lobe error within 1% of the cold fits'
/// and no entry worse by 5% (measured: equal to 4 digits, the largest entry difference 4e-5
/// relative; printed with --nocapture).
#[test]
fn warm_started_chains_fit_as_well_as_cold_fits() {
    let size = aniso::SIZE;
    let chain = [6, 2, 0];
    let (mut warm_sum, mut cold_sum) = (0.0, 0.0);
    for (i, warm) in aniso::fit_chain(size, chain) {
        let cold = aniso::fit_entry(size, i);
        println!("{i:?}: warm L1 {:.4e}, cold L1 {:.4e}", warm.l1, cold.l1);
        assert!(warm.l1 <= 1.05 * cold.l1, "{i:?}: warm {} vs cold {}", warm.l1, cold.l1);
        warm_sum += warm.l1;
        cold_sum += cold.l1;
    }
    println!("chain {chain:?}: summed L1 warm {warm_sum:.4e}, cold {cold_sum:.4e}");
    assert!(warm_sum <= 1.01 * cold_sum, "warm {warm_sum} vs cold {cold_sum}");
}

#[test]
fn committed_table_is_complete_aligned_and_symmetric() {
    let t = aniso::ours();
    let [n0, n1, n2, n3] = t.size;
    for a in 0..n0 {
        for b in 0..n1 {
            for c in 0..n2 {
                for d in 0..n3 {
                    let i = [a, b, c, d];
                    let e = &t.entries[index(t.size, i)];
                    // det > 0: the flipped alignment (det < 0) never wins on this table
                    // (the run record's `flipped` is 0); if a refit made one win, this says so.
                    let ok = e.m.iter().flatten().all(|x| x.is_finite())
                        && linelight::input::geometry::det(&e.m) > 0.0
                        && e.magnitude > 0.0
                        && e.magnitude <= 1.0 + 1e-9
                        && e.l1.is_finite()
                        && e.l1 >= 0.0;
                    assert!(ok, "entry {i:?}: {e:?}");
                    let col = (e.m[0][2].powi(2) + e.m[1][2].powi(2) + e.m[2][2].powi(2)).sqrt();
                    assert!((col - 1.0).abs() < 1e-12, "{i:?}: third column of length {col}");
                    // Eq. 16: φ = 0 is symmetric under y → −y, φ = π/2 under x → −x.
                    if b == 0 || a == 0 {
                        assert_eq!([e.m[0][1], e.m[1][0], e.m[1][2], e.m[2][1]], [0.0; 4], "{i:?}");
                    }
                    if b == n1 - 1 || a == 0 {
                        assert_eq!([e.m[0][1], e.m[1][0], e.m[0][2], e.m[2][0]], [0.0; 4], "{i:?}");
                    }
                    // θ = 0: the same entry for every φ.
                    if a == 0 {
                        assert_eq!(e.m, t.entries[index(t.size, [0, 0, c, d])].m, "{i:?}");
                    }
                    // Aligned (Eq. 12): the diagonal is positive.
                    assert!(e.m[0][0] > 0.0 && e.m[1][1] > 0.0, "{i:?}: {:?}", e.m);
                }
            }
        }
    }
}

/// The lobe error of what the look-up gives for (α, view), against that configuration's GGX.
fn lookup_error(alpha: [f64; 2], view: [f64; 3]) -> (f64, f64) {
    let (minv, mag, _) = aniso::ours().sample(alpha, view, Storage::F32);
    let g = Ggx {
        ax: alpha[0],
        ay: alpha[1],
        view,
    };
    let (_, l1) = fit::errors(
        &g,
        &Ltc::new(linelight::input::geometry::inverse(&minv)),
        mag,
        fit::OBJECTIVE_GRID,
    );
    (l1, mag)
}

#[test]
fn look_up_at_a_node_gives_the_nodes_lobe_in_every_quadrant_and_axis_order() {
    let t = aniso::ours();
    for i in [[3, 2, 1, 0], [5, 1, 2, 1], [2, 3, 4, 2]] {
        let e = &t.entries[index(t.size, i)];
        let p = entry_point(t.size, i);
        let g = lobe(p);
        let (theta, phi) = (p[0], p[1]);
        let (st, ct) = theta.sin_cos();
        let view = |phi: f64| [st * phi.cos(), st * phi.sin(), ct];
        // The node itself, its mirror images (Eq. 13) and the swapped roughness (Eq. 14).
        let cases = [
            ([g.ax, g.ay], view(phi)),
            ([g.ax, g.ay], view(PI - phi)),
            ([g.ax, g.ay], view(-phi)),
            ([g.ax, g.ay], view(PI + phi)),
            ([g.ay, g.ax], view(FRAC_PI_2 - phi)),
            ([g.ay, g.ax], view(FRAC_PI_2 + phi)),
        ];
        for (alpha, v) in cases {
            let (l1, mag) = lookup_error(alpha, v);
            assert!(
                (l1 - e.l1).abs() <= 1e-4 * e.l1.max(1e-3),
                "{i:?} at α {alpha:?}, view {v:?}: look-up error {l1} vs the node's {}",
                e.l1
            );
            assert!(
                (mag - e.magnitude).abs() <= 1e-6,
                "{i:?}: magnitude {mag} vs {}",
                e.magnitude
            );
        }
    }
}

#[test]
fn the_feed_rotates_the_look_up_into_the_views_plane_and_f16_rounds_it() {
    let alpha = [0.3, 0.12];
    let phi: f64 = 2.2;
    let (st, ct) = 0.9f64.sin_cos();
    let view = [st * phi.cos(), st * phi.sin(), ct];
    let (minv, mag, _) = aniso::ours().sample(alpha, view, Storage::F32);
    let f = feed(alpha, view, Feed::Aniso).unwrap();
    let back = f.minv_unrotated();
    for r in 0..3 {
        for c in 0..3 {
            assert!(
                (back[r][c] - minv[r][c]).abs() <= 1e-12 * (1.0 + minv[r][c].abs()),
                "[{r}][{c}]"
            );
        }
    }
    assert_eq!(f.magnitude, mag);
    // The rotated frame has the view in the xz-plane.
    let v = f.rotate(view);
    assert!(v[1].abs() < 1e-15 && v[0] > 0.0);
    let h = feed(alpha, view, Feed::AnisoF16).unwrap();
    let d = (h.minv[0][0] - f.minv[0][0]).abs() / f.minv[0][0].abs();
    assert!(d > 0.0 && d < 1e-2, "binary16 texels: relative change {d}");
}

#[test]
fn an_ltc_ggx_family_draws_full_matrices_from_the_anisotropic_table() {
    use linelight::input::case::Case;
    use linelight::input::scene::Material;
    let case = |material: &str| Case::parse("t.toml", &crate::common::case::family("line.ltc2023_full", 6, material));
    let ok = "kind = \"ltc_ggx\"\nalpha = { dist = \"log_uniform\", min = 0.05, max = 1.0 }\n\
              view_angle = { dist = \"uniform\", min = 0.0, max = 80.0 }\n\
              view_azimuth = { dist = \"uniform\", min = 0.0, max = 360.0 }\n\
              anisotropy = { dist = \"log_uniform\", min = 0.25, max = 4.0 }";
    let c = case(&format!("{ok}\nltc = \"aniso\"")).unwrap();
    let samples = linelight::input::sampler::sample_case(&c);
    assert_eq!(samples.len(), 6);
    for s in &samples {
        let Material::Ltc { minv } = &s.config.material else {
            panic!("an ltc_ggx family makes ltc materials: {:?}", s.config.material);
        };
        // An anisotropic lobe seen off its axes fills M⁻¹.
        assert!(!s.config.material.is_sparse(), "{minv:?}");
        assert!(minv.iter().flatten().all(|x| x.is_finite()));
    }
    assert!(case(&format!("{ok}\nltc = \"aniso_f16\"")).is_ok());
    let err = case(&format!("{ok}\nltc = \"table\"")).unwrap_err().to_string();
    assert!(err.contains("aniso"), "{err}");
}
