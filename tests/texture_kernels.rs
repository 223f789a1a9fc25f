//! Light textures: the texel buffer and the prelude's look-ups. A probe kernel reads texels and
//! bilinear values back: the GPU and the CPU evaluator read the same texels, the f32 paths agree,
//! and the f64 evaluator's `ll_texel_bilinear` and `ll_texel_cube` match the host's definition
//! (`Texture::bilinear`, `Texture::cube`) computed directly. The seed-002 tints scale a constant
//! texture's line exactly by the constant.

use crate::common;
use common::gpu_values;

use linelight::eval::interp::{CpuColumns, Mode};
use linelight::input::scene::{Config, Material};
use linelight::input::texture::{Texture, TextureKind};
use linelight::kernel::methods::{resolve, Method};
use linelight::kernel::{builtin_kernels, KernelFile};

const PROBE: &str = "//! id: user.texel_probe
//! target: line
//! source: tests/texture_kernels.rs: a texel, a bilinear value or a cube value read back
//! minv: ggx
//! params: MODE=0.0 U=0.0 V=0.0
override MODE: f32 = 0.0;
override U: f32 = 0.0;
override V: f32 = 0.0;
fn method(scene: Scene) -> f32 {
    if (MODE == 0.0) {
        return ll_texels[scene.tex_offset + u32(U)];
    }
    if (MODE == 1.0) {
        return ll_texel_bilinear(scene.tex_offset, scene.tex_nu, scene.tex_nv, U, V, true);
    }
    if (MODE == 2.0) {
        return ll_texel_bilinear(scene.tex_offset, scene.tex_nu, scene.tex_nv, U, V, false);
    }
    return ll_texel_cube(scene.tex_offset, scene.tex_nu, vec3<f32>(U, V, 0.25));
}
";

fn probe(kernels: &[KernelFile], mode: u32, u: f64, v: f64) -> Method {
    resolve(&format!("user.texel_probe@{mode}x{u}x{v}"), kernels).unwrap()
}

fn config(id: &str, texture: Texture) -> Config {
    Config {
        id: id.into(),
        p1: [0.3, -0.2, 1.0],
        p2: [0.9, 0.4, 1.6],
        radius: None,
        rect: None,
        material: Material::Diffuse,
        texture: Some(texture),
    }
}

/// Texels with digits below f32's (so f64 and f32 lanes differ) and a jump.
fn textures() -> Vec<Config> {
    let cyl = |nu: u32, nv: u32| Texture {
        kind: TextureKind::Cylindrical,
        size: [nu, nv],
        texels: (0..nu * nv)
            .map(|k| 0.1 + f64::from(k % 7) * 0.3 + f64::from(k / 5) * 1e-9)
            .collect(),
        origin: None,
    };
    let cube = Texture {
        kind: TextureKind::Cubemap,
        size: [3, 3],
        texels: (0..54).map(|k| 0.2 + f64::from(k) * 0.05 + 1e-10).collect(),
        origin: None,
    };
    vec![
        config("a", cyl(4, 3)),
        config("b", cyl(3, 2)),
        config("cube", cube),
        config("c", cyl(7, 2)),
    ]
}

#[test]
fn gpu_and_evaluator_read_the_same_texels() {
    let mut kernels = builtin_kernels();
    kernels.push(KernelFile::parse("probe.wgsl", PROBE).unwrap());
    let cs = textures();
    for k in 0..6 {
        let m = probe(&kernels, 0, f64::from(k), 0.0);
        let gpu = gpu_values(&m, &cs);
        let f32s = m.cpu_column(&cs, Mode::F32).unwrap();
        let f64s = m.cpu_column(&cs, Mode::F64).unwrap();
        for (((c, g), a), b) in cs.iter().zip(gpu).zip(f32s).zip(f64s) {
            let t = c.texture.as_ref().unwrap().texels[k as usize];
            assert_eq!(g, t as f32, "{}: GPU texel {k}", c.id);
            assert_eq!(a.unwrap(), f64::from(t as f32), "{}: evaluator f32 texel {k}", c.id);
            assert_eq!(b.unwrap(), t, "{}: evaluator f64 texel {k}", c.id);
        }
    }
}

