// linelight scan: configurations generated on the GPU from the seed, the method evaluated on
// each, and only counts (and the first offending configurations) written back. Appended to a
// composed method kernel; bindings 3–5 of group 0 (the sweep entry point has 0–2), names `ll_`-reserved.
//
// The stream: uniform k of configuration i of family f is
//   pcg4d(i_lo, i_hi, seed_lo ^ f·0x9E3779B9, seed_hi ^ k·0x85EBCA6B).x / 2³²  (24 bits kept),
// a counter-based generator (Jarzynski & Olano 2020, "Hash Functions for GPU Rendering"), so
// every configuration is a pure function of (seed, family, index): a different stream from the
// CPU sampler's ChaCha8, documented in docs/scan.md.

struct LlScanParams {
    base_lo: u32,
    base_hi: u32,
    count: u32,
    family: u32,
    seed_lo: u32,
    seed_hi: u32,
    material: u32,   // 0 diffuse, 1 ltc_sparse, 2 ltc_full
    capture: u32,    // capture slots
    bound: f32,      // values above it count (when has_bound)
    has_bound: u32,
    trip_limit: u32, // loop trips that count as cut short by the driver (0: not counted)
    pad1: u32,
    // (kind, a, b, default): kind 0 fixed a, 1 uniform [a, b], 2 log-uniform, 3 signed
    // log-uniform, 4 absent (the default). Slots: see LL_* below.
    dists: array<vec4<f32>, 16>,
}

struct LlCaptured {
    p1: vec4<f32>,
    p2: vec4<f32>,
    r0: vec4<f32>,
    r1: vec4<f32>,
    r2: vec4<f32>,
    index_lo: u32,
    index_hi: u32,
    value: f32,
    why: u32,        // 1 NaN, 2 inf, 3 negative, 4 above the bound, 5 above the light's bound
}

@group(0) @binding(3) var<uniform> ll_scan: LlScanParams;
// nan, inf, negative, above, captured, cut short by the driver's loop limit, degenerate (skipped),
// above the light's bound
@group(0) @binding(4) var<storage, read_write> ll_counts: array<atomic<u32>, 8>;
@group(0) @binding(5) var<storage, read_write> ll_captured: array<LlCaptured>;
// Loop-body executions of this invocation, when the method's loops are counted (gpu/loops.rs).
var<private> ll_trips: u32;

const LL_DISTANCE: u32 = 0u;
const LL_ELEVATION: u32 = 1u;
const LL_AZIMUTH: u32 = 2u;
const LL_TILT: u32 = 3u;
const LL_LENGTH: u32 = 4u;
const LL_CENTER: u32 = 5u;
const LL_ENDPOINT_HEIGHT: u32 = 6u;
const LL_ALPHA: u32 = 7u;
const LL_ASPECT: u32 = 8u;
const LL_PEAK: u32 = 9u;
const LL_SHEAR: u32 = 10u;
const LL_ROTATION: u32 = 11u;

fn ll_pcg4d(v_in: vec4<u32>) -> vec4<u32> {
    var v = v_in * 1664525u + 1013904223u;
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    v = v ^ (v >> vec4<u32>(16u));
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    return v;
}

fn ll_unit(lo: u32, hi: u32, k: u32) -> f32 {
    let h = ll_pcg4d(vec4<u32>(lo, hi, ll_scan.seed_lo ^ (ll_scan.family * 0x9E3779B9u), ll_scan.seed_hi ^ (k * 0x85EBCA6Bu)));
    return f32(h.x >> 8u) * (1.0 / 16777216.0);
}

fn ll_draw(slot: u32, lo: u32, hi: u32) -> f32 {
    let d = ll_scan.dists[slot];
    let u = ll_unit(lo, hi, slot);
    let kind = u32(d.x);
    if (kind == 0u) {
        return d.y;
    }
    if (kind == 1u) {
        return d.y + (d.z - d.y) * u;
    }
    if (kind == 2u) {
        return exp(log(d.y) + (log(d.z) - log(d.y)) * u);
    }
    if (kind == 3u) {
        var s = 1.0;
        var v = 2.0 * u - 1.0;
        if (u < 0.5) {
            s = -1.0;
            v = 2.0 * u;
        }
        return s * exp(log(d.y) + (log(d.z) - log(d.y)) * v);
    }
    return d.w;
}

fn ll_deg(x: f32) -> f32 {
    return x * (PI / 180.0);
}

