//! Seed 004's objective: the sliced-Wasserstein fit (src/input/ltc/sw.rs), its
//! committed subsets (data/ltc_ggx_aniso_sw_subset.csv at 2 000 steps,
//! data/ltc_ggx_aniso_sw10000_subset.csv at the seed's 10 000) and the comparison command
//! (`linelight objectives`). The suite refits one entry of each, never a subset.

use linelight::input::geometry::det;
use linelight::input::ltc::{aniso, sw};
use std::process::Output;

/// The committed subsets and their SGD steps.
const SUBSETS: [(&str, usize); 2] = [
    ("data/ltc_ggx_aniso_sw_subset.csv", 2000),
    ("data/ltc_ggx_aniso_sw10000_subset.csv", 10000),
];

fn subset_at(file: &str) -> Vec<aniso::Fitted> {
    let path = format!("{}/{file}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).expect("the committed subset");
    aniso::parse_entries(&text, &path).expect("it parses")
}

/// Runs `linelight` from the checkout (the cases' and data's relative paths).
fn linelight(args: &[&str]) -> Output {
    crate::common::linelight_in(std::path::Path::new(env!("CARGO_MANIFEST_DIR")), args)
}

/// The committed subset is the documented one and passes the L1 table's checks: finite, a
/// positive determinant (no flip), third column of unit length, the Eq. 16 zeros, aligned
/// (positive diagonal), and the same magnitude as the L1 table's entry (the same quadrature
/// of the same lobe).
#[test]
fn the_committed_subsets_are_the_documented_ones_and_well_formed() {
    for (file, _) in SUBSETS {
        subset_is_well_formed(&subset_at(file));
    }
}

fn subset_is_well_formed(entries: &[aniso::Fitted]) {
    let size = aniso::SIZE;
    let indices: Vec<[usize; 4]> = entries.iter().map(|(i, _)| *i).collect();
    assert_eq!(
        indices,
        sw::subset(size),
        "the subset is sw::SUBSET_SLICES, in table order"
    );
    assert_eq!(indices.len(), 192);
    let table = aniso::ours();
    for (i, e) in entries {
        let [a, b, _, _] = *i;
        assert!(
            e.m.iter().flatten().all(|x| x.is_finite()) && det(&e.m) > 0.0,
            "{i:?}: {e:?}"
        );
        let col = (e.m[0][2].powi(2) + e.m[1][2].powi(2) + e.m[2][2].powi(2)).sqrt();
        assert!((col - 1.0).abs() < 1e-12, "{i:?}: third column of length {col}");
        if b == 0 || a == 0 {
            assert_eq!([e.m[0][1], e.m[1][0], e.m[1][2], e.m[2][1]], [0.0; 4], "{i:?}");
        }
        if b == size[1] - 1 || a == 0 {
            assert_eq!([e.m[0][1], e.m[1][0], e.m[0][2], e.m[2][0]], [0.0; 4], "{i:?}");
        }
        assert!(e.m[0][0] > 0.0 && e.m[1][1] > 0.0, "{i:?}: not aligned {:?}", e.m);
        let l1 = &table.entries[aniso::index(size, *i)];
        assert_eq!(e.magnitude, l1.magnitude, "{i:?}");
        assert_eq!(e.fresnel, l1.fresnel, "{i:?}");
        assert!(e.l1.is_finite() && e.l1 >= 0.0, "{i:?}");
    }
}

/// A fit is a pure function of its entry: one entry refitted (its own seed, the committed
/// hyperparameters) gives the committed bytes.
#[test]
fn one_entry_refits_to_the_committed_bits() {
    for (file, steps) in SUBSETS {
        let entries = subset_at(file);
        let i = [3, 3, 7, 0];
        let committed = &entries.iter().find(|(j, _)| *j == i).expect("in the subset").1;
        let e = sw::fit_entry(aniso::SIZE, i, &sw::Params { steps, ..sw::PARAMS });
        assert_eq!(&e, committed, "{file}");
    }
}

/// The comparison's plumbing: the L1 table's entries compared with themselves give equal
/// errors on every line (no line favours either side), with highlight lines within the cap.
#[test]
fn the_same_matrices_compare_equal() {
    use linelight::measure::objectives::{measure, Region, HIGHLIGHT_CAP};
    let table = aniso::ours();
    let same: Vec<aniso::Fitted> = [[2, 0, 4, 7], [5, 3, 6, 0]]
        .into_iter()
        .map(|i| (i, table.entries[aniso::index(table.size, i)].clone()))
        .collect();
    let run = measure(table, &same, 3, &|| {}).expect("measured");
    assert_eq!(run.lines.len(), 2 * 2 * 3);
    let o = linelight::analyse::objectives::analyse(&run);
    for (_, groups) in &o.regions {
        let all = &groups[0];
        assert_eq!((all.sw_nearer, all.l1_nearer), (0, 0));
        assert_eq!(all.equal, all.n);
        assert_eq!(all.median[0], all.median[1]);
    }
    for l in &run.lines {
        if l.region == Region::Highlight {
            assert!(l.highlight < HIGHLIGHT_CAP, "{l:?}");
        }
        assert!(l.truth > 0.0 || l.region == Region::Natural, "{l:?}");
    }
    for lobe in &run.lobes {
        assert_eq!(lobe.l1_error[0], lobe.l1_error[1]);
        assert_eq!(lobe.sw_distance[0], lobe.sw_distance[1]);
    }
}

#[test]
fn bad_input_is_refused_with_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    let out = out.to_str().unwrap();
    for (args, says) in [
        (
            vec!["fit", "--objective", "sw", "--out", out],
            "--objective sw is for --aniso",
        ),
        (
            vec!["fit", "--aniso", "--objective", "sw", "--sw-steps", "0", "--out", out],
            "--sw-steps 0",
        ),
        (vec!["objectives", "--lines", "0", "--out", out], "--lines 0"),
        (
            vec!["objectives", "--subset", "no/such.csv", "--out", out],
            "no/such.csv",
        ),
    ] {
        let o = linelight(&args);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(says), "{args:?}: {stderr}");
    }
    assert!(!std::path::Path::new(out).exists());
}
