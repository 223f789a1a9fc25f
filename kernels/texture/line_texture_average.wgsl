//! id: line.texture_average
//! target: line
//! source: ours: the texture averaged over the line, weighted by what each part contributes, times the untextured line integral
//! minv: full
//! uses: line
//! params: TEX_SAMPLES=8

// Ours, not a published formula. One look-up at the closest point misses a texture that varies
// along the light; this tint is the average of the texture over TEX_SAMPLES midpoints of the
// segment, each weighted as the line integral weighs it (D(ω_p)·‖ω_p × ω_t‖/‖p‖², Eq. 1.6),
// and, for a cylindrical texture, around the light over its visible half as the thin tube weighs
// it (max(0, cos(φ − φ₀)): two Gauss nodes in sin(φ − φ₀), at φ₀ ± asin(1/√3)). A cubemap is looked
// up in each midpoint's emission direction. Without a texture the tint is 1.
override TEX_SAMPLES: u32 = 8u;

fn method(scene: Scene) -> f32 {
    let line = I_line(scene.p1, scene.p2);
    if (scene.tex_kind == 0u) {
        return line;
    }
    let ab = scene.p2 - scene.p1;
    let axis = normalize(ab);
    let o = scene.tex_origin;
    let b = cross(axis, o);
    // φ₀: the side of the light facing the shading point (the same for every point of it).
    let facing = -(scene.p1 - dot(scene.p1, axis) * axis);
    let phi0 = atan2(dot(facing, b), dot(facing, o));
    let spread = 0.61547970867038734; // asin(1/√3)
    var sum = 0.0;
    var weights = 0.0;
    for (var k = 0u; k < TEX_SAMPLES; k++) {
        let t = (f32(k) + 0.5) / f32(TEX_SAMPLES);
        let p = scene.p1 + t * ab;
        let r2 = dot(p, p);
        let wp = p * inverseSqrt(r2);
        let weight = D(wp) * length(cross(wp, axis)) / r2;
        var tint = 0.0;
        if (scene.tex_kind == 1u) {
            let v0 = (phi0 - spread) / (2.0 * PI);
            let v1 = (phi0 + spread) / (2.0 * PI);
            tint = 0.5 * (ll_texel_bilinear(scene.tex_offset, scene.tex_nu, scene.tex_nv, t, v0, true)
                + ll_texel_bilinear(scene.tex_offset, scene.tex_nu, scene.tex_nv, t, v1, true));
        } else {
            let e = -wp;
            tint = ll_texel_cube(scene.tex_offset, scene.tex_nu, vec3<f32>(dot(e, o), dot(e, b), dot(e, axis)));
        }
        sum += weight * tint;
        weights += weight;
    }
    if (weights > 0.0) {
        return sum / weights * line;
    }
    return line;
}
