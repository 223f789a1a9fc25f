//! The anisotropic table's resolution study: the 4⁴ table and the fine slice (`data/ltc_ggx_aniso_4.csv`,
//! `data/ltc_ggx_aniso_slice.csv`, written by `linelight fit --aniso [--aniso-slice φ,r]`),
//! a table read from a file checked as an input, and the slice option refused when wrong.

use linelight::input::ltc::aniso::{self, entry_point, entry_point_in, index, AnisoTable};
use linelight::input::ltc::table::Storage;
use linelight::input::ltc::{feed, feed_aniso, Feed};
use std::path::Path;
use std::process::Command;

fn data(name: &str) -> AnisoTable {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(name);
    AnisoTable::load(&path, "test table").unwrap_or_else(|e| panic!("{name}: {e:#}"))
}

/// The slice's (φ, r): the 8⁴ node (index 3 of φ, index 2 of r).
fn slice_point() -> [f64; 2] {
    let p = entry_point(aniso::SIZE, [0, 3, 0, 2]);
    [p[1], p[3]]
}

#[test]
fn the_committed_4_table_is_complete_and_invertible() {
    let t = data("ltc_ggx_aniso_4.csv");
    assert_eq!(t.size, [4, 4, 4, 4]);
    assert_eq!(t.slice, None);
    for e in &t.entries {
        assert!(linelight::input::geometry::det(&e.m) > 0.0);
        assert!(e.magnitude > 0.0 && e.l1.is_finite());
    }
}

#[test]
fn the_committed_slice_sits_on_an_8_node_and_its_lookup_at_a_node_is_the_node() {
    let t = data("ltc_ggx_aniso_slice.csv");
    assert_eq!(t.size, [32, 1, 32, 1]);
    let [phi, r] = t.slice.expect("a slice");
    let [p8, r8] = slice_point();
    assert!(
        (phi - p8).abs() < 1e-15 && (r - r8).abs() < 1e-15,
        "({phi}, {r}) is not the 8⁴ node ({p8}, {r8})"
    );
    // At a node of the slice (θ and α_max on its grid), the look-up is that node's M (f32).
    let (it, ia) = (17, 9);
    let [theta, _, a, _] = entry_point_in(t.size, t.slice, [it, 0, ia, 0]);
    let view = [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()];
    let (minv, magnitude, _) = t.sample([a, a * r], view, Storage::F32);
    let e = &t.entries[index(t.size, [it, 0, ia, 0])];
    let m = linelight::input::geometry::inverse(&minv);
    for (row, want) in m.iter().zip(&e.m) {
        for (x, y) in row.iter().zip(want) {
            assert!(
                (x - y).abs() < 1e-5 * (1.0 + y.abs()),
                "look-up {m:?} against the node {:?}",
                e.m
            );
        }
    }
    assert!((magnitude - e.magnitude).abs() < 1e-6 * e.magnitude);
    // The feed of a file's table is the feed `ltc = "aniso"` gives when the table is ours.
    let ours = feed([0.3, 0.12], [0.5, 0.2, (1.0f64 - 0.29).sqrt()], Feed::Aniso).unwrap();
    let same = feed_aniso(
        aniso::ours(),
        [0.3, 0.12],
        [0.5, 0.2, (1.0f64 - 0.29).sqrt()],
        Storage::F32,
    );
    assert_eq!(ours, same);
}

/// A 2×2×2×2 table's text (the 4⁴ table's corners, with their own grid columns).
fn small_table() -> String {
    let t4 = data("ltc_ggx_aniso_4.csv");
    let size = [2, 2, 2, 2];
    let mut entries = Vec::new();
    for a in 0..2 {
        for b in 0..2 {
            for c in 0..2 {
                for d in 0..2 {
                    entries.push(t4.entries[index(t4.size, [3 * a, 3 * b, 3 * c, 3 * d])].clone());
                }
            }
        }
    }
    AnisoTable {
        size,
        entries,
        slice: None,
    }
    .to_csv("a test table")
}

