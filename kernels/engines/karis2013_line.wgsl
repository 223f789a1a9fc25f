//! id: line_isotropic.karis2013
//! target: line_isotropic
//! source: Karis 2013, "Real Shading in Unreal Engine 4" (SIGGRAPH course notes, tube lights: line irradiance), the paper's closed form; Unreal Engine 4's LineIrradiance (Engine/Shaders/Private/CapsuleLight.ush, its horizon clip commented out) adds a distance bias, DistanceBiasSqr·InvLength01 in the denominator (the light softened near its surface), which this kernel omits; written from the paper's formula
//! minv: diffuse

// Karis's closed form of a line of isotropic emitters' irradiance, with L0, L1 the end points
// seen from the shading point:
//     ∫ n·ω/‖p‖² dl / L = 2·(n·L0/(2‖L0‖) + n·L1/(2‖L1‖)) / (‖L0‖‖L1‖ + L0·L1),
// the intensity spread over the length L. It is exact while the whole segment is above the
// horizon; below it the cosine goes negative and the sum is clamped at 0, as a shader must.
// Here the light has unit intensity per unit length (target line_isotropic), hence ×L, and
// D = cos/π, hence /π.
fn method(scene: Scene) -> f32 {
    let L0 = scene.p1;
    let L1 = scene.p2;
    let len0 = length(L0);
    let len1 = length(L1);
    let NoL = L0.z / len0 + L1.z / len1;
    let E = NoL / (len0 * len1 + dot(L0, L1));
    return max(0.0, E) * length(L1 - L0) / PI;
}
