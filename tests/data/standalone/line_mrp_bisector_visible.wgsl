//! id: line.mrp_bisector_visible
//! target: line_isotropic
//! source: linelight: line_mrp_bisector.wgsl (seed 002) shading only the part above the horizon: the point light's intensity is the clipped segment's length, not the whole light's
//! minv: diffuse

// The seed clips the segment to the horizon to place the point but says nothing of its
// intensity; the published-form kernels keep the whole light's. Here the light below the
// surface, which contributes nothing, is left out of the intensity too.

fn mrp_point(p1: vec3<f32>, p2: vec3<f32>, visible: ptr<function, f32>) -> vec3<f32> {
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
    // Bisector theorem: a / b = x / y with x + y = |AB|, so x = a/(a + b) of AB.
    let a = length(PA);
    let b = length(PB);
    let x = a / (b + a);
    *visible = length(AB);
    return A + AB * x;
}

fn method(scene: Scene) -> f32 {
    var visible = 0.0;
    let X = mrp_point(scene.p1, scene.p2, &visible);
    let d2 = dot(X, X);
    return visible * max(0.0, X.z * inverseSqrt(d2)) / (PI * d2);
}
