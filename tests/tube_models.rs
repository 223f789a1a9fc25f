//! Which model a real tube light follows, from the references alone: a Lambertian tube of
//! radius R → 0 (target `cylinder`) against the chapter's thin-cylinder line (`R·line`) and
//! against isotropic emitters of the tube's power (`(π/2)·R·line_isotropic`, the model the
//! engines shade). Prints the table quoted in docs/line_models.md:
//! `cargo test --release --test all tube_models:: -- --nocapture`.

use linelight::input::scene::{Config, Material};
use linelight::input::target::Target;
use linelight::reference::reference;
use std::f64::consts::PI;

/// A segment of length 2 centred at distance 1 from the shading point, its tangent at
/// `angle` degrees from the direction to the shading point, tilted about the view ray.
fn config(name: &str, angle: f64, elevation: f64, material: Material, radius: f64) -> Config {
    let (se, ce) = elevation.to_radians().sin_cos();
    let centre = [ce, 0.0, se];
    // Perpendicular to the centre direction, in its vertical plane, and horizontal.
    let (up, side) = ([-se, 0.0, ce], [0.0, 1.0, 0.0]);
    let (sa, ca) = angle.to_radians().sin_cos();
    // `angle` between the tangent and the direction towards the shading point (−centre).
    let t = [0, 1, 2].map(|k| -ca * centre[k] + sa * (0.6 * up[k] + 0.8 * side[k]));
    let half = 1.0;
    Config {
        id: name.to_string(),
        p1: [0, 1, 2].map(|k| centre[k] - half * t[k]),
        p2: [0, 1, 2].map(|k| centre[k] + half * t[k]),
        radius: Some(radius),
        rect: None,
        material,
        texture: None,
    }
}

#[test]
fn a_thin_tube_follows_the_cylinder_model_not_isotropic_emitters() {
    let ltc = Material::Ltc {
        minv: [[4.0, 0.0, -1.5], [0.0, 3.5, 0.0], [0.1, 0.0, 1.0]],
    };
    let cases = [
        ("broadside, overhead", 90.0, 90.0, Material::Diffuse),
        ("oblique 45°, overhead", 45.0, 90.0, Material::Diffuse),
        ("oblique 20°, elevation 40°", 20.0, 40.0, Material::Diffuse),
        ("broadside, ltc lobe", 90.0, 60.0, ltc.clone()),
        ("oblique 30°, ltc lobe", 30.0, 60.0, ltc),
    ];
    println!("| configuration | R | cylinder / (R·line) | cylinder / ((π/2)·R·line_isotropic) |");
    println!("|---|---:|---:|---:|");
    for (name, angle, elevation, material) in cases {
        let mut last: Option<f64> = None;
        for r in [1e-2, 1e-3, 1e-4] {
            let c = config(name, angle, elevation, material.clone(), r);
            c.validate().unwrap();
            let cyl = reference(&c, Target::Cylinder).unwrap();
            let line = reference(&c, Target::Line).unwrap().value;
            let iso = reference(&c, Target::LineIsotropic).unwrap().value;
            let (a, b) = (cyl.value / (r * line), cyl.value / (0.5 * PI * r * iso));
            println!("| {name} | {r:.0e} | {a:.6} | {b:.6} |");
            // The error of the cylinder model is O(R): it shrinks tenfold with R.
            if let Some(prev) = last {
                let (e, e_prev) = ((a - 1.0f64).abs(), (prev - 1.0f64).abs());
                assert!(e <= 0.2 * e_prev + 1e-7, "{name} R={r}: {a} after {prev}");
            }
            last = Some(a);
        }
        let a = last.unwrap();
        assert!((a - 1.0).abs() < 1e-3, "{name}: {a}");
    }
}

#[test]
fn isotropic_emitters_differ_from_the_cylinder_by_the_projected_width() {
    // Broadside the tube's projected width 2R exceeds its mean πR/2, end-on it tends to 0:
    // the isotropic model is brighter end-on and dimmer broadside than a real tube.
    let r = 1e-4;
    let ratio = |angle: f64| {
        let c = config("x", angle, 90.0, Material::Diffuse, r);
        reference(&c, Target::Cylinder).unwrap().value
            / (0.5 * PI * r * reference(&c, Target::LineIsotropic).unwrap().value)
    };
    let (broadside, endish) = (ratio(90.0), ratio(10.0));
    assert!(broadside > 1.0 && endish < 1.0, "{broadside} {endish}");
}
