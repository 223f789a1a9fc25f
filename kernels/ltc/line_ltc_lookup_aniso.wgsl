//! id: line.ltc_lookup_aniso
//! target: line
//! source: ours: our anisotropic GGX LTC table (seed 004's 4D table, data/ltc_ggx_aniso.csv) looked up on the device: the reduction to the table's domain (Eqs. 13–14), quadrilinear filtering, M inverted; then the inner LTC line method times the Fresnel-weighted magnitude
//! minv: ggx
//! uses: line

// The device side of the `aniso` feed (src/input/ltc/aniso.rs, `AnisoTable::sample` with f32
// texels, turned into the scene's frame as `ltc::feed_aniso` turns it), written from seed 004's
// description as that is: the view taken into the roughness frame (x along `tangent`), reduced by
// the lobe's mirror symmetries and the axis swap (a signed permutation Q, Eqs. 13 and 14) to
// θ ∈ [0, π/2), φ ∈ [0, π/2], α_max, r = α_min/α_max ≤ 1; texel coordinates in f32, clamped to
// the edges; the 16 corners weighted by products of f32 lerp factors (3D-texture trilinear
// filtering plus one lerp, as the host writes it); M inverted by adjugate and determinant, each
// entry divided; M⁻¹ = Qᵀ·M_red⁻¹·Q; then into the scene's frame. Read from the harness's LTC
// tables (`ll_ltc`, layout in src/input/ltc/device.rs) instead of three RGBA textures.

struct LtcAnisoFeed {
    minv: mat3x3<f32>,
    magnitude: f32,
    fresnel: f32,
}

// Entry (iθ, iφ, iα, ir) of a table of `size`, channel k (M row-major, magnitude, Fresnel).
fn ltc_aniso_texel(base: u32, size: vec4<u32>, i: vec4<u32>, k: u32) -> f32 {
    let index = ((i.x * size.y + i.y) * size.z + i.z) * size.w + i.w;
    return ll_ltc[base + 11u * index + k];
}

// The look-up for roughness (αx, αy) and a unit view (vz > 0), both in the roughness frame:
// M⁻¹ in that frame, the magnitude and the Fresnel term.
fn ltc_aniso_lookup(alpha: vec2<f32>, view: vec3<f32>) -> LtcAnisoFeed {
    // The reduction (Eqs. 13, 14): Q takes the view into the table's quadrant, ω_red = Q·ω.
    var vx = view.x;
    var vy = view.y;
    var sx = 1.0;
    var sy = 1.0;
    if (vy < 0.0) {
        vy = -vy;
        sy = -1.0;
    }
    if (vx < 0.0) {
        vx = -vx;
        sx = -1.0;
    }
    var ax = alpha.x;
    var ay = alpha.y;
    // Rows of Q.
    var q0 = vec3<f32>(sx, 0.0, 0.0);
    var q1 = vec3<f32>(0.0, sy, 0.0);
    if (ay > ax) {
        let a = ax;
        ax = ay;
        ay = a;
        let v = vx;
        vx = vy;
        vy = v;
        let q = q0;
        q0 = q1;
        q1 = q;
    }
    let coords = vec4<f32>(acos(clamp(view.z, -1.0, 1.0)), atan2(vy, vx), ax, ay / ax);
    let base = u32(ll_ltc[2]);
    let size = vec4<u32>(u32(ll_ltc[3]), u32(ll_ltc[4]), u32(ll_ltc[5]), u32(ll_ltc[6]));
    let lo_edge = vec4<f32>(0.0, 0.0, ll_ltc[9], ll_ltc[10]);
    let hi_edge = vec4<f32>(ll_ltc[7], ll_ltc[8], 1.0, 1.0);
    var lo: vec4<u32>;
    var frac: vec4<f32>;
    for (var k = 0u; k < 4u; k++) {
        let top = f32(size[k] - 1u);
        let pos = clamp((coords[k] - lo_edge[k]) / (hi_edge[k] - lo_edge[k]) * top, 0.0, top);
        let i = min(u32(floor(pos)), size[k] - 2u);
        lo[k] = i;
        frac[k] = pos - f32(i);
    }
    var acc: array<f32, 11>;
    for (var corner = 0u; corner < 16u; corner++) {
        var idx = lo;
        var w = 1.0;
        for (var k = 0u; k < 4u; k++) {
            if (((corner >> k) & 1u) == 1u) {
                idx[k] += 1u;
                w *= frac[k];
            } else {
                w *= 1.0 - frac[k];
            }
        }
        if (w == 0.0) {
            continue;
        }
        for (var c = 0u; c < 11u; c++) {
            acc[c] += w * ltc_aniso_texel(base, size, idx, c);
        }
    }
    // M_red⁻¹ by adjugate and determinant (row-major m[r][c] = acc[3r + c]), each entry divided.
    let adj00 = acc[4] * acc[8] - acc[5] * acc[7];
    let adj01 = -(acc[1] * acc[8] - acc[2] * acc[7]);
    let adj02 = acc[1] * acc[5] - acc[2] * acc[4];
    let adj10 = -(acc[3] * acc[8] - acc[5] * acc[6]);
    let adj11 = acc[0] * acc[8] - acc[2] * acc[6];
    let adj12 = -(acc[0] * acc[5] - acc[2] * acc[3]);
    let adj20 = acc[3] * acc[7] - acc[4] * acc[6];
    let adj21 = -(acc[0] * acc[7] - acc[1] * acc[6]);
    let adj22 = acc[0] * acc[4] - acc[1] * acc[3];
    let det = acc[0] * adj00 + acc[1] * adj10 + acc[2] * adj20;
    let red = mat3x3<f32>(
        vec3<f32>(adj00 / det, adj10 / det, adj20 / det),
        vec3<f32>(adj01 / det, adj11 / det, adj21 / det),
        vec3<f32>(adj02 / det, adj12 / det, adj22 / det),
    );
    // Q as columns (its rows q0, q1, z): M⁻¹ = Qᵀ·M_red⁻¹·Q, exact (a signed permutation).
    let q = transpose(mat3x3<f32>(q0, q1, vec3<f32>(0.0, 0.0, 1.0)));
    return LtcAnisoFeed(transpose(q) * red * q, acc[9], acc[10]);
}

// The feed of this scene: the view in the roughness frame (x along `tangent`, y along
// cross(+z, tangent)), looked up, and M⁻¹ turned back into the scene's frame (ω_rough = R·ω with
// R's rows tangent, cross(+z, tangent), +z).
fn ltc_aniso_feed(scene: Scene) -> LtcAnisoFeed {
    let t = scene.tangent;
    let b = vec3<f32>(-t.y, t.x, 0.0);
    let view = vec3<f32>(dot(scene.view, t), dot(scene.view, b), scene.view.z);
    var feed = ltc_aniso_lookup(vec2<f32>(scene.alpha_x, scene.alpha_y), view);
    let r = transpose(mat3x3<f32>(t, b, vec3<f32>(0.0, 0.0, 1.0)));
    feed.minv = feed.minv * r;
    return feed;
}

fn method(scene: Scene) -> f32 {
    let feed = ltc_aniso_feed(scene);
    Minv = feed.minv;
    let weight = scene.f0 * feed.magnitude + (1.0 - scene.f0) * feed.fresnel;
    return I_line(scene.p1, scene.p2) * weight;
}
