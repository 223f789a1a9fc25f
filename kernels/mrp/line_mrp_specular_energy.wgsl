//! id: line.mrp_specular_energy
//! target: line_isotropic
//! source: line_mrp_specular.wgsl (seed 002) with Karis 2013's "energy normalization", "Real Shading in Unreal Engine 4", sphere lights, Eq. 14: the lobe at α times (α/α')², α' = saturate(α + sourceRadius/(2·distance)) (Eq. 10) with the segment's subtended half-angle; written from the paper's formulas
//! minv: ggx

// The representative point's lobe keeps its roughness α; its peak is scaled by the ratio of
// the GGX normalizations 1/(π α²) before and after widening, (α/α')², so that a widened
// highlight does not gain energy (Karis: "divide the new widened normalization factor by the
// original").
// Seed 002's horizon handling, as in line_mrp_bisector.wgsl: "limit the points A or B
// (depending on the case)" to where the segment crosses the surface's plane.
fn mrp_clip(p1: vec3<f32>, p2: vec3<f32>, a_out: ptr<function, vec3<f32>>, b_out: ptr<function, vec3<f32>>) {
    var A = p1;
    var B = p2;
    var PA = A;
    var PB = B;
    var AB = B - A;
    let N = vec3<f32>(0.0, 0.0, 1.0);
    if ((dot(PA, N) > 0.0) != (dot(PB, N) > 0.0)) {
        let t = -dot(PA, N) / dot(AB, N);
        let intersectionPoint = A + t * AB;
        if (dot(PA, N) > 0.0) {
            B = intersectionPoint;
            PB = B;
        } else {
            A = intersectionPoint;
            PA = A;
        }
        AB = B - A;
    }
    *a_out = A;
    *b_out = B;
}

// Seed 002's specular MRP: the closest point of segment AB to the reflection ray R from P
// (R unit, so dot(R, R) = 1 "can be optimized away"), operation for operation.
fn mrp_specular_point(A: vec3<f32>, B: vec3<f32>, R: vec3<f32>) -> vec3<f32> {
    let PA = A;
    let AB = B - A;
    let t_num = dot(R, PA) * dot(AB, R) - dot(AB, PA);
    let t_denom = dot(AB, AB) - dot(AB, R) * dot(AB, R);
    let t = saturate(t_num / t_denom);
    return A + AB * t;
}

// DESIGN §1's ggx lobe, the cosine-weighted BRDF a point light is shaded with (F = 1):
// D(ω) = NDF(h)·G2(v, ω)/(4 v.z) for ω.z > 0, height-correlated Smith, roughness ax along
// `tangent` and ay along cross(+z, tangent), in the scene's frame.
fn mrp_lambda(w: vec3<f32>, ax: f32, ay: f32) -> f32 {
    let s = (ax * ax * w.x * w.x + ay * ay * w.y * w.y) / (w.z * w.z);
    return 0.5 * (-1.0 + sqrt(1.0 + s));
}

fn mrp_ggx(view: vec3<f32>, dir: vec3<f32>, tangent: vec3<f32>, ax: f32, ay: f32) -> f32 {
    if (dir.z <= 0.0) {
        return 0.0;
    }
    let bitangent = vec3<f32>(-tangent.y, tangent.x, 0.0);
    let v = vec3<f32>(dot(view, tangent), dot(view, bitangent), view.z);
    let w = vec3<f32>(dot(dir, tangent), dot(dir, bitangent), dir.z);
    let h = normalize(v + w);
    let e = (h.x / ax) * (h.x / ax) + (h.y / ay) * (h.y / ay) + h.z * h.z;
    let ndf = 1.0 / (PI * ax * ay * e * e);
    let g2 = 1.0 / (1.0 + mrp_lambda(v, ax, ay) + mrp_lambda(w, ax, ay));
    return ndf * g2 / (4.0 * v.z);
}

// Karis 2013 (Real Shading in Unreal Engine 4, sphere lights, Eq. 10): the lobe widened by
// the angle the light subtends, α' = saturate(α + sourceRadius/(2·distance)). For a sphere
// sourceRadius/distance is the sine of the subtended half-angle; for the (clipped) segment AB
// we take the sine of the half-angle it subtends, ‖Â − B̂‖/2 (a chord of the unit sphere).
fn mrp_widening(A: vec3<f32>, B: vec3<f32>) -> f32 {
    let sin_half = 0.5 * length(normalize(A) - normalize(B));
    return 0.5 * sin_half;
}

fn method(scene: Scene) -> f32 {
    var A: vec3<f32>;
    var B: vec3<f32>;
    mrp_clip(scene.p1, scene.p2, &A, &B);
    let R = vec3<f32>(-scene.view.x, -scene.view.y, scene.view.z);
    let X = mrp_specular_point(A, B, R);
    let d2 = dot(X, X);
    let w = mrp_widening(A, B);
    let ax = scene.alpha_x;
    let ay = scene.alpha_y;
    // (α/α')² for one α; for two, the product of the per-axis ratios (the NDF's 1/(ax·ay)).
    let energy = (ax / saturate(ax + w)) * (ay / saturate(ay + w));
    let f = mrp_ggx(scene.view, X * inverseSqrt(d2), scene.tangent, ax, ay);
    return length(scene.p2 - scene.p1) * f * energy / d2;
}
