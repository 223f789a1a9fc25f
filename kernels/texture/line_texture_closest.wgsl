//! id: line.texture_closest
//! target: line
//! source: seed 002 (most-representative-point line lights), "Light Textures": a cylindrical texture sampled once, at the closest point of the line to the shading point, times the untextured line integral
//! minv: full
//! uses: line

// Seed 002: "calculate the closest point from the shaded pixel to the line light, and use
// that to sample the texture". The closest point is clamped to the segment, as a user expects
// (u = its t in [0, 1]); the texture is looked up around the light in the direction of the
// vector from that point to the shading point (its angle φ about ω_t from `tex_origin`). One
// look-up tints the whole line: the untextured `I_line` of any inner line method times it.
// On a scene without a cylindrical texture the tint is 1.
fn method(scene: Scene) -> f32 {
    let ab = scene.p2 - scene.p1;
    var tint = 1.0;
    if (scene.tex_kind == 1u) {
        let t = clamp(dot(-scene.p1, ab) / dot(ab, ab), 0.0, 1.0);
        let to_point = -(scene.p1 + t * ab);
        let b = cross(normalize(ab), scene.tex_origin);
        let phi = atan2(dot(to_point, b), dot(to_point, scene.tex_origin));
        tint = ll_texel_bilinear(scene.tex_offset, scene.tex_nu, scene.tex_nv, t, phi / (2.0 * PI), true);
    }
    return tint * I_line(scene.p1, scene.p2);
}
