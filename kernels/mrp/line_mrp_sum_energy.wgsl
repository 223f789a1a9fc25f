//! id: line.mrp_sum_energy
//! derive: line.mrp_sum
//! replace: method
//! source: line_mrp_sum.wgsl (seed 002) with the specular term normalized as in line_mrp_specular_energy.wgsl (Karis 2013, Eq. 10 and 14); written from the published formulas

// line_mrp_sum.wgsl with the specular term scaled by Karis's energy normalization (α/α')²,
// as line_mrp_specular_energy.wgsl does (target line_isotropic_sum).
fn method(scene: Scene) -> f32 {
    var A: vec3<f32>;
    var B: vec3<f32>;
    mrp_clip(scene.p1, scene.p2, &A, &B);
    let L = length(scene.p2 - scene.p1);
    let Xd = mrp_diffuse_point(A, B);
    let dd2 = dot(Xd, Xd);
    let diffuse = L * max(0.0, Xd.z * inverseSqrt(dd2)) / (PI * dd2);
    let R = vec3<f32>(-scene.view.x, -scene.view.y, scene.view.z);
    let Xs = mrp_specular_point(A, B, R);
    let ds2 = dot(Xs, Xs);
    // Karis 2013 (sphere lights, Eq. 10): α' = saturate(α + sourceRadius/(2·distance)), with
    // the sine of the half-angle the clipped segment subtends, ‖Â − B̂‖/2; Eq. 14: (α/α')².
    let sin_half = 0.5 * length(normalize(A) - normalize(B));
    let w = 0.5 * sin_half;
    let energy = (scene.alpha_x / saturate(scene.alpha_x + w)) * (scene.alpha_y / saturate(scene.alpha_y + w));
    let f = energy * mrp_ggx(scene.view, Xs * inverseSqrt(ds2), scene.tangent, scene.alpha_x, scene.alpha_y, scene.f0);
    return diffuse + L * f / ds2;
}
