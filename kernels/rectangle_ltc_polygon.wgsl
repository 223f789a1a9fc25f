//! id: rectangle.ltc_polygon
//! target: rectangle
//! source: seed 003 (polygonal LTC lights): Lambert's polygon integral of the LTC-transformed rectangle, clipped to the horizon (Heitz et al. 2016, "Real-Time Polygonal-Light Shading with Linearly Transformed Cosines")
//! minv: full

// The thin rectangle's four corners are mapped by M⁻¹; there D is the clamped cosine, so
// ∫_rect D dω is the cosine form factor of the transformed polygon clipped to z > 0 (exact),
// by Lambert's formula as seed 003 writes it:
//     E = 1/(2π) Σ acos(⟨p_i, p_j⟩)·⟨normalize(p_i × p_j), z⟩,   p unit, j = i + 1.
// The rectangle is two-sided: the side facing the shading point is taken by |E|. The
// clip (Sutherland–Hodgman on z = 0) yields at most 5 vertices; an edge whose end points
// coincide (a vertex on z = 0 is emitted twice) has no direction and adds nothing.

fn rect_corners(scene: Scene) -> array<vec3<f32>, 4> {
    let wb = normalize(cross(scene.rect_normal, normalize(scene.p2 - scene.p1)));
    let h = 0.5 * scene.rect_width * wb;
    return array<vec3<f32>, 4>(scene.p1 - h, scene.p2 - h, scene.p2 + h, scene.p1 + h);
}

fn rect_edge_exact(a: vec3<f32>, b: vec3<f32>) -> f32 {
    let c = cross(a, b);
    if (dot(c, c) == 0.0) {
        return 0.0;
    }
    return acos(clamp(dot(a, b), -1.0, 1.0)) * normalize(c).z;
}

fn method(scene: Scene) -> f32 {
    let q = rect_corners(scene);
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
        sum = sum + rect_edge_exact(normalize(v[i]), normalize(v[(i + 1u) % n]));
    }
    return abs(sum) / (2.0 * PI);
}
