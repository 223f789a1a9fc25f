//! id: rectangle.ltc_sphere
//! target: rectangle
//! source: Hill & Heitz 2016, "Real-Time Area Lighting: a Journey from Research to Production" (SIGGRAPH Advances course): unclipped edge vectors with the rational θ/sin θ fit, the horizon handled by the form factor of a clipped sphere with the same vector form factor, (|F|² + F.z)/(|F| + 1) (the formula three.js's LTC_ClippedSphereFormFactor also uses, lights_physical_pars_fragment.glsl.js); the edge fit is the course's, as in rectangle_ltc_polygon_fit.wgsl, not three.js's (a different rational fit), so this is not three.js's shader; written from the published formulas
//! minv: full

// The vector form factor F = 1/(2π) Σ (a × b)·θ/sin θ of the whole transformed rectangle
// (no polygon clipping), turned to face the polygon (two-sided: F·Σ v_i > 0), then the
// clipped-sphere approximation: a sphere of form factor |F| seen at elevation asin(F.z/|F|),
// clipped by the horizon, has form factor ≈ max(0, (|F|² + F.z)/(|F| + 1)), the course's
// cheap fit. It is exact only for F straight up (F.z = |F| gives |F|); elsewhere, even
// wholly above the horizon where the exact value is F.z, it is an approximation.

fn rsph_corners(scene: Scene) -> array<vec3<f32>, 4> {
    let wb = normalize(cross(scene.rect_normal, normalize(scene.p2 - scene.p1)));
    let h = 0.5 * scene.rect_width * wb;
    return array<vec3<f32>, 4>(scene.p1 - h, scene.p2 - h, scene.p2 + h, scene.p1 + h);
}

fn rsph_edge(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
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
    let q = rsph_corners(scene);
    var v: array<vec3<f32>, 4>;
    var centre = vec3<f32>(0.0);
    for (var i = 0u; i < 4u; i = i + 1u) {
        v[i] = normalize(Minv * q[i]);
        centre = centre + v[i];
    }
    var F = vec3<f32>(0.0);
    for (var i = 0u; i < 4u; i = i + 1u) {
        F = F + rsph_edge(v[i], v[(i + 1u) % 4u]);
    }
    F = F / (2.0 * PI);
    if (dot(F, centre) < 0.0) {
        F = -F;
    }
    let l = length(F);
    return max((l * l + F.z) / (l + 1.0), 0.0);
}