#[test]
fn bilinear_and_cube_lookups_match_the_host_definition() {
    let mut kernels = builtin_kernels();
    kernels.push(KernelFile::parse("probe.wgsl", PROBE).unwrap());
    let cs = textures();
    // Dyadic coordinates (exact in f32 and f64), inside, between centres, beyond the edges
    // and (v) wrapping below 0 and above 1.
    let points = [
        (0.375, 0.8125),
        (0.0, 0.0),
        (1.0, 1.0),
        (-0.25, -0.3125),
        (0.5625, 1.40625),
        (0.96875, 0.03125),
    ];
    for mode in [1u32, 2, 3] {
        for &(u, v) in &points {
            let m = probe(&kernels, mode, u, v);
            let gpu = gpu_values(&m, &cs);
            let f32s = m.cpu_column(&cs, Mode::F32).unwrap();
            let f64s = m.cpu_column(&cs, Mode::F64).unwrap();
            for (((c, g), a), b) in cs.iter().zip(gpu).zip(f32s).zip(f64s) {
                let t = c.texture.as_ref().unwrap();
                let cube = t.kind == TextureKind::Cubemap;
                let host = match mode {
                    // The probe passes the texture's own size: a cubemap's first face.
                    1 => t.bilinear(0, u, v, true),
                    2 => t.bilinear(0, u, v, false),
                    _ if cube => t.cube([u, v, 0.25]),
                    _ => continue,
                };
                let (a, b) = (a.unwrap(), b.unwrap());
                let at = format!("{} mode {mode} at ({u}, {v})", c.id);
                assert!(
                    (b - host).abs() <= 1e-14 * host.abs().max(1.0),
                    "{at}: f64 {b} vs host {host}"
                );
                // f32: the GPU and the evaluator's f32 agree to a few ulps of the value.
                let tol = 4.0 * f64::from(f32::EPSILON) * host.abs().max(1.0);
                assert!((f64::from(g) - a).abs() <= tol, "{at}: GPU {g} vs evaluator f32 {a}");
                assert!((a - host).abs() <= tol + 1e-8, "{at}: evaluator f32 {a} vs host {host}");
            }
        }
    }
}

#[test]
fn one_lookup_tints_scale_a_constant_texture_exactly() {
    let kernels = builtin_kernels();
    let inner = resolve("line.ltc2023_full", &kernels).unwrap();
    let constant = |kind| {
        let n = if kind == TextureKind::Cubemap { 54 } else { 6 };
        let size = if kind == TextureKind::Cubemap { [3, 3] } else { [2, 3] };
        Texture {
            kind,
            size,
            texels: vec![2.5; n],
            origin: None,
        }
    };
    for (spec, kind) in [
        ("line.texture_closest[line.ltc2023_full]", TextureKind::Cylindrical),
        ("line.texture_cube[line.ltc2023_full]", TextureKind::Cubemap),
        ("line.texture_average[line.ltc2023_full]", TextureKind::Cylindrical),
        ("line.texture_average[line.ltc2023_full]", TextureKind::Cubemap),
    ] {
        let m = resolve(spec, &kernels).unwrap();
        let cs = vec![config("k", constant(kind))];
        let plain = inner.cpu_column(&cs, Mode::F64).unwrap()[0].unwrap();
        let tinted = m.cpu_column(&cs, Mode::F64).unwrap()[0].unwrap();
        assert!(
            (tinted - 2.5 * plain).abs() <= 1e-13 * plain,
            "{spec} {kind:?}: {tinted} vs 2.5 × {plain}"
        );
        let g = gpu_values(&m, &cs)[0];
        assert!(
            (f64::from(g) - 2.5 * plain).abs() <= 1e-4 * plain,
            "{spec} {kind:?}: GPU {g}, plain {plain} tinted {tinted}"
        );
    }
}

/// `eval` refuses a malformed texture before any work: exit 2, the configuration, the line and
/// the field named, the output not written. A good textured line evaluates.
#[test]
fn eval_refuses_malformed_textures_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let good = r#"{"id":"ok","p1":[0.3,-0.2,1.0],"p2":[0.9,0.4,1.6],"material":{"kind":"diffuse"},"texture":{"kind":"cylindrical","size":[2,1],"texels":[0.5,1.5]}}"#;
    let cases = [
        (good.replace("[0.5,1.5]", "[0.5]"), "texture.texels"),
        (good.replace("[0.5,1.5]", "[0.5,1e999]"), ""),
        (
            good.replace("\"size\"", "\"origin\":[0,0,1],\"size\""),
            "texture.origin",
        ),
        (good.replace("cylindrical", "spherical"), "spherical"),
        (good.replace("[2,1]", "[2,0]"), "texture.size"),
    ];
    for (line, field) in cases {
        let input = common::write(dir.path(), "in.jsonl", &format!("{good}\n{line}\n"));
        let out = dir.path().join("out.jsonl");
        let o = common::eval(&input, &out, &["--methods", "line.texture_closest"]);
        let err = common::stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{line}: {err}");
        assert!(err.contains("in.jsonl:2") && err.contains(field), "{line}: {err}");
        assert!(!out.exists(), "{line}: output written");
    }
    let input = common::write(dir.path(), "in.jsonl", &format!("{good}\n"));
    let out = dir.path().join("out.jsonl");
    let o = common::eval(
        &input,
        &out,
        &["--methods", "line.texture_closest,line.texture_average"],
    );
    assert_eq!(o.status.code(), Some(0), "{}", common::stderr(&o));
    let row: serde_json::Value = serde_json::from_str(std::fs::read_to_string(&out).unwrap().trim()).unwrap();
    let reference = row["reference"]["line"].as_f64().unwrap();
    let closest = row["methods"]["line.texture_closest"]["f64"].as_f64().unwrap();
    assert!(reference > 0.0 && closest > 0.0, "{row}");
}
