//! id: rectangle.line_fixed
//! target: rectangle
//! source: linelight: Listing 1.11 with the rectangle's width direction in place of its normal, scaled by W/2
//! minv: full
//! uses: line

// The thin-rectangle limit. With ωb = normalize(ωn × ωt) the width direction,
//     I_rect = ∫∫ D(ω_p)|ω_p·ωn|/‖p‖² ds dl → W·∫ D(ω_p)|ω_p·ωn|/‖p‖² dl   (W → 0).
// ω_p lies in the plane through the origin and the line, whose normal is
// ω⊥ = normalize(p1 × p2); in the frame (ωt, u = ω⊥ × ωt, ω⊥), ω_p = ±‖ω_p × ωt‖·u +
// (ω_p·ωt)·ωt and ωn ⟂ ωt, so |ω_p·ωn| = ‖ω_p × ωt‖·|u·ωn|, and u·ωn = −ω⊥·(ωn × ωt):
//     lim I_rect/W = |ω⊥·ωb|·∫ D ‖ω_p × ωt‖/‖p‖² dl = |ω⊥·ωb|·I_line/2,
// I_line being Eq. 1.6 (with its factor 2). So I_rect ≈ (W/2)·|ω⊥·ωb|·I_line: the W/2
// scale of docs/methods.md is right, and Listing 1.11's |ω⊥·ωn| must be |ω⊥·ωb|, i.e. the
// listing is correct if its `wn` is read as the width direction instead of the normal.
// |ω⊥·ωb| = sqrt(1 − (ω⊥·ωn)²) when ωn ⟂ ωt. No clamp, as in Listing 1.11.
fn rect_I_line_rectangle_fixed(p1: vec3<f32>, p2: vec3<f32>, wn: vec3<f32>) -> f32 {
    let wortho = normalize(cross(p1, p2));
    let wb = normalize(cross(wn, normalize(p2 - p1)));
    let I = abs(dot(wortho, wb)) * I_line(p1, p2);
    return I;
}

fn method(scene: Scene) -> f32 {
    return 0.5 * scene.rect_width * rect_I_line_rectangle_fixed(scene.p1, scene.p2, scene.rect_normal);
}
