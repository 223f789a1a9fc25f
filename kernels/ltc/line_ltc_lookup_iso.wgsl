//! id: line.ltc_lookup_iso
//! target: line
//! source: ours: our isotropic GGX LTC table (data/ltc_ggx_iso.csv) looked up on the device as seed 003's shader samples it (bilinear, half-texel scale and bias), α = √(αx·αy) for anisotropic roughness (the engines' fallback), then the inner LTC line method times the Fresnel-weighted magnitude
//! minv: ggx
//! uses: line

// The device side of the `table` feed (src/input/ltc/table.rs, `Table::sample` with f32 texels):
// the same texel positions, clamp-to-edge and lerps, in f32, read from the harness's LTC tables
// (`ll_ltc`, layout in src/input/ltc/device.rs) instead of a texture unit. On an isotropic lobe it
// is the host feed; on an anisotropic one it is the isotropic fallback at the geometric-mean α.
// The result is the engine's: I_line with this M⁻¹, times f0·magnitude + (1 − f0)·fresnel
// (seed 003 §2.3; with f0 = 1 the magnitude itself).

struct LtcIsoFeed {
    minv: mat3x3<f32>,
    magnitude: f32,
    fresnel: f32,
}

// Texel (a, t), channel k: (a, b, c, d) of the sparse M⁻¹, magnitude, Fresnel term.
fn ltc_iso_texel(base: u32, n: u32, a: u32, t: u32, k: u32) -> f32 {
    return ll_ltc[base + 6u * (a + n * t) + k];
}

// The look-up at roughness `alpha` and cos θ = `cos_theta`: M⁻¹ in the frame where the view lies
// in the xz-plane, the magnitude and the Fresnel term.
fn ltc_iso_lookup(alpha: f32, cos_theta: f32) -> LtcIsoFeed {
    let size = u32(ll_ltc[0]);
    let base = u32(ll_ltc[1]);
    let n = f32(size);
    // (u, v) = (√α, √(1 − cos θ)), seed 003's LUT_SCALE and LUT_BIAS, then the texture unit's
    // texel position u·N − ½, clamped to the edge texels.
    let scale = (n - 1.0) / n;
    let bias = 0.5 / n;
    let u = sqrt(alpha);
    let v = sqrt(max(1.0 - cos_theta, 0.0));
    let px = clamp((u * scale + bias) * n - 0.5, 0.0, n - 1.0);
    let py = clamp((v * scale + bias) * n - 0.5, 0.0, n - 1.0);
    let i0 = min(u32(floor(px)), size - 1u);
    let i1 = min(u32(floor(py)), size - 1u);
    let fx = px - f32(i0);
    let fy = py - f32(i1);
    let j0 = min(i0 + 1u, size - 1u);
    let j1 = min(i1 + 1u, size - 1u);
    var c: array<f32, 6>;
    for (var k = 0u; k < 6u; k++) {
        let t00 = ltc_iso_texel(base, size, i0, i1, k);
        let t10 = ltc_iso_texel(base, size, j0, i1, k);
        let t01 = ltc_iso_texel(base, size, i0, j1, k);
        let t11 = ltc_iso_texel(base, size, j0, j1, k);
        let lo = t00 + fx * (t10 - t00);
        let hi = t01 + fx * (t11 - t01);
        c[k] = lo + fy * (hi - lo);
    }
    // [[a, 0, b], [0, c, 0], [d, 0, 1]] row-major, as columns.
    let minv = mat3x3<f32>(
        vec3<f32>(c[0], 0.0, c[3]),
        vec3<f32>(0.0, c[2], 0.0),
        vec3<f32>(c[1], 0.0, 1.0),
    );
    return LtcIsoFeed(minv, c[4], c[5]);
}

// The feed of this scene: its roughness (one α, or the geometric mean of two) and view.
fn ltc_iso_feed(scene: Scene) -> LtcIsoFeed {
    var alpha = scene.alpha_x;
    if (scene.alpha_y != scene.alpha_x) {
        alpha = sqrt(scene.alpha_x * scene.alpha_y);
    }
    return ltc_iso_lookup(alpha, scene.view.z);
}

fn method(scene: Scene) -> f32 {
    let feed = ltc_iso_feed(scene);
    Minv = feed.minv;
    let weight = scene.f0 * feed.magnitude + (1.0 - scene.f0) * feed.fresnel;
    return I_line(scene.p1, scene.p2) * weight;
}
