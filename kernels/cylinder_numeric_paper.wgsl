//! id: cylinder.numeric_paper
//! target: cylinder
//! source: Heitz & Hill 2017, GPU Zen, Listing 1.2 (with Listing 1.3)
//! minv: full

// Listing 1.2 as published, 20 × 100 samples. Two things in it look wrong and are kept:
// - l = L·j/(n−1) includes both end points (spacing L/(n−1)), yet the weight is
//   2πRL/(nφ·nl), i.e. L/n per sample along the axis: the sum is (n−1)/n times the
//   trapezoid rule plus half the end-point samples, an O(1/n) bias of
//   (L/n)·(mean of the two end columns − mean over the length), relatively.
// - φ = 2π·i/n has no half-sample offset. This one is harmless: for a periodic integrand
//   any offset of the rectangle rule is equally accurate (the max(0, ·) kink limits it).
// Eq. 1.2 above the listing has |−ω_p·ω_n|, the listing max(0, −ω_p·ω_n): the listing is
// the one-sided (front-facing) integral that docs/conventions.md defines as the target; with the
// absolute value the back side, hidden behind the front, would be counted too.
// GLSL `out vec3` parameters are pointers in WGSL (the prelude's buildOrthonormalBasis).
fn I_cylinder_numerical(p1: vec3<f32>, p2: vec3<f32>, R: f32) -> f32 {
    // init orthonormal basis
    let L = length(p2 - p1);
    let wt = normalize(p2 - p1);
    var wt1: vec3<f32>;
    var wt2: vec3<f32>;
    buildOrthonormalBasis(wt, &wt1, &wt2);

    // integral discretization
    var I = 0.0;
    const nSamplesphi = 20;
    const nSamplesl = 100;
    for (var i = 0; i < nSamplesphi; i++) {
        for (var j = 0; j < nSamplesl; j++) {
            // normal
            let phi = 2.0 * PI * f32(i) / f32(nSamplesphi);
            let wn = cos(phi) * wt1 + sin(phi) * wt2;

            // position
            let l = L * f32(j) / f32(nSamplesl - 1);
            let p = p1 + l * wt + R * wn;

            // normalized direction
            let wp = normalize(p);

            // integrate
            I += D(wp) * max(0.0, dot(-wp, wn)) / dot(p, p);
        }
    }

    I *= 2.0 * PI * R * L / f32(nSamplesphi * nSamplesl);
    return I;
}

fn method(scene: Scene) -> f32 {
    return I_cylinder_numerical(scene.p1, scene.p2, scene.radius);
}
