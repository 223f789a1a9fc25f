//! id: line.mrp_specular_widened
//! derive: line.mrp_specular
//! replace: method
//! source: line_mrp_specular.wgsl (seed 002) shaded with the lobe widened by the subtended angle, α' = saturate(α + sin(half-angle)/2), after Karis 2013, "Real Shading in Unreal Engine 4", sphere lights, Eq. 10 (radius/(2·distance)); written from the paper's formula

// line_mrp_specular.wgsl with the ggx lobe evaluated at the widened roughness α' (each axis
// widened by the same angle) instead of α: the representative point's lobe spread over the
// light's extent. Karis uses α' inside the energy normalization (line_mrp_specular_energy.wgsl);
// evaluating the lobe at α' is the other reading of "widening", kept apart to measure both.
fn method(scene: Scene) -> f32 {
    var A: vec3<f32>;
    var B: vec3<f32>;
    mrp_clip(scene.p1, scene.p2, &A, &B);
    let R = vec3<f32>(-scene.view.x, -scene.view.y, scene.view.z);
    let X = mrp_specular_point(A, B, R);
    let d2 = dot(X, X);
    // Karis 2013 (sphere lights, Eq. 10): α' = saturate(α + sourceRadius/(2·distance)). For a
    // sphere sourceRadius/distance is the sine of the subtended half-angle; for the (clipped)
    // segment AB we take the sine of the half-angle it subtends, ‖Â − B̂‖/2 (a chord of the
    // unit sphere).
    let sin_half = 0.5 * length(normalize(A) - normalize(B));
    let w = 0.5 * sin_half;
    let ax = saturate(scene.alpha_x + w);
    let ay = saturate(scene.alpha_y + w);
    let f = mrp_ggx(scene.view, X * inverseSqrt(d2), scene.tangent, ax, ay, scene.f0);
    return length(scene.p2 - scene.p1) * f / d2;
}
