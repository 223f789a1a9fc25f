//! id: rectangle.ltc_polygon_atan2
//! target: rectangle
//! source: linelight: rectangle_ltc_polygon.wgsl (seed 003) with each edge's angle by atan2(‖a × b‖, a·b) in place of acos(a·b)
//! minv: full

// rectangle_ltc_polygon.wgsl with one change. The long edges of a thin rectangle contribute
// O(1) terms that cancel to O(W), so each angle's absolute error counts against the result:
// acos(x) near x = 1 loses ε/θ to the rounding of x (and Vulkan allows 4096 ULP on acos);
// atan2 of the cross product's length and the dot product is accurate at every angle.

fn ratan_corners(scene: Scene) -> array<vec3<f32>, 4> {
    let wb = normalize(cross(scene.rect_normal, normalize(scene.p2 - scene.p1)));
    let h = 0.5 * scene.rect_width * wb;
    return array<vec3<f32>, 4>(scene.p1 - h, scene.p2 - h, scene.p2 + h, scene.p1 + h);
}

fn ratan_edge(a: vec3<f32>, b: vec3<f32>) -> f32 {
    let c = cross(a, b);
    let s = length(c);
    if (s == 0.0) {
        return 0.0;
    }
    return atan2(s, dot(a, b)) * (c.z / s);
}

fn method(scene: Scene) -> f32 {
    let q = ratan_corners(scene);
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
        sum = sum + ratan_edge(normalize(v[i]), normalize(v[(i + 1u) % n]));
    }
    return abs(sum) / (2.0 * PI);
}
