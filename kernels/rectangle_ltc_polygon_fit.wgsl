//! id: rectangle.ltc_polygon_fit
//! target: rectangle
//! source: Hill & Heitz 2016, "Real-Time Area Lighting: a Journey from Research to Production" (SIGGRAPH Advances course): the edge integral with the course's rational fit of θ/sin θ, as the LTC demo's IntegrateEdgeVec uses it (three.js's LTC_EdgeVectorFormFactor, lights_physical_pars_fragment.glsl.js, uses a different rational fit, of θ/(2π sin θ) with other coefficients; not this one); written from the published fit
//! minv: full

// rectangle_ltc_polygon.wgsl with each edge's acos(x)·normalize(a × b) replaced by
// (a × b)·θ/sin θ, θ/sin θ from a fit in |x| (x = a·b): (5.42031 + (3.12829 + 0.0902326|x|)|x|)
// / (3.45068 + (4.18814 + |x|)|x|) for x ≥ 0, reflected through π/sin θ − f(|x|) for x < 0.
// No acos and no normalize of the cross product; the clip to the horizon is kept.

fn rfit_corners(scene: Scene) -> array<vec3<f32>, 4> {
    let wb = normalize(cross(scene.rect_normal, normalize(scene.p2 - scene.p1)));
    let h = 0.5 * scene.rect_width * wb;
    return array<vec3<f32>, 4>(scene.p1 - h, scene.p2 - h, scene.p2 + h, scene.p1 + h);
}

fn rfit_edge(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    let x = dot(a, b);
    let y = abs(x);
    let num = 5.42031 + (3.12829 + 0.0902326 * y) * y;
    let den = 3.45068 + (4.18814 + y) * y;
    var theta_sintheta = num / den;
    if (x < 0.0) {
        theta_sintheta = PI * inverseSqrt(1.0 - x * x) - theta_sintheta;
    }
    return cross(a, b) * theta_sintheta;
}

fn method(scene: Scene) -> f32 {
    let q = rfit_corners(scene);
    var v: array<vec3<f32>, 5>;
    var n = 0u;
    for (var i = 0u; i < 4u; i = i + 1u) {
        let a = Minv * q[i];
        let b = Minv * q[(i + 1u) % 4u];
        if (a.z > 0.0) {
            v[n] = a;
            n = n + 1u;
        }
        if ((a.z > 0.0) != (b.z > 0.0)) {
            v[n] = mix(a, b, a.z / (a.z - b.z));
            n = n + 1u;
        }
    }
    if (n < 3u) {
        return 0.0;
    }
    var sum = 0.0;
    for (var i = 0u; i < n; i = i + 1u) {
        sum = sum + rfit_edge(normalize(v[i]), normalize(v[(i + 1u) % n])).z;
    }
    return abs(sum) / (2.0 * PI);
}
