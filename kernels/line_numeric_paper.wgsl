//! id: line.numeric_paper
//! target: line
//! source: Heitz & Hill 2017, GPU Zen, Listing 1.4
//! minv: full

// Listing 1.4 as published: 100 samples at l = L·i/(n−1), i.e. both end points included
// (spacing L/(n−1)), yet weighted L/n. The mismatch biases the sum by about (n−1)/n plus
// the end-point terms; it is kept because this method is the published listing.
fn I_line_numerical(p1: vec3<f32>, p2: vec3<f32>) -> f32 {
    let L = length(p2 - p1);
    let wt = normalize(p2 - p1);

    // integral discretization
    var I = 0.0;
    const nSamples = 100;
    for (var i = 0; i < nSamples; i++) {
        // position
        let p = p1 + L * f32(i) / f32(nSamples - 1) * wt;

        // normalized direction
        let wp = normalize(p);

        // integrate
        I += 2.0 * D(wp) * length(cross(wp, wt)) / dot(p, p);
    }

    I *= L / f32(nSamples);
    return I;
}

fn method(scene: Scene) -> f32 {
    return I_line_numerical(scene.p1, scene.p2);
}
