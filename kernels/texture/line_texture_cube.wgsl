//! id: line.texture_cube
//! target: line
//! source: seed 002 (most-representative-point line lights), "Light Textures": a cubemap sampled once, as for a point light at the segment's centre, times the untextured line integral
//! minv: full
//! uses: line

// Seed 002: "use a cubemap and treat it as if it was a point light. Simply calculate the
// center of the segment (before horizon handling) and get vector from shading point to
// center". The cube holds what the light emits in each direction, so it is looked up with the
// direction from the centre to the shading point (the emission direction), in the
// light's frame (X = tex_origin, Y = ω_t × tex_origin, Z = ω_t). One look-up tints the whole
// line. On a scene without a cubemap the tint is 1.
fn method(scene: Scene) -> f32 {
    var tint = 1.0;
    if (scene.tex_kind == 2u) {
        let axis = normalize(scene.p2 - scene.p1);
        let emitted = -0.5 * (scene.p1 + scene.p2);
        let w = vec3<f32>(dot(emitted, scene.tex_origin), dot(emitted, cross(axis, scene.tex_origin)), dot(emitted, axis));
        tint = ll_texel_cube(scene.tex_offset, scene.tex_nu, w);
    }
    return tint * I_line(scene.p1, scene.p2);
}
