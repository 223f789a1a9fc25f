//! Light textures: texture content as a case distribution (`[materials.texture]`,
//! src/input/case/texture.rs). Good and bad case keys (a bad one exits 2 naming the key, nothing
//! written), the sampler's texture draws (the same for a seed, texels in range), and the
//! `frequency` axis against what the texels hold: the sign changes of a stripes texture along
//! the light counted between its texel centres, against the zeros of the drawn square wave there.

use crate::common;

use common::snapshot::{only_changed, refused, s, snapshot};
use common::{linelight, write};
use linelight::input::case::Case;
use linelight::input::sampler::sample_case;
use linelight::input::texture::TextureKind;

const BASE: &str = r#"
name = "t"
title = "t"
seed = 7
min_per_bin = 0
methods = ["line.ltc2017", "line.texture_closest[line.ltc2017]"]
[geometry]
elevation = { dist = "uniform", min = 10.0, max = 90.0 }
tilt_angle = { dist = "uniform", min = 0.0, max = 180.0 }
length = { dist = "log_uniform", min = 0.1, max = 10.0 }
center = { dist = "uniform", min = -0.5, max = 0.5 }
[[materials]]
name = "along"
kind = "diffuse"
count = 60
[materials.texture]
kind = "cylindrical"
size = [64, 2]
pattern = { shape = "stripes", direction = "along", frequency = { dist = "log_uniform", min = 0.5, max = 16.0 }, contrast = { dist = "uniform", min = 0.2, max = 0.8 } }
[[materials]]
name = "around"
kind = "diffuse"
count = 30
[materials.texture]
kind = "cylindrical"
size = [2, 32]
pattern = { shape = "stripes", direction = "around", frequency = { dist = "uniform", min = 1.0, max = 8.0 }, contrast = { dist = "fixed", value = 0.5 } }
[[materials]]
name = "gradient"
kind = "diffuse"
count = 20
[materials.texture]
kind = "cylindrical"
size = [16, 1]
pattern = { shape = "gradient", direction = "along", contrast = { dist = "uniform", min = 0.0, max = 1.0 } }
[[materials]]
name = "step"
kind = "diffuse"
count = 20
[materials.texture]
kind = "cylindrical"
size = [16, 16]
pattern = { shape = "step", contrast = { dist = "uniform", min = 0.3, max = 0.6 } }
[[materials]]
name = "constant"
kind = "diffuse"
count = 20
[materials.texture]
kind = "cylindrical"
size = [3, 2]
pattern = { shape = "constant" }
[[materials]]
name = "cube"
kind = "diffuse"
count = 20
[materials.texture]
kind = "cubemap"
size = [8, 8]
pattern = { shape = "stripes", direction = "around", frequency = { dist = "uniform", min = 1.0, max = 4.0 }, contrast = { dist = "uniform", min = 0.1, max = 0.9 } }
[[materials]]
name = "plain"
kind = "diffuse"
count = 20
[[bins]]
axis = "frequency"
edges = [0.5, 2.0, 16.0]
[[bins]]
axis = "texture_contrast"
edges = [0.0, 0.5, 1.0]
[[bins]]
axis = "distance_over_length"
edges = [0.1, 1.0, 10.0]
"#;

