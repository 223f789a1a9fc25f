//! id: line.mrp_bisector
//! target: line_isotropic
//! source: seed 002 (Tt Games, "Line lights", most representative point): diffuse MRP, bisector (angle bisector theorem) form, with the listing's horizon handling
//! minv: diffuse

// Ported from seed 002; shaded as in line_mrp_intersection.wgsl (the whole line, L, as a
// point light at the representative point, D = cos/π, 1/r²).

fn mrp_point(p1: vec3<f32>, p2: vec3<f32>) -> vec3<f32> {
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
    return A + AB * x;
}

fn method(scene: Scene) -> f32 {
    let X = mrp_point(scene.p1, scene.p2);
    let d2 = dot(X, X);
    return length(scene.p2 - scene.p1) * max(0.0, X.z * inverseSqrt(d2)) / (PI * d2);
}