// The sampler's geometry (src/input/sampler.rs, `sample_one`), in f32.
fn ll_generate(lo: u32, hi: u32) -> Scene {
    let d = ll_draw(LL_DISTANCE, lo, hi);
    let el = ll_deg(ll_draw(LL_ELEVATION, lo, hi));
    let az = ll_deg(ll_draw(LL_AZIMUTH, lo, hi));
    let tilt = ll_deg(ll_draw(LL_TILT, lo, hi));
    let len = ll_draw(LL_LENGTH, lo, hi);
    let center = ll_draw(LL_CENTER, lo, hi);
    let w_po = vec3<f32>(cos(el) * cos(az), cos(el) * sin(az), sin(el));
    let h = vec3<f32>(-sin(az), cos(az), 0.0);
    let v = cross(w_po, h);
    let w_t = h * cos(tilt) + v * sin(tilt);
    let p_o = w_po * d;
    let half_len = 0.5 * len * d;
    var s: Scene;
    s.p1 = p_o + w_t * (center * d - half_len);
    s.p2 = p_o + w_t * (center * d + half_len);
    if (u32(ll_scan.dists[LL_ENDPOINT_HEIGHT].x) != 4u) {
        s.p2.z = ll_draw(LL_ENDPOINT_HEIGHT, lo, hi) * d;
    }
    s.radius = 0.0;
    s.rect_width = 0.0;
    s.rect_normal = vec3<f32>(0.0);
    s.flags = 0u;
    var r0 = vec3<f32>(1.0, 0.0, 0.0);
    var r1 = vec3<f32>(0.0, 1.0, 0.0);
    var r2 = vec3<f32>(0.0, 0.0, 1.0);
    if (ll_scan.material != 0u) {
        s.flags = FLAG_LTC;
        let alpha = ll_draw(LL_ALPHA, lo, hi);
        let aspect = ll_draw(LL_ASPECT, lo, hi);
        let peak = ll_deg(ll_draw(LL_PEAK, lo, hi));
        let shear = ll_draw(LL_SHEAR, lo, hi);
        let a = aspect / alpha;
        r0 = vec3<f32>(a, 0.0, -a * tan(peak));
        r1 = vec3<f32>(0.0, 1.0 / alpha, 0.0);
        r2 = vec3<f32>(shear, 0.0, 1.0);
        if (ll_scan.material == 2u) {
            // M⁻¹·R_z(r): the lobe turned by r about the normal.
            let r = ll_deg(ll_draw(LL_ROTATION, lo, hi));
            let c = cos(r);
            let sn = sin(r);
            let rz = transpose(mat3x3<f32>(vec3<f32>(c, -sn, 0.0), vec3<f32>(sn, c, 0.0), vec3<f32>(0.0, 0.0, 1.0)));
            let m = transpose(mat3x3<f32>(r0, r1, r2)) * rz;
            let t = transpose(m);
            r0 = t[0];
            r1 = t[1];
            r2 = t[2];
        }
    }
    // mat3x3 takes columns: the transpose of the rows is M⁻¹.
    s.minv = transpose(mat3x3<f32>(r0, r1, r2));
    return s;
}

// f32 bits of 2^60 and 2^-60: the sizes the sweep's configurations must lie within
// (src/input/scene.rs, F32_SCALE). Compared as bits: NaN and inf fail, whatever a compiler
// assumes of comparisons with NaN.
const LL_BIG: u32 = 0x5D800000u;
const LL_SMALL: u32 = 0x21800000u;

fn ll_within(x: f32, lo: u32, hi: u32) -> bool {
    let b = bitcast<u32>(abs(x));
    return b >= lo && b <= hi;
}

fn ll_entries(v: vec3<f32>) -> bool {
    return ll_within(v.x, 0u, LL_BIG) && ll_within(v.y, 0u, LL_BIG) && ll_within(v.z, 0u, LL_BIG);
}

// A configuration the sweep's sampler would redraw (src/input/scene.rs, `validate`): not
// representable in f32 (size outside 2^±60, an M⁻¹ entry above 2^60), the shading point on the
// segment, or a singular M⁻¹. Its value would be the generator's failure, not the method's.
fn ll_degenerate(s: Scene) -> bool {
    let size = max(length(s.p1), length(s.p2));
    if (!ll_within(size, LL_SMALL, LL_BIG)) {
        return true;
    }
    let m = s.minv;
    if (!(ll_entries(m[0]) && ll_entries(m[1]) && ll_entries(m[2]))) {
        return true;
    }
    let e = s.p2 - s.p1;
    let ee = dot(e, e);
    if (!(ee > 0.0)) {
        return true;
    }
    let t = clamp(-dot(s.p1, e) / ee, 0.0, 1.0);
    if (!(length(s.p1 + t * e) > 1e-12 * size)) {
        return true;
    }
    let det = determinant(s.minv);
    return !ll_within(det, 1u, 0x7F7FFFFFu);
}