#[test]
fn a_table_file_is_checked_as_an_input() {
    let good = small_table();
    let t = AnisoTable::parse(&good, "t").expect("a good table parses");
    assert_eq!(t.size, [2, 2, 2, 2]);
    let rows: Vec<&str> = good.lines().collect();
    let data_row = rows.iter().position(|l| l.starts_with("0,0,0,0,")).unwrap();
    let with = |row: String| {
        let mut r = rows.clone();
        r[data_row] = &row;
        AnisoTable::parse(&r.join("\n"), "t").unwrap_err()
    };
    let fields: Vec<&str> = rows[data_row].split(',').collect();
    let set = |k: usize, v: &str| {
        let mut f = fields.clone();
        f[k] = v;
        f.join(",")
    };
    // A grid column that is not the grid's.
    assert!(
        with(set(6, "0.5")).contains("not its grid point"),
        "{}",
        with(set(6, "0.5"))
    );
    // A number that is not finite, a singular M, a magnitude of 0.
    assert!(with(set(8, "NaN")).contains("not finite"));
    let singular = {
        let mut f = fields.clone();
        for x in &mut f[8..17] {
            *x = "0";
        }
        f.join(",")
    };
    assert!(with(singular).contains("singular"));
    assert!(with(set(17, "0")).contains("magnitude"));
    // An entry missing.
    let mut r = rows.clone();
    r.remove(data_row);
    assert!(AnisoTable::parse(&r.join("\n"), "t")
        .unwrap_err()
        .contains("not a full"));
    // One entry on φ alone is neither a table nor a slice.
    let one_phi: String = good
        .lines()
        .filter(|l| !l.chars().next().is_some_and(|c| c.is_ascii_digit()) || l.split(',').nth(1) == Some("0"))
        .collect::<Vec<_>>()
        .join("\n");
    assert!(AnisoTable::parse(&one_phi, "t").unwrap_err().contains("neither"));
}

fn linelight(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn a_wrong_slice_is_refused_before_any_work() {
    let dir = std::env::temp_dir().join(format!("linelight-slice-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("slice.csv");
    let out = out.to_str().unwrap();
    for (size, slice, says) in [
        ("4,1,4,1", "2,0.5", "φ = 2"),
        ("4,1,4,1", "0.5,0.1", "r = 0.1"),
        ("4,1,4,1", "NaN,0.5", "φ = NaN"),
        ("4,2,4,1", "0.5,0.5", "one entry on φ and on r"),
        ("1,1,4,1", "0.5,0.5", "at least 2 entries on θ"),
        ("4,1,4,1", "0.5", "2 numbers"),
    ] {
        let o = linelight(&[
            "fit",
            "--aniso",
            "--aniso-size",
            size,
            "--aniso-slice",
            slice,
            "--out",
            out,
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{size} {slice}: {err}");
        assert!(err.contains(says), "{size} {slice}: `{err}` does not say `{says}`");
        assert!(!Path::new(out).exists());
    }
    // A size of one on φ and r without a slice, and a slice without --aniso.
    let o = linelight(&["fit", "--aniso", "--aniso-size", "4,1,4,1", "--out", out]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--aniso-slice"));
    let o = linelight(&["fit", "--aniso-slice", "0.5,0.5", "--out", out]);
    assert_eq!(o.status.code(), Some(2));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_slice_fit_writes_a_slice_that_reads_back() {
    let dir = std::env::temp_dir().join(format!("linelight-slicefit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("slice.csv");
    let [phi, r] = slice_point();
    let slice = format!("{phi},{r}");
    let o = linelight(&[
        "fit",
        "--aniso",
        "--aniso-size",
        "2,1,2,1",
        "--aniso-slice",
        &slice,
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let t = AnisoTable::load(&out, "slice").unwrap();
    assert_eq!((t.size, t.slice), ([2, 1, 2, 1], Some([phi, r])));
    // Each entry is the fit of the slice's own lobe: refitted here, the same bits.
    let e = aniso::fit_entry_from_in(t.size, t.slice, [1, 0, 1, 0], None).0;
    assert_eq!(e, t.entries[index(t.size, [1, 0, 1, 0])]);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_study_refuses_a_bad_table_and_a_case_it_cannot_study() {
    let dir = std::env::temp_dir().join(format!("linelight-study-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("out");
    let case = concat!(env!("CARGO_MANIFEST_DIR"), "/cases/studies/ggx_resolution.toml");
    // A table file that is not a table (its grid columns off).
    let bad = dir.join("bad.csv");
    std::fs::write(&bad, small_table().replace("\n0,0,0,0,0e0,0e0,", "\n0,0,0,0,1e0,0e0,")).unwrap();
    let o = linelight(&[
        "resolution",
        case,
        "--table",
        bad.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("bad.csv") && err.contains("not its grid point"), "{err}");
    assert!(!out.exists());
    // A case with an isotropic family.
    let iso = dir.join("iso.toml");
    let text = std::fs::read_to_string(case)
        .unwrap()
        .replace("anisotropy = { dist = \"fixed\", value = 0.4642857142857143 }", "");
    std::fs::write(&iso, text).unwrap();
    let good = dir.join("good.csv");
    std::fs::write(&good, small_table()).unwrap();
    let o = linelight(&[
        "resolution",
        iso.to_str().unwrap(),
        "--table",
        good.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("anisotropic ggx families"), "{err}");
    assert!(!out.exists());
    std::fs::remove_dir_all(&dir).ok();
}
