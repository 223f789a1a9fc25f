//! id: line.mrp_intersection
//! target: line_isotropic
//! source: seed 002 (Tt Games, "Line lights", most representative point after Drobot, GPU Pro 5 II.1): diffuse MRP, intersection form, with the listing's horizon handling
//! minv: diffuse

// Ported from seed 002 operation for operation (HLSL → WGSL; P is the origin here).
// The listing gives only the representative point; the light is then shaded "as a point
// light": the whole line (unit intensity per unit length, so L in all, L measured before
// the horizon clip) at that point, with D = cos/π and the 1/r² falloff. The seed gives no
// normalization of its own.

fn mrp_point(p1: vec3<f32>, p2: vec3<f32>) -> vec3<f32> {
    var A = p1;
    var B = p2;
    var PA = A;
    var PB = B;
    var AB = B - A;
    // Horizon handling: "If points are on opposite sides, guaranteed intersection".
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
    // Intersection of the half vector with the line (RTR 3rd ed., p. 782).
    let H = normalize(PA) + normalize(PB);
    let perpendicularVector = cross(H, AB);
    // HLSL float3x3(PA, AB, perp) takes rows; the determinant is the same for columns.
    let m = mat3x3<f32>(PA, AB, perpendicularVector);
    let s = determinant(m) / dot(perpendicularVector, perpendicularVector);
    return H * s;
}

fn method(scene: Scene) -> f32 {
    let X = mrp_point(scene.p1, scene.p2);
    let d2 = dot(X, X);
    return length(scene.p2 - scene.p1) * max(0.0, X.z * inverseSqrt(d2)) / (PI * d2);
}