#[test]
fn texture_draws_are_seeded_in_range_and_hold_the_frequency_drawn() {
    let case = Case::parse("t.toml", BASE).unwrap();
    let a = sample_case(&case);
    let b = sample_case(&case);
    assert_eq!(a.len(), 190);
    // The same seed gives the same textures, texel for texel; another seed others.
    assert!(a.iter().zip(&b).all(|(x, y)| x.config == y.config));
    let mut other = case.clone();
    other.seed = 8;
    let c = sample_case(&other);
    assert_ne!(a[0].config.texture, c[0].config.texture);
    let family = |s: &linelight::input::sampler::Sample| case.materials[s.material].name.as_str();
    let mut checked_changes = 0;
    for s in &a {
        let name = family(s);
        let ax = &s.axes;
        assert!((ax.distance_over_length * ax.length - 1.0).abs() < 1e-12, "{name}");
        let Some(t) = &s.config.texture else {
            assert_eq!(name, "plain");
            assert!(ax.frequency.is_nan() && ax.texture_contrast.is_nan());
            continue;
        };
        let spec = case.materials[s.material].texture.as_ref().unwrap();
        assert_eq!((t.kind, t.size), (spec.kind, spec.size), "{name}");
        assert_eq!(t.texels.len() as u64, spec.texel_count(), "{name}");
        // Texels lie in [1 − c, 1 + c] with c the drawn contrast; a constant texture is 1.
        let c = ax.texture_contrast;
        if name == "constant" {
            assert!(c.is_nan() && t.texels.iter().all(|&x| x == 1.0));
            continue;
        }
        let (lo, hi) = case.materials[s.material]
            .texture
            .as_ref()
            .and_then(|t| t.pattern.contrast.as_ref())
            .unwrap()
            .bounds();
        assert!(c >= lo && c <= hi, "{name}: contrast {c}");
        for &x in &t.texels {
            assert!(
                x >= 1.0 - c - 1e-12 && x <= 1.0 + c + 1e-12,
                "{name}: texel {x}, contrast {c}"
            );
        }
        // Stripes take two values only; a gradient is monotone along u.
        let distinct = |v: &[f64]| {
            let mut d: Vec<f64> = v.to_vec();
            d.sort_by(f64::total_cmp);
            d.dedup();
            d.len()
        };
        match name {
            "along" | "around" | "cube" => {
                assert!(distinct(&t.texels) <= 2, "{name}");
                let f = ax.frequency;
                assert!(f.is_finite() && f > 0.0, "{name}: frequency {f}");
            }
            "gradient" => {
                assert!(t.texels.windows(2).all(|w| w[0] < w[1]), "{name}: {:?}", t.texels);
                assert!(ax.frequency.is_nan());
            }
            "step" => {
                // A box: both levels present.
                assert_eq!(distinct(&t.texels), 2, "{name}");
                assert!(ax.frequency.is_nan());
            }
            _ => unreachable!(),
        }
        if name == "cube" {
            assert_eq!(t.kind, TextureKind::Cubemap);
        }
        if !matches!(name, "along" | "around") {
            continue;
        }
        // The frequency axis against the texels: the texels' sign changes (about 1) along the
        // pattern's direction, between the first and the last texel centre, equal the zeros of
        // sin(2π(f·x + phase)) there, with the phase found from the first texel's sign and the
        // count; and their number is within 2 of 2f over the whole length.
        let [nu, nv] = t.size.map(|n| n as usize);
        let row: Vec<f64> = if name == "along" {
            t.texels[..nu].to_vec()
        } else {
            (0..nv).map(|j| t.texels[j * nu]).collect()
        };
        let n = row.len() as f64;
        let changes = row.windows(2).filter(|w| (w[0] >= 1.0) != (w[1] >= 1.0)).count() as f64;
        let f = ax.frequency;
        // Zeros of the square wave in [x0, x1] (x the texel centres' span) number f·(x1 − x0)·2
        // up to one either way.
        let span = (n - 1.0) / n;
        assert!(
            (changes - 2.0 * f * span).abs() <= 1.0 + 1e-9,
            "{name}: {changes} sign changes between {n} texel centres, frequency {f}"
        );
        // And each band holds at least one texel: no run of equal texels longer than a band
        // (1/(2f) of the length) plus one texel.
        let mut run = 1usize;
        let mut longest = 1usize;
        for w in row.windows(2) {
            run = if w[0] == w[1] { run + 1 } else { 1 };
            longest = longest.max(run);
        }
        if changes >= 2.0 {
            assert!(
                (longest as f64) <= n / (2.0 * f) + 1.0 + 1e-9,
                "{name}: a run of {longest} equal texels, longer than a band of {} texels",
                n / (2.0 * f)
            );
        }
        checked_changes += 1;
    }
    assert_eq!(checked_changes, 90);
}

#[test]
fn an_untextured_family_draws_what_it_drew_before() {
    // Textures are drawn last and only for textured families: a family without one is the
    // same configuration by configuration whether the families beside it are textured or not.
    let case = Case::parse("t.toml", BASE).unwrap();
    let plain: Vec<_> = sample_case(&case).into_iter().filter(|s| s.material == 6).collect();
    let mut untextured = case.clone();
    for m in untextured.materials.iter_mut() {
        m.texture = None;
    }
    untextured.bins.clear();
    let without = sample_case(&untextured);
    let again: Vec<_> = without.iter().filter(|s| s.material == 6).collect();
    assert_eq!(plain.len(), 20);
    assert!(plain.iter().zip(&again).all(|(a, b)| a.config == b.config));
    // A configuration's texture is drawn after its geometry: each textured family's first
    // configuration has the geometry it has without the texture (the next ones follow on in
    // the family's stream).
    let with = sample_case(&case);
    for m in 0..6 {
        let a = with.iter().find(|s| s.material == m).unwrap();
        let b = without.iter().find(|s| s.material == m).unwrap();
        assert_eq!((a.config.p1, a.config.p2), (b.config.p1, b.config.p2), "family {m}");
        assert!(a.config.texture.is_some() && b.config.texture.is_none());
    }
}

