// linelight prelude: prepended to every method kernel (built-in or --kernel FILE).
// It holds what the published listings take for granted: PI, the scene, the global
// `Minv` and `D(w)` of Listing 1.10, and the basis of Listing 1.3.
// Names starting with `ll_` are reserved for the harness.

const PI: f32 = 3.14159265358979323846;

// One configuration in the shading frame (origin = shading point, normal = +z).
// std430, 160 bytes: must match `GpuScene` in src/scene.rs. Members are only ever added at
// the end, so a kernel written to an older contract reads what it always read.
struct Scene {
    p1: vec3<f32>,
    radius: f32,          // 0 when the configuration has no radius
    p2: vec3<f32>,
    rect_width: f32,      // 0 when the configuration has no rectangle
    rect_normal: vec3<f32>,
    flags: u32,           // FLAG_* below
    minv: mat3x3<f32>,    // M⁻¹, ω_o = minv * ω; the identity for the diffuse material
    // The ggx material, in this scene's frame (for ggx the harness rotates the configuration
    // about z so that the view lies in the xz-plane); all 0 otherwise, so alpha_x > 0 tells
    // a ggx scene. No new global names: a kernel's own names cannot clash with them.
    view: vec3<f32>,      // the unit view direction v (v.z > 0)
    alpha_x: f32,         // GGX roughness along `tangent`
    tangent: vec3<f32>,   // unit, ⟂ +z: the material's x axis; alpha_y is along cross(+z, tangent)
    alpha_y: f32,         // GGX roughness along cross(+z, tangent)
    // Contract 3 (160 bytes): Fresnel and the textured emitter.
    tex_origin: vec3<f32>, // textured light: the unit vector ⟂ the light where φ = 0; 0 untextured
    f0: f32,              // ggx: Schlick's F0, F = f0 + (1 − f0)(1 − v·h)⁵; 1 (so F = 1) otherwise
    tex_kind: u32,        // 0 untextured, 1 cylindrical, 2 cubemap (kernels/README.md)
    tex_offset: u32,      // this scene's first texel in the harness's texel buffer
    tex_nu: u32,          // texels along u (cubemap: the face size)
    tex_nv: u32,          // texels along v (cubemap: the face size)
}

const FLAG_LTC: u32 = 1u;
const FLAG_RADIUS: u32 = 2u;
const FLAG_RECT: u32 = 4u;

// The listings' global `mat3 Minv;`, set by the harness entry point before `method`.
var<private> Minv: mat3x3<f32>;

// Listing 1.10: LTC evaluation (with Minv = I it is the diffuse distribution).
fn D(w: vec3<f32>) -> f32 {
    let wo = Minv * w;
    let lo = length(wo);
    let res = 1.0 / PI * max(0.0, wo.z / lo) * abs(determinant(Minv)) / (lo * lo * lo);
    return res;
}

// Listing 1.3: orthonormal basis from a unit vector [Frisvad 12].
fn buildOrthonormalBasis(n: vec3<f32>, b1: ptr<function, vec3<f32>>, b2: ptr<function, vec3<f32>>) {
    if (n.z < -0.9999999) {
        *b1 = vec3<f32>(0.0, -1.0, 0.0);
        *b2 = vec3<f32>(-1.0, 0.0, 0.0);
        return;
    }
    let a = 1.0 / (1.0 + n.z);
    let b = -n.x * n.y * a;
    *b1 = vec3<f32>(1.0 - n.x * n.x * a, b, -n.x);
    *b2 = vec3<f32>(b, 1.0 - n.y * n.y * a, -n.y);
}

// GLSL's inverse(mat3), which WGSL lacks: adjugate over determinant.
fn inverse3(m: mat3x3<f32>) -> mat3x3<f32> {
    let c0 = cross(m[1], m[2]);
    let c1 = cross(m[2], m[0]);
    let c2 = cross(m[0], m[1]);
    let det = dot(m[0], c0);
    return transpose(mat3x3<f32>(c0, c1, c2)) * (1.0 / det);
}

