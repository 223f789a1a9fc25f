//! id: line.ltc2017_fwt
//! target: line
//! source: Heitz & Hill 2017, GPU Zen, Listings 1.6 + 1.7; Fwt (Eq. 1.23) as corrected in the 2023 revision
//! minv: full

// Listing 1.6 with only Fwt replaced, otherwise ported operation for operation. The seed
// text reads `1/(d*(d*d + 1*1))` for Fpo: the PDF rendered the letter l as the digit 1;
// Eq. 1.22 above the listing gives l/(d(d²+l²)), so `l` is used here.

fn Fpo(d: f32, l: f32) -> f32 {
    return l / (d * (d * d + l * l)) + atan(l / d) / (d * d);
}

// The only change from line_ltc2017.wgsl: Eq. 1.23 as corrected in the 2023 revision.
// It differs from the published l²/(d(d²+l²)) by the constant 1/d, so the result is the
// same in exact arithmetic; this form does not cancel when |l| ≫ d.
fn Fwt(d: f32, l: f32) -> f32 {
    return -d / (d * d + l * l);
}

// GLSL assigns to the `in` parameters; WGSL parameters are immutable, hence the copies.
fn I_diffuse_line(p1_in: vec3<f32>, p2_in: vec3<f32>) -> f32 {
    var p1 = p1_in;
    var p2 = p2_in;

    // tangent
    let wt = normalize(p2 - p1);

    // clamping
    if (p1.z <= 0.0 && p2.z <= 0.0) {
        return 0.0;
    }
    if (p1.z < 0.0) {
        p1 = (p1 * p2.z - p2 * p1.z) / (p2.z - p1.z);
    }
    if (p2.z < 0.0) {
        p2 = (-p1 * p2.z + p2 * p1.z) / (-p2.z + p1.z);
    }

    // parameterization
    let l1 = dot(p1, wt);
    let l2 = dot(p2, wt);

    // shading point orthonormal projection on the line
    let po = p1 - l1 * wt;

    // distance to line
    let d = length(po);

    // integral
    let I = (Fpo(d, l2) - Fpo(d, l1)) * po.z + (Fwt(d, l2) - Fwt(d, l1)) * wt.z;
    return I / PI;
}

// Listing 1.7. GLSL `inverse` is the prelude's `inverse3`.
fn I_ltc_line(p1: vec3<f32>, p2: vec3<f32>) -> f32 {
    // transform to diffuse configuration
    let p1o = Minv * p1;
    let p2o = Minv * p2;
    let I_diffuse = I_diffuse_line(p1o, p2o);

    // width factor
    let ortho = normalize(cross(p1, p2));
    let w = 1.0 / length(inverse3(transpose(Minv)) * ortho);

    return w * I_diffuse;
}

fn method(scene: Scene) -> f32 {
    return I_ltc_line(scene.p1, scene.p2);
}
