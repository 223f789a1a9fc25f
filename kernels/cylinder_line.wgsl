//! id: cylinder.line
//! target: cylinder
//! source: Heitz & Hill 2017, GPU Zen, Listing 1.5 (Eq. 1.10 clamped by Eq. 1.11)
//! minv: full
//! uses: line

// Listing 1.5: the cylinder integral approximated by R times the line integral of its
// axis, clamped to 1 (the integral of a normalized D over the sphere). `I_line` is the
// line method chosen at run time (`cylinder.line[line.ltc2023]`).
// The published signature `float I_cylinder_approx(vec3 p1, float p2, float R)` declares
// p2 as a float: a typo (it is passed to I_line as the second end point), so vec3 here.
fn I_cylinder_approx(p1: vec3<f32>, p2: vec3<f32>, R: f32) -> f32 {
    return min(1.0, R * I_line(p1, p2));
}

fn method(scene: Scene) -> f32 {
    return I_cylinder_approx(scene.p1, scene.p2, scene.radius);
}
