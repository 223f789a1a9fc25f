//! id: line.mrp_specular_energy
//! derive: line.mrp_specular
//! replace: method
//! source: line_mrp_specular.wgsl (seed 002) with Karis 2013's "energy normalization", "Real Shading in Unreal Engine 4", sphere lights, Eq. 14: the lobe at α times (α/α')², α' = saturate(α + sourceRadius/(2·distance)) (Eq. 10) with the segment's subtended half-angle; written from the paper's formulas

// The representative point's lobe keeps its roughness α; its peak is scaled by the ratio of
// the GGX normalizations 1/(π α²) before and after widening, (α/α')², so that a widened
// highlight does not gain energy (Karis: "divide the new widened normalization factor by the
// original").
fn method(scene: Scene) -> f32 {
    var A: vec3<f32>;
    var B: vec3<f32>;
    mrp_clip(scene.p1, scene.p2, &A, &B);
    let R = vec3<f32>(-scene.view.x, -scene.view.y, scene.view.z);
    let X = mrp_specular_point(A, B, R);
    let d2 = dot(X, X);
    // The widening α' − α, as in line_mrp_specular_widened.wgsl (Karis 2013, Eq. 10, with the
    // sine of the half-angle the clipped segment subtends).
    let sin_half = 0.5 * length(normalize(A) - normalize(B));
    let w = 0.5 * sin_half;
    let ax = scene.alpha_x;
    let ay = scene.alpha_y;
    // (α/α')² for one α; for two, the product of the per-axis ratios (the NDF's 1/(ax·ay)).
    let energy = (ax / saturate(ax + w)) * (ay / saturate(ay + w));
    let f = mrp_ggx(scene.view, X * inverseSqrt(d2), scene.tangent, ax, ay, scene.f0);
    return length(scene.p2 - scene.p1) * f * energy / d2;
}
