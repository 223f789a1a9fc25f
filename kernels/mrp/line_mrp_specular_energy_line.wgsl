//! id: line.mrp_specular_energy_line
//! derive: line.mrp_specular
//! replace: method
//! source: line_mrp_specular_energy.wgsl with the normalization in one dimension, α/α' instead of (α/α')², as UE4-derived engines ship it for line lights (AreaLightSpecular: LobeEnergy *= m / saturate(m + 0.5·LineAngle), LineAngle = saturate(SourceLength/distance): a widening of about half the subtended angle, about twice this kernel's); here with this kernel family's widening sin(half-angle)/2; written from the formula

// A sphere widens the highlight in two directions, hence (α/α')²; a thin segment only along
// itself, hence one factor α/α'.
fn method(scene: Scene) -> f32 {
    var A: vec3<f32>;
    var B: vec3<f32>;
    mrp_clip(scene.p1, scene.p2, &A, &B);
    let R = vec3<f32>(-scene.view.x, -scene.view.y, scene.view.z);
    let X = mrp_specular_point(A, B, R);
    let d2 = dot(X, X);
    // The widening α' − α, as in line_mrp_specular_widened.wgsl.
    let sin_half = 0.5 * length(normalize(A) - normalize(B));
    let w = 0.5 * sin_half;
    let ax = scene.alpha_x;
    let ay = scene.alpha_y;
    // α/α' for one α: the square root of the sphere's (α/α')².
    let energy = sqrt((ax / saturate(ax + w)) * (ay / saturate(ay + w)));
    let f = mrp_ggx(scene.view, X * inverseSqrt(d2), scene.tangent, ax, ay, scene.f0);
    return length(scene.p2 - scene.p1) * f * energy / d2;
}
