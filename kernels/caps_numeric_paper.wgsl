//! id: caps.numeric_paper
//! target: caps
//! source: Heitz & Hill 2017, GPU Zen, Listing 1.8 (with Listing 1.3)
//! minv: full

// Listing 1.8 as published, 20 × 200 samples over both end disks. Kept as printed:
// - r = R·j/(n−1) includes r = 0 and r = R (spacing R/(n−1)), weighted R/n: exact when
//   D(ω_p)/‖p‖²·cos is constant over the disk (the r factor makes the end-point error and
//   the (n−1)/n factor cancel), otherwise an O(1/n) bias.
// - φ = 2π·i/n without a half-sample offset (harmless for a periodic integrand).
// Signs: the disk at p1 (outward normal −ω_t) is weighted max(0, ω_p·ω_t), the disk at p2
// (outward normal +ω_t) max(0, ω_p·(−ω_t)), as the text says ("one-sided disks ... with
// normals −ω_t and ω_t") and as Listing 1.9 and Eqs. 1.32–1.34 have it. Only Eq. 1.29
// above the listing differs: it writes |ω_p·ω_t| (two-sided). `L` is computed and never
// used, as in the listing.
fn I_disks_numerical(p1: vec3<f32>, p2: vec3<f32>, R: f32) -> f32 {
    // init orthonormal basis
    let L = length(p2 - p1);
    let wt = normalize(p2 - p1);
    var wt1: vec3<f32>;
    var wt2: vec3<f32>;
    buildOrthonormalBasis(wt, &wt1, &wt2);

    // integration
    var Idisks = 0.0;
    const nSamplesphi = 20;
    const nSamplesr = 200;
    for (var i = 0; i < nSamplesphi; i++) {
        for (var j = 0; j < nSamplesr; j++) {
            let phi = 2.0 * PI * f32(i) / f32(nSamplesphi);
            let r = R * f32(j) / f32(nSamplesr - 1);
            var p: vec3<f32>;
            var wp: vec3<f32>;

            p = p1 + r * (cos(phi) * wt1 + sin(phi) * wt2);
            wp = normalize(p);
            Idisks += r * D(wp) * max(0.0, dot(wp, wt)) / dot(p, p);

            p = p2 + r * (cos(phi) * wt1 + sin(phi) * wt2);
            wp = normalize(p);
            Idisks += r * D(wp) * max(0.0, dot(wp, -wt)) / dot(p, p);
        }
    }

    Idisks *= 2.0 * PI * R / f32(nSamplesr * nSamplesphi);
    return Idisks;
}

fn method(scene: Scene) -> f32 {
    return I_disks_numerical(scene.p1, scene.p2, scene.radius);
}
