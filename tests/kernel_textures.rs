//! Textures and samplers in the kernel contract: `//! texture: NAME = FILE` and
//! `//! sampler: NAME = FILTER, ADDRESS` headers (src/kernel/file.rs), the files confined to the
//! kernel's folder, and each texture or sampler global bound by exactly one header
//! (src/kernel/compose.rs). A refusal exits 2 naming the kernel file and line.

use crate::common;

use common::linelight;
use common::snapshot::s;
use linelight::input::texture_file::Dimension;
use linelight::kernel::{AddressMode, Filter, Includes, KernelFile};
use std::path::{Path, PathBuf};

/// A NumPy .npy file of little-endian float32 values of `shape`, C order.
fn npy(dir: &Path, name: &str, shape: &[usize], values: &[f32]) -> PathBuf {
    assert_eq!(shape.iter().product::<usize>(), values.len());
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let tuple = if dims.len() == 1 {
        format!("({},)", dims[0])
    } else {
        format!("({})", dims.join(", "))
    };
    let mut header = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': {tuple}, }}");
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
    bytes.extend_from_slice(header.as_bytes());
    for v in values {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// A kernel reading texture `lut` with sampler `s` at (0.5, 0.5), with `headers` and `decls`.
fn kernel_text(headers: &str, decls: &str) -> String {
    format!(
        "//! id: user.tex\n//! target: line\n{headers}{decls}\
         fn method(scene: Scene) -> f32 {{\n    return textureSampleLevel(lut, s, vec2<f32>(0.5, 0.5), 0.0).x;\n}}\n"
    )
}

const DECLS: &str = "@group(1) @binding(0) var lut: texture_2d<f32>;\n@group(1) @binding(1) var s: sampler;\n";

fn texels16() -> Vec<f32> {
    (0..16).map(|i| i as f32 * 0.25).collect()
}

#[test]
fn headers_bind_a_file_and_a_sampler() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("luts")).unwrap();
    npy(&dir.path().join("luts"), "t.npy", &[4, 4, 1], &texels16());
    let text = kernel_text(
        "//! texture: lut = luts/t.npy\n//! sampler: s = nearest, repeat\n",
        DECLS,
    );
    let path = dir.path().join("k.wgsl");
    std::fs::write(&path, &text).unwrap();
    let k = KernelFile::read(&path, &Includes::none()).unwrap();
    assert_eq!(k.textures.len(), 1);
    let t = &k.textures[0];
    assert_eq!((t.name.as_str(), t.file.as_str(), t.line), ("lut", "luts/t.npy", 3));
    assert_eq!((t.data.width, t.data.height, t.data.channels), (4, 4, 1));
    assert_eq!(t.data.kind, Dimension::D2);
    assert_eq!(t.data.texels, texels16());
    assert_eq!(k.samplers.len(), 1);
    assert_eq!(
        (
            k.samplers[0].name.as_str(),
            k.samplers[0].spec.filter,
            k.samplers[0].spec.address,
            k.samplers[0].line
        ),
        ("s", Filter::Nearest, AddressMode::Repeat, 4)
    );
    let out = linelight(&["check", s(&path)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

/// `linelight check` of a kernel `text` written beside the 4×4 `t.npy`: its exit status and stderr.
fn check(dir: &Path, text: &str) -> (i32, String) {
    npy(dir, "t.npy", &[4, 4, 1], &texels16());
    let path = dir.join("k.wgsl");
    std::fs::write(&path, text).unwrap();
    let out = linelight(&["check", s(&path)]);
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn bad_bindings_are_refused_naming_the_kernel_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let outside = tempfile::tempdir().unwrap();
    npy(outside.path(), "o.npy", &[4, 4, 1], &texels16());
    std::os::unix::fs::symlink(outside.path().join("o.npy"), d.join("link.npy")).unwrap();
    let abs = outside.path().join("o.npy");
    let sampler = "//! sampler: s = linear, clamp\n";
    let cases: Vec<(String, String, &str)> = vec![
        (
            "//! texture: lut = t.npy\n//! sampler: s = bilinear, clamp\n".to_string(),
            DECLS.into(),
            "k.wgsl:4: a sampler is `linear` or `nearest`, then `clamp` or `repeat`",
        ),
        (
            format!("//! texture: lut t.npy\n{sampler}"),
            DECLS.into(),
            "k.wgsl:3: a texture header is `//! texture: NAME = FILE`",
        ),
        (
            format!("//! texture: lut = missing.npy\n{sampler}"),
            DECLS.into(),
            "k.wgsl:3: cannot find texture file `missing.npy`",
        ),
        (
            format!("//! texture: lut = ../t.npy\n{sampler}"),
            DECLS.into(),
            "k.wgsl:3: texture file `../t.npy` leaves the kernel's folder",
        ),
        (
            format!("//! texture: lut = {}\n{sampler}", abs.display()),
            DECLS.into(),
            "is an absolute path: name it relative to the kernel's folder",
        ),
        (
            format!("//! texture: lut = link.npy\n{sampler}"),
            DECLS.into(),
            "k.wgsl:3: texture file `link.npy` resolves to",
        ),
        (
            format!("//! texture: lut = t.npy\n//! texture: lut = t.npy\n{sampler}"),
            DECLS.into(),
            "k.wgsl:4: `lut` is bound twice (first on line 3)",
        ),
        (
            sampler.to_string(),
            DECLS.into(),
            "texture `lut` is bound to nothing: add a header line `//! texture: lut = FILE`",
        ),
        (
            format!("//! texture: lut = t.npy\n//! texture: extra = t.npy\n{sampler}"),
            DECLS.into(),
            "k.wgsl:4: `//! texture: extra = …` names no texture global of the kernel",
        ),
        (
            "//! texture: lut = t.npy\n//! sampler: lut = linear, clamp\n".to_string(),
            "@group(1) @binding(0) var lut: texture_2d<f32>;\n@group(1) @binding(1) var s: sampler;\n".into(),
            "k.wgsl:4: `lut` is bound twice (first on line 3)",
        ),
    ];
    for (headers, decls, expected) in cases {
        let (code, stderr) = check(d, &kernel_text(&headers, &decls));
        assert_eq!(code, 2, "{headers}: {stderr}");
        assert!(
            stderr.contains(expected),
            "{headers}: expected `{expected}` in:\n{stderr}"
        );
        assert!(stderr.len() < 2000, "bounded: {stderr}");
    }
    // The unbound global's message points at its declaration.
    let (_, stderr) = check(d, &kernel_text("//! sampler: s = linear, clamp\n", DECLS));
    assert!(stderr.contains("k.wgsl:4"), "{stderr}");
}

#[test]
fn bindings_are_assigned_in_group_1_and_implicit_lod_samples_level_0() {
    let dir = tempfile::tempdir().unwrap();
    npy(dir.path(), "t.npy", &[4, 4, 1], &texels16());
    let text = "//! id: user.tex\n//! target: line\n//! texture: lut = t.npy\n//! sampler: s = linear, clamp\n\
                var lut: texture_2d<f32>;\n@group(1) @binding(0) var s: sampler;\n\
                fn method(scene: Scene) -> f32 {\n    return textureSample(lut, s, vec2<f32>(0.5, 0.5)).x;\n}\n";
    let path = dir.path().join("k.wgsl");
    std::fs::write(&path, text).unwrap();
    let k = KernelFile::read(&path, &Includes::none()).unwrap();
    let composed = linelight::kernel::compose(&k).unwrap_or_else(|e| panic!("{e}"));
    // The kernel's own binding of `s` kept; `lut` takes the next free one of group 1.
    let binding = |name: &str| {
        let (_, g) = composed
            .module
            .global_variables
            .iter()
            .find(|(_, g)| g.name.as_deref() == Some(name))
            .unwrap();
        g.binding.as_ref().map(|b| (b.group, b.binding))
    };
    assert_eq!(binding("s"), Some((1, 0)));
    assert_eq!(binding("lut"), Some((1, 1)));
    assert!(composed
        .source
        .contains("textureSampleLevel(lut, s, vec2<f32>(0.5, 0.5), 0.0)"));
    // Line numbers kept: `method` is still on line 7 of the kernel.
    let method = composed.source.find("fn method").unwrap();
    assert_eq!(composed.locate(method).1, 7);

    for (decls, expected) in [
        (
            "@group(0) @binding(7) var lut: texture_2d<f32>;\n@group(1) @binding(1) var s: sampler;\n",
            "`lut` is bound in group 0, the harness's",
        ),
        (
            "@group(1) @binding(1) var lut: texture_2d<f32>;\n@group(1) @binding(1) var s: sampler;\n",
            "`s` and `lut` are both bound at @group(1) @binding(1)",
        ),
    ] {
        let (code, stderr) = check(
            dir.path(),
            &kernel_text("//! texture: lut = t.npy\n//! sampler: s = linear, clamp\n", decls),
        );
        assert_eq!(code, 2, "{stderr}");
        assert!(stderr.contains(expected), "expected `{expected}` in:\n{stderr}");
        assert!(stderr.contains("k.wgsl:"), "{stderr}");
    }
}

/// A 4×4 single-channel float32 texture sampled on lavapipe with a nearest and a linear sampler
/// (both clamped) at chosen uv, against the values computed here from the texels: nearest exactly;
/// linear within the bound 8 bits of sub-texel precision allow (lavapipe's): each axis's weight
/// off by at most 2⁻⁸, so |error| ≤ 2 · max texel difference · 2⁻⁸.
#[test]
fn gpu_samples_a_kernel_texture_nearest_and_linear() {
    use linelight::input::scene::Material;
    use linelight::kernel::builtin_kernels;
    use linelight::kernel::methods::resolve;
    let dir = tempfile::tempdir().unwrap();
    // Texel (x, y), row y first: not linear in x, so a filter off by half a texel shows.
    let texel = |x: usize, y: usize| (x * x) as f32 * 0.25 + y as f32 * 0.75;
    let texels: Vec<f32> = (0..16).map(|k| texel(k % 4, k / 4)).collect();
    npy(dir.path(), "t.npy", &[4, 4, 1], &texels);
    let text = "//! id: user.tex_sample\n//! target: line\n//! params: MODE=0.0 U=0.5 V=0.5\n\
                //! texture: lut = t.npy\n//! sampler: near = nearest, clamp\n//! sampler: lin = linear, clamp\n\
                var lut: texture_2d<f32>;\nvar near: sampler;\nvar lin: sampler;\n\
                override MODE: f32 = 0.0;\noverride U: f32 = 0.5;\noverride V: f32 = 0.5;\n\
                fn method(scene: Scene) -> f32 {\n    if (MODE == 0.0) {\n        return textureSample(lut, near, vec2<f32>(U, V)).x;\n    }\n\
                    return textureSample(lut, lin, vec2<f32>(U, V)).x;\n}\n";
    let path = dir.path().join("k.wgsl");
    std::fs::write(&path, text).unwrap();
    let mut kernels = builtin_kernels();
    kernels.push(KernelFile::read(&path, &Includes::none()).unwrap());
    let config = common::segment("a", [0.3, -0.2, 1.0], [0.9, 0.4, 1.6], Material::Diffuse);
    let max_diff = texels.iter().cloned().fold(f32::MIN, f32::max) - texels.iter().cloned().fold(f32::MAX, f32::min);
    let bound = 2.0 * f64::from(max_diff) * 2f64.powi(-8);
    let at = |i: f64| i.clamp(0.0, 3.0) as usize;
    for (u, v) in [(0.1, 0.1), (0.3, 0.6), (0.55, 0.2), (0.9, 0.95), (0.4375, 0.8125)] {
        let gpu = |mode: u32| {
            let m = resolve(&format!("user.tex_sample@{mode}.0x{u}x{v}"), &kernels).unwrap();
            common::gpu_values(&m, std::slice::from_ref(&config))[0]
        };
        let nearest = texel(at((u * 4.0f64).floor()), at((v * 4.0f64).floor()));
        assert_eq!(gpu(0), nearest, "nearest at ({u}, {v})");
        // Bilinear between texel centres, clamped to the edge texels.
        let (x, y) = (u * 4.0 - 0.5, v * 4.0 - 0.5);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let t = |i: f64, j: f64| f64::from(texel(at(i.max(0.0)), at(j.max(0.0))));
        let linear = (1.0 - fy) * ((1.0 - fx) * t(x0, y0) + fx * t(x0 + 1.0, y0))
            + fy * ((1.0 - fx) * t(x0, y0 + 1.0) + fx * t(x0 + 1.0, y0 + 1.0));
        let got = f64::from(gpu(1));
        assert!(
            (got - linear).abs() <= bound,
            "linear at ({u}, {v}): GPU {got}, exact bilinear {linear}, bound {bound}"
        );
    }
}
