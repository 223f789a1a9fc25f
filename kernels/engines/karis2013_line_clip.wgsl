//! id: line_isotropic.karis2013_clip
//! target: line_isotropic
//! source: Karis 2013, "Real Shading in Unreal Engine 4" (tube lights: line irradiance) with the segment first clipped to the horizon, as O3DE shades it (Gems/Atom/Feature/Common/Assets/ShaderLib/Atom/Features/PBR/Lights/CapsuleLight.azsli); written from the paper's formula
//! minv: diffuse

// The same closed form as karis2013_line.wgsl on the part of the segment above the horizon
// (z ≥ 0), which makes it exact for a line of isotropic emitters. The clip moves an end
// point below the surface to where the segment crosses z = 0.
fn method(scene: Scene) -> f32 {
    var L0 = scene.p1;
    var L1 = scene.p2;
    if (L0.z <= 0.0 && L1.z <= 0.0) {
        return 0.0;
    }
    if (L0.z < 0.0) {
        L0 = mix(L0, L1, L0.z / (L0.z - L1.z));
    }
    if (L1.z < 0.0) {
        L1 = mix(L1, L0, L1.z / (L1.z - L0.z));
    }
    let len0 = length(L0);
    let len1 = length(L1);
    let NoL = L0.z / len0 + L1.z / len1;
    let E = NoL / (len0 * len1 + dot(L0, L1));
    return max(0.0, E) * length(L1 - L0) / PI;
}
