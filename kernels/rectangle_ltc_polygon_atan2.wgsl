//! id: rectangle.ltc_polygon_atan2
//! derive: rectangle.ltc_polygon
//! replace: rect_edge_exact
//! source: linelight: rectangle_ltc_polygon.wgsl (seed 003) with each edge's angle by atan2(‖a × b‖, a·b) in place of acos(a·b)

// The one change from rectangle_ltc_polygon.wgsl. The long edges of a thin rectangle contribute
// O(1) terms that cancel to O(W), so each angle's absolute error counts against the result:
// acos(x) near x = 1 loses ε/θ to the rounding of x (and Vulkan allows 4096 ULP on acos);
// atan2 of the cross product's length and the dot product is accurate at every angle.
fn rect_edge_exact(a: vec3<f32>, b: vec3<f32>) -> f32 {
    let c = cross(a, b);
    let s = length(c);
    if (s == 0.0) {
        return 0.0;
    }
    return atan2(s, dot(a, b)) * (c.z / s);
}