#[test]
fn bad_texture_keys_exit_2_naming_the_key() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let stripes = r#"pattern = { shape = "stripes", direction = "along", frequency = { dist = "log_uniform", min = 0.5, max = 16.0 }, contrast = { dist = "uniform", min = 0.2, max = 0.8 } }"#;
    let cases: Vec<(String, Vec<&str>)> = vec![
        (
            BASE.replace(stripes, &stripes.replace("shape = \"stripes\"", "shape = \"stripes\", angle = 3.0")),
            vec!["angle"],
        ),
        (BASE.replace("size = [64, 2]", "size = [64, 2]\ntint = 2.0"), vec!["tint"]),
        (
            BASE.replace("kind = \"cylindrical\"\nsize = [64, 2]", "kind = \"spherical\"\nsize = [64, 2]"),
            vec!["spherical"],
        ),
        (
            BASE.replace("min = 0.2, max = 0.8 } }", "min = 0.2, max = 1.5 } }"),
            vec!["materials[0].texture.pattern.contrast", "1.5"],
        ),
        (
            BASE.replace("size = [64, 2]", "size = [16, 2]"),
            vec!["materials[0].texture.pattern.frequency", "size", "[16, 2]"],
        ),
        (
            BASE.replace("size = [64, 2]", "size = [5000, 2]"),
            vec!["materials[0].texture.size", "4096"],
        ),
        (
            BASE.replace("size = [64, 2]", "size = [2048, 2048]"),
            vec!["materials[0].texture.size", "texels per configuration"],
        ),
        (
            BASE.replace("size = [8, 8]", "size = [8, 4]"),
            vec!["materials[5].texture.size", "square"],
        ),
        (
            BASE.replace(
                "pattern = { shape = \"constant\" }",
                "pattern = { shape = \"constant\", contrast = { dist = \"fixed\", value = 0.5 } }",
            ),
            vec!["materials[4].texture.pattern.contrast", "constant"],
        ),
        (
            BASE.replace(", direction = \"along\", contrast", ", contrast"),
            vec!["materials[2].texture.pattern.direction", "gradient"],
        ),
        (
            BASE.replace("min = 0.5, max = 16.0 }, contrast", "min = 0.0, max = 16.0 }, contrast"),
            vec!["materials[0].texture.pattern.frequency"],
        ),
        (
            BASE.replace("center = { dist = \"uniform\", min = -0.5, max = 0.5 }", "center = { dist = \"uniform\", min = -0.5, max = 0.5 }\nrect_width = { dist = \"fixed\", value = 0.1 }"),
            vec!["materials[0].texture", "rect_width"],
        ),
        (
            BASE.replace("axis = \"frequency\"\nedges = [0.5, 2.0, 16.0]", "axis = \"frequency\"\nedges = [20.0, 30.0]"),
            vec!["bins[0].edges", "frequency"],
        ),
    ];
    let before = snapshot(d);
    for (text, words) in cases {
        assert_ne!(text, BASE, "the replacement for {words:?} matched nothing");
        let path = write(d, "case.toml", &text);
        let o = linelight(&["sweep", s(&path), "--out", s(&d.join("reports"))]);
        refused(&o, &words);
    }
    // An axis no family draws is refused too.
    let none = BASE.replace("[materials.texture]", "[materials.nothing]");
    let none = Case::parse("t.toml", &none).unwrap_err().to_string();
    assert!(none.contains("nothing"), "{none}");
    only_changed(&before, &snapshot(d), &["case.toml"]);
}

#[test]
fn the_texels_enter_the_memory_estimate() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    // 4096 × 256 texels per configuration: a chunk of them is gigabytes, refused by name.
    let big = BASE
        .replace("size = [64, 2]", "size = [4096, 256]")
        .replace("count = 60", "count = 100000");
    let path = write(d, "case.toml", &big);
    let o = linelight(&["sweep", s(&path), "--out", s(&d.join("reports")), "--max-memory", "4G"]);
    refused(&o, &["needs an estimated", "light textures of", "1048576 texels each"]);
    // The same case untextured fits.
    let small = big.replace("size = [4096, 256]", "size = [64, 2]");
    let case = Case::parse("t.toml", &small).unwrap();
    assert_eq!(case.materials[0].texture.as_ref().unwrap().texel_count(), 128);
}
