//! The committed isotropic LTC table against fits made here: a few entries are refitted from
//! their committed chain predecessor (the suite never refits the whole table), and the table
//! is checked for what `linelight fit` promises (every entry, finite, honest errors).

use linelight::input::ltc::fit::{fit_iso, Ltc};
use linelight::input::ltc::ggx::Ggx;
use linelight::input::ltc::table::{self, entry_point, Storage};

fn lobe(size: usize, a: usize, t: usize) -> Ggx {
    let (alpha, ct) = entry_point(size, a, t);
    Ggx {
        ax: alpha,
        ay: alpha,
        view: [(1.0 - ct * ct).max(0.0).sqrt(), 0.0, ct],
    }
}

#[test]
fn refitted_entries_match_the_committed_table() {
    let t = table::ours();
    assert_eq!(t.size, 64);
    // Low, middle and high roughness; normal, oblique and grazing views.
    for (a, row) in [(5, 0), (20, 30), (40, 50), (62, 63), (10, 60)] {
        let committed = &t.entries[a + t.size * row];
        let start = t.entries[a + 1 + t.size * row].params;
        let f = fit_iso(&lobe(t.size, a, row), Some(start));
        let close = |x: f64, y: f64, tol: f64| (x - y).abs() <= tol * y.abs().max(1e-12);
        for (i, j) in [(0, 0), (0, 2), (1, 1), (2, 0)] {
            assert!(
                close(f.minv[i][j], committed.minv[i][j], 1e-6),
                "({a}, {row}) M⁻¹[{i}][{j}]: refit {} vs committed {}",
                f.minv[i][j],
                committed.minv[i][j]
            );
        }
        assert!(close(f.magnitude, committed.magnitude, 1e-9), "({a}, {row}) magnitude");
        assert!(close(f.fresnel, committed.fresnel, 1e-6), "({a}, {row}) fresnel");
        assert!(close(f.l1, committed.l1, 1e-6), "({a}, {row}) fit error");
    }
}

#[test]
fn committed_table_is_complete_and_sampled_like_a_texture() {
    let t = table::ours();
    for (i, e) in t.entries.iter().enumerate() {
        let ok = e.minv.iter().flatten().all(|x| x.is_finite())
            && e.magnitude > 0.0
            && e.magnitude <= 1.0 + 1e-9
            && e.l1.is_finite()
            && e.l1 >= 0.0;
        assert!(ok, "entry {i}: {e:?}");
    }
    // At a texel centre the bilinear look-up returns that texel (in f32).
    let (a, row) = (17, 41);
    let (alpha, ct) = entry_point(t.size, a, row);
    let (minv, mag, _) = t.sample(alpha, ct, Storage::F32);
    let e = &t.entries[a + t.size * row];
    let s = e.minv[2][2];
    assert_eq!(minv[2][2], 1.0);
    for (got, want) in [
        (minv[0][0], e.minv[0][0] / s),
        (minv[0][2], e.minv[0][2] / s),
        (minv[1][1], e.minv[1][1] / s),
        (minv[2][0], e.minv[2][0] / s),
    ] {
        assert!((got - want).abs() <= 1e-5 * want.abs(), "{got} vs {want}");
    }
    assert!((mag - e.magnitude).abs() <= 1e-6, "{mag} vs {}", e.magnitude);
    // binary16 texels keep about 3 digits.
    let (m16, _, _) = t.sample(alpha, ct, Storage::F16);
    assert!((m16[0][0] - minv[0][0]).abs() <= 1e-3 * minv[0][0].abs());
    assert!(m16[0][0] != minv[0][0]);
}

#[test]
fn the_fit_is_better_than_the_diffuse_start_and_its_error_is_honest() {
    // The fitted LTC must beat the cosine it starts from, by its own objective.
    let g = lobe(64, 30, 40);
    let f = fit_iso(&g, None);
    let diffuse = Ltc::new([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    let (l3_diffuse, l1_diffuse) = linelight::input::ltc::fit::errors(&g, &diffuse, f.magnitude, 32);
    assert!(
        f.l3 < 0.1 * l3_diffuse && f.l1 < l1_diffuse,
        "{f:?} vs {l3_diffuse} {l1_diffuse}"
    );
    // The reported L1 error agrees with a finer estimate of the same integral.
    let ltc = Ltc::new(linelight::input::geometry::inverse(&f.minv));
    let (_, fine) = linelight::input::ltc::fit::errors(&g, &ltc, f.magnitude, 128);
    assert!((fine - f.l1).abs() <= 0.1 * fine, "{fine} vs {}", f.l1);
}
