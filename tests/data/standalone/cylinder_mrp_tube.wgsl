//! id: cylinder.mrp_tube
//! target: cylinder
//! source: seed 002 (Tt Games, "Line lights", tube light extension): the diffuse MRP (bisector form, horizon handled) moved onto the tube of radius R by similar triangles, the offset clamped to the distance of the point
//! minv: diffuse

// Seed 002 describes the extension in words only: with c the closest point of the segment,
// the ray from the shading point to the representative point X leaves the axis' distance
// ‖c‖ at the origin and 0 at X, so it meets the tube (distance R) R/‖c‖ of the way back
// from X: distance ‖X‖ − min(‖X‖, R·‖X‖/‖c‖) ("clamp the distance ... or we risk selecting
// a point behind the surface"). Shaded as a point light of the tube's broadside intensity:
// a Lambertian tube of unit radiance emits 2R per unit length seen side-on, so 2R·L in all,
// D = cos/π, 1/r² (the seed gives no normalization).

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
    let a = length(PA);
    let b = length(PB);
    let x = a / (b + a);
    return A + AB * x;
}

fn method(scene: Scene) -> f32 {
    let X = mrp_point(scene.p1, scene.p2);
    let ab = scene.p2 - scene.p1;
    let c = scene.p1 + clamp(-dot(scene.p1, ab) / dot(ab, ab), 0.0, 1.0) * ab;
    let dx = length(X);
    let r = dx - min(dx, scene.radius * dx / length(c));
    let I = 2.0 * scene.radius * length(ab);
    return I * max(0.0, X.z / dx) / (PI * r * r);
}
