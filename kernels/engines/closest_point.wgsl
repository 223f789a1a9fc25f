//! id: line_isotropic.closest_point
//! target: line_isotropic
//! source: the closest-point capsule light as Heaps shades its diffuse term: one point light at the closest point of the segment, with the falloff 1/(d² + 1) of Heaps' lights (h3d/shader/pbr/Light.hx, after Karis 2013); written from that description
//! minv: diffuse

// The whole light (unit intensity per unit length, so L in all) as one isotropic point
// light at the closest point c of the segment: L·max(0, ω_c.z)/π · 1/(‖c‖² + 1). The "+ 1"
// is in scene units; in this harness the line's distance is 1, so it halves a near light.
fn method(scene: Scene) -> f32 {
    let ab = scene.p2 - scene.p1;
    let t = clamp(-dot(scene.p1, ab) / dot(ab, ab), 0.0, 1.0);
    let c = scene.p1 + t * ab;
    let d2 = dot(c, c);
    let NoL = max(0.0, c.z * inverseSqrt(d2));
    return length(ab) * NoL / PI / (d2 + 1.0);
}
