//! id: line.mrp_bisector_nohorizon
//! target: line_isotropic
//! source: seed 002 (Tt Games, "Line lights"): diffuse MRP, bisector form, without the horizon handling (the algorithm as first presented, before "Horizon Handling")
//! minv: diffuse

// line_mrp_bisector.wgsl without the horizon clip: the seed says this "breaks down when the
// segment intersects the plane"; kept to measure by how much.

fn method(scene: Scene) -> f32 {
    let A = scene.p1;
    let AB = scene.p2 - scene.p1;
    let a = length(scene.p1);
    let b = length(scene.p2);
    let x = a / (b + a);
    let X = A + AB * x;
    let d2 = dot(X, X);
    return length(AB) * max(0.0, X.z * inverseSqrt(d2)) / (PI * d2);
}
