//! id: caps.point
//! target: caps
//! source: Heitz & Hill 2017, GPU Zen, Listing 1.9 (Eqs. 1.33 + 1.34)
//! minv: full

// Listing 1.9 as published: each end disk as a point light of area πR² at its centre.
// The signs agree with Eqs. 1.33/1.34 (max(0, ω_p1·ω_t) at p1, max(0, −ω_t·ω_p2) at p2)
// and with Listing 1.8. WGSL has no unary `+`: the listing's `dot(+wt, wp1)` is written
// `dot(wt, wp1)`.
fn I_ltc_disks(p1: vec3<f32>, p2: vec3<f32>, R: f32) -> f32 {
    let A = PI * R * R;
    let wt = normalize(p2 - p1);
    let wp1 = normalize(p1);
    let wp2 = normalize(p2);
    let Idisks = A * (
        D(wp1) * max(0.0, dot(wt, wp1)) / dot(p1, p1) +
        D(wp2) * max(0.0, dot(-wt, wp2)) / dot(p2, p2));
    return Idisks;
}

fn method(scene: Scene) -> f32 {
    return I_ltc_disks(scene.p1, scene.p2, scene.radius);
}
