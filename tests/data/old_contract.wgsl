//! id: user.old_contract
//! target: line
//! source: tests/scene_contract.rs: a user kernel written to the documented kernel contract as it stood before the Scene carried the view and roughness; it reads every Scene member of that contract and calls every prelude helper
//! minv: full

// Not a formula: a kernel that depends on every old member and helper, so a layout or prelude
// change that moved one of them changes its values (tests/scene_contract.rs compares them
// with the values recorded before the change).
fn method(scene: Scene) -> f32 {
    let w = normalize(scene.p1 + scene.p2);
    var b1: vec3<f32>;
    var b2: vec3<f32>;
    buildOrthonormalBasis(w, &b1, &b2);
    var extra = 0.0;
    if ((scene.flags & FLAG_RADIUS) != 0u) {
        extra += scene.radius;
    }
    if ((scene.flags & FLAG_RECT) != 0u) {
        extra += scene.rect_width * (1.0 + abs(scene.rect_normal.x) + 2.0 * abs(scene.rect_normal.z));
    }
    if ((scene.flags & FLAG_LTC) != 0u) {
        extra += 0.5;
    }
    let m = inverse3(scene.minv);
    let len = length(scene.p2 - scene.p1);
    return D(w) * len / dot(scene.p1, scene.p1) + extra + 1e-3 * determinant(m) + 1e-2 * dot(b1, Minv * b2) * PI;
}
