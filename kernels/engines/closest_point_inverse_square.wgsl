//! id: line_isotropic.closest_point_r2
//! target: line_isotropic
//! source: linelight: closest_point.wgsl with the plain inverse-square falloff 1/d² in place of 1/(d² + 1) (isolates the falloff's offset)
//! minv: diffuse

fn method(scene: Scene) -> f32 {
    let ab = scene.p2 - scene.p1;
    let t = clamp(-dot(scene.p1, ab) / dot(ab, ab), 0.0, 1.0);
    let c = scene.p1 + t * ab;
    let d2 = dot(c, c);
    let NoL = max(0.0, c.z * inverseSqrt(d2));
    return length(ab) * NoL / PI / d2;
}
