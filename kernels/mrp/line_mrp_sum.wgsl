//! id: line.mrp_sum
//! target: line_isotropic_sum
//! source: seed 002 (Tt Games, "Line lights"): "Each point does its part and after evaluating the BRDF we add their contributions together": the diffuse MRP (bisector form) shaded with cos/π plus the specular MRP shaded with the ggx lobe, both with the listing's horizon handling, no normalization
//! minv: ggx

// line_mrp_bisector.wgsl + line_mrp_specular.wgsl in one kernel, against the lobe plus a white
// Lambertian base (target line_isotropic_sum): each point a point light carrying the whole
// light's intensity L.
// Seed 002's horizon handling (lib/mrp_horizon.wgsl): "limit the points A or B
// (depending on the case)" to where the segment crosses the surface's plane.
fn mrp_clip(p1: vec3<f32>, p2: vec3<f32>, a_out: ptr<function, vec3<f32>>, b_out: ptr<function, vec3<f32>>) {
    #include "lib/mrp_horizon.wgsl"
    *a_out = A;
    *b_out = B;
}

// Seed 002's diffuse MRP, bisector form, on the clipped segment (line_mrp_bisector.wgsl).
fn mrp_diffuse_point(A: vec3<f32>, B: vec3<f32>) -> vec3<f32> {
    let AB = B - A;
    let a = length(A);
    let b = length(B);
    let x = a / (b + a);
    return A + AB * x;
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

// The ggx lobe of docs/conventions.md, the cosine-weighted BRDF a point light is shaded with:
// D(ω) = NDF(h)·G2(v, ω)·F(v·h)/(4 v.z) for ω.z > 0, Schlick's F with the scene's f0,
// height-correlated Smith, roughness ax along `tangent` and ay along cross(+z, tangent), in
// the scene's frame.
fn mrp_lambda(w: vec3<f32>, ax: f32, ay: f32) -> f32 {
    let s = (ax * ax * w.x * w.x + ay * ay * w.y * w.y) / (w.z * w.z);
    return 0.5 * (-1.0 + sqrt(1.0 + s));
}

fn mrp_ggx(view: vec3<f32>, dir: vec3<f32>, tangent: vec3<f32>, ax: f32, ay: f32, f0: f32) -> f32 {
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
    // Schlick's F of the material (the BRDF the point is shaded with includes it); f0 = 1
    // without one, so F = 1 + 0·x⁵ = 1 exactly.
    let x = 1.0 - dot(v, h);
    let x2 = x * x;
    let F = f0 + (1.0 - f0) * (x2 * x2 * x);
    return ndf * g2 * F / (4.0 * v.z);
}

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
    let f = mrp_ggx(scene.view, Xs * inverseSqrt(ds2), scene.tangent, scene.alpha_x, scene.alpha_y, scene.f0);
    return diffuse + L * f / ds2;
}
