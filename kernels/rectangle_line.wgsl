//! id: rectangle.line
//! target: rectangle
//! source: Heitz & Hill 2017, GPU Zen, Listing 1.11 (Eq. 1.35), scaled by W/2 as docs/methods.md states
//! minv: full
//! uses: line

// Listing 1.11 as published, with the listing's I_ltc_line(p1, p2) being `I_line`, the
// line method chosen at run time. The listing gives no scale for the width; docs/methods.md
// scales it by the half-width W/2 the way Listing 1.5 scales the line by R: a cylinder of
// radius R and a strip of width W = 2R facing the origin subtend the same width, and the
// factor 2 of Eq. 1.6 is that diameter. W/2 is right (rectangle_line_fixed.wgsl derives it).
// What looks wrong is the orientation factor: ω⊥ = normalize(p1 × p2) is the normal of
// the plane through the origin and the line, so a rectangle whose normal ωn is ω⊥ lies in
// that plane and is seen edge-on (integral 0), yet |ω⊥·ωn| = 1 there; and a strip facing
// the origin (ωn ⟂ ω⊥) gets 0. As W → 0 the target tends to (W/2)·|ω⊥·ωb|·I_line with
// ωb = normalize(ωn × ωt) the width direction, = (W/2)·sqrt(1 − (ω⊥·ωn)²)·I_line: the
// listing has the complementary factor. Kept as published; the fix is rectangle.line_fixed.
// Like the listing, no clamp to 1 (Listing 1.5 clamps the cylinder; 1.11 does not).
fn rect_I_ltc_line_rectangle(p1: vec3<f32>, p2: vec3<f32>, wn: vec3<f32>) -> f32 {
    let wortho = normalize(cross(p1, p2));
    let I = abs(dot(wortho, wn)) * I_line(p1, p2);
    return I;
}

fn method(scene: Scene) -> f32 {
    return 0.5 * scene.rect_width * rect_I_ltc_line_rectangle(scene.p1, scene.p2, scene.rect_normal);
}
