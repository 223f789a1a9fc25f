//! id: line.mrp_specular
//! target: line_isotropic
//! source: seed 002 (Tt Games, "Line lights", most representative point): specular MRP, the closest point of the segment to the reflection ray, with the listing's horizon handling; shaded as a point light with the ggx lobe (docs/conventions.md), no normalization (the seed gives none)
//! minv: ggx

// The listing gives the point only; like the diffuse ports (line_mrp_intersection.wgsl) it
// is shaded as a point light carrying the whole light's intensity (unit intensity per unit
// length, so L in all, measured before the horizon clip) with the ggx lobe and 1/r². The
// reflection ray is the view mirrored about the normal +z.
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
    let R = vec3<f32>(-scene.view.x, -scene.view.y, scene.view.z);
    let X = mrp_specular_point(A, B, R);
    let d2 = dot(X, X);
    let f = mrp_ggx(scene.view, X * inverseSqrt(d2), scene.tangent, scene.alpha_x, scene.alpha_y, scene.f0);
    return length(scene.p2 - scene.p1) * f / d2;
}
