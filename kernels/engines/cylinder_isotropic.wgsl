//! id: cylinder.isotropic
//! target: cylinder
//! source: linelight: a tube shaded as a row of isotropic emitters, the way Unreal Engine 4 and O3DE shade a tube light's diffuse term (Karis 2013, tube lights), with the tube's power: (π/2)·R·I_line of an isotropic-emitter line method
//! minv: full
//! uses: line_isotropic

// A Lambertian tube of unit radiance and radius R emits 2R‖ω × ω_t‖ per unit length towards
// ω; averaged over all directions that is πR/2, so isotropic emitters of the same power have
// intensity πR/2 per unit length. `I_line` is an isotropic-emitter line method (unit intensity
// per unit length, `cylinder.isotropic[line_isotropic.karis2013_clip]`; with a specular
// isotropic-emitter method, `cylinder.isotropic[line.mrp_specular_energy]`, the tube's
// specular term). Its own formula ignores M⁻¹: what it handles is what its inner handles.
fn method(scene: Scene) -> f32 {
    return 0.5 * PI * scene.radius * I_line(scene.p1, scene.p2);
}