// The light's bound B (docs/scan.md), an upper bound on `line` and `line_upper` whatever the
// method: the same light with D replaced by an upper bound D̂ of its maximum, and the segment's
// geometric factor ∫ 2‖ω_p × ω_t‖/‖p‖² dl bounded by 2L/r², r the distance from the shading point
// to the segment (taken a hair short for f32 rounding). D̂ = 1/π for the diffuse material; for an
// LTC, D ≤ |det M⁻¹|/(π σ_min(M⁻¹)³) and σ_min(M⁻¹) is bounded below two ways: by
// |det|/‖adj M⁻¹‖_F (as ‖M‖₂ ≤ ‖M‖_F) and by 2|det|/‖M⁻¹‖_F² (as σ₁σ₂ ≤ (σ₁² + σ₂²)/2); the larger
// is kept. Returns 0 where no bound is computed (r rounds to 0): nothing is counted then. A value
// counts above it past 1.001·B, so f32 rounding of a value at the bound is not counted.
fn ll_light_bound(s: Scene) -> f32 {
    let e = s.p2 - s.p1;
    let len = length(e);
    let t = clamp(-dot(s.p1, e) / dot(e, e), 0.0, 1.0);
    let size = max(length(s.p1), length(s.p2));
    let r = length(s.p1 + t * e) - 1e-6 * size;
    if (!(r > 0.0)) {
        return 0.0;
    }
    var d_max = 1.0 / PI;
    if (ll_scan.material != 0u) {
        let m = s.minv;
        let det = abs(determinant(m));
        // The adjugate's rows are the cross products of M⁻¹'s columns.
        let a0 = cross(m[1], m[2]);
        let a1 = cross(m[2], m[0]);
        let a2 = cross(m[0], m[1]);
        let adj_f = sqrt(dot(a0, a0) + dot(a1, a1) + dot(a2, a2));
        let f2 = dot(m[0], m[0]) + dot(m[1], m[1]) + dot(m[2], m[2]);
        let sigma = max(det / adj_f, 2.0 * det / f2);
        d_max = det / (PI * sigma * sigma * sigma);
    }
    return d_max * 2.0 * len / (r * r);
}

@compute @workgroup_size(64)
fn ll_scan_main(@builtin(global_invocation_id) ll_id: vec3<u32>) {
    let ll_i = ll_id.x;
    if (ll_i >= ll_scan.count) {
        return;
    }
    let lo = ll_scan.base_lo + ll_i;
    let hi = ll_scan.base_hi + select(0u, 1u, lo < ll_scan.base_lo);
    {scene} = ll_generate(lo, hi);
    if (ll_degenerate(ll_scene)) {
        atomicAdd(&ll_counts[6], 1u);
        return;
    }
    Minv = ll_scene.minv;
    let value = method(ll_scene);
    if (ll_scan.trip_limit != 0u && ll_trips >= ll_scan.trip_limit) {
        atomicAdd(&ll_counts[5], 1u);
        return;
    }
    // NaN and inf from the bits: a compiler may assume comparisons see no NaN.
    let bits = bitcast<u32>(value);
    let special = (bits & 0x7f800000u) == 0x7f800000u;
    var why = 0u;
    if (special && (bits & 0x007fffffu) != 0u) {
        why = 1u;
    } else if (special) {
        why = 2u;
    } else if (value < 0.0) {
        why = 3u;
    } else if (ll_scan.has_bound != 0u && value > ll_scan.bound) {
        why = 4u;
    } else {
        let b = ll_light_bound(ll_scene);
        if (b > 0.0 && value > 1.001 * b) {
            why = 5u;
        }
    }
    if (why == 0u) {
        return;
    }
    atomicAdd(&ll_counts[select(why - 1u, 7u, why == 5u)], 1u);
    let slot = atomicAdd(&ll_counts[4], 1u);
    if (slot < ll_scan.capture) {
        let m = transpose(ll_scene.minv);
        ll_captured[slot] = LlCaptured(vec4<f32>(ll_scene.p1, 0.0), vec4<f32>(ll_scene.p2, 0.0), vec4<f32>(m[0], 0.0), vec4<f32>(m[1], 0.0), vec4<f32>(m[2], 0.0), lo, hi, value, why);
    }
}