// The harness's texel buffer (light textures): every textured scene's texels, each from its
// `tex_offset`; one 0 when no scene is textured. Bound by the runner beside the entry point's
// bindings 0–2 (src/kernel/compose.rs).
@group(0) @binding(3) var<storage, read> ll_texels: array<f32>;

// The harness's LTC tables (the device look-ups): our isotropic 2D GGX table and our anisotropic
// 4D table (seed 004) as a shader's textures hold them (f32), behind a header giving their
// sizes, first texels and axes (layout: src/input/ltc/device.rs). Bound by the runner beside
// the texels; read by the device look-ups of kernels/ltc/, as storage, not through a sampler,
// for the texels' reason above.
@group(0) @binding(4) var<storage, read> ll_ltc: array<f32>;

// Seed 002's light textures (src/input/texture.rs, kernels/README.md): the texture's
// value at (u, v) on the nu×nv grid of texels starting at `base` in the harness's texel buffer
// (`ll_texels`, bound by the entry point; texel (i, j) at base + j·nu + i). Bilinear between
// texel centres ((i+½)/nu, (j+½)/nv): clamped to the edge in u; in v wrapping (`wrap_v`: a
// cylindrical texture around the light) or clamped (a cubemap face). Read through a storage
// buffer, not a sampler: hardware filtering has no WGSL accuracy bound and the CPU evaluator
// could not reproduce it.
fn ll_texel_bilinear(base: u32, nu: u32, nv: u32, u: f32, v: f32, wrap_v: bool) -> f32 {
    let x = clamp(u * f32(nu) - 0.5, 0.0, f32(nu - 1u));
    let i0 = min(u32(floor(x)), nu - 1u);
    let i1 = min(i0 + 1u, nu - 1u);
    let a = x - f32(i0);
    var j0 = 0u;
    var j1 = 0u;
    var b = 0.0;
    if (wrap_v) {
        let y = (v - floor(v)) * f32(nv) - 0.5;
        let f = floor(y);
        j0 = u32(i32(f) + i32(nv)) % nv;
        j1 = (j0 + 1u) % nv;
        b = y - f;
    } else {
        let y = clamp(v * f32(nv) - 0.5, 0.0, f32(nv - 1u));
        j0 = min(u32(floor(y)), nv - 1u);
        j1 = min(j0 + 1u, nv - 1u);
        b = y - f32(j0);
    }
    let t00 = ll_texels[base + j0 * nu + i0];
    let t10 = ll_texels[base + j0 * nu + i1];
    let t01 = ll_texels[base + j1 * nu + i0];
    let t11 = ll_texels[base + j1 * nu + i1];
    return (1.0 - b) * ((1.0 - a) * t00 + a * t10) + b * ((1.0 - a) * t01 + a * t11);
}

// A cubemap light texture's value in direction `w` (the light's frame: X = tex_origin,
// Y = ω_t × tex_origin, Z = ω_t; need not be unit), its six n×n faces from texel `base` in
// Vulkan's order +X, −X, +Y, −Y, +Z, −Z: Vulkan's face selection (ties to X, then Y), then
// the face's bilinear look-up, clamped at its edges.
fn ll_texel_cube(base: u32, n: u32, w: vec3<f32>) -> f32 {
    let a = abs(w);
    var face = 0u;
    var sc = 0.0;
    var tc = 0.0;
    var ma = 0.0;
    if (a.x >= a.y && a.x >= a.z) {
        ma = a.x;
        if (w.x >= 0.0) { face = 0u; sc = -w.z; tc = -w.y; } else { face = 1u; sc = w.z; tc = -w.y; }
    } else if (a.y >= a.z) {
        ma = a.y;
        if (w.y >= 0.0) { face = 2u; sc = w.x; tc = w.z; } else { face = 3u; sc = w.x; tc = -w.z; }
    } else {
        ma = a.z;
        if (w.z >= 0.0) { face = 4u; sc = w.x; tc = -w.y; } else { face = 5u; sc = -w.x; tc = -w.y; }
    }
    return ll_texel_bilinear(base + face * n * n, n, n, 0.5 * (sc / ma + 1.0), 0.5 * (tc / ma + 1.0), false);
}
