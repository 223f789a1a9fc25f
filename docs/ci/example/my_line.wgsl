//! id: my.line
//! target: line
//! source: example user kernel: Listing 1.6 of Heitz & Hill 2017 (diffuse only)
//! minv: none

// The example kernel of docs/ci/: Listing 1.6 as linelight's line_ltc2017.wgsl ports it,
// diffuse only. Listing 1.6, ported operation for operation. The seed text reads `1/(d*(d*d + 1*1))`
// and `l*l/(d*(d*d + 1*1))`: the PDF rendered the letter l as the digit 1. Eqs. 1.22 and
// 1.23 above the listing give l/(d(d²+l²)) and l²/(d(d²+l²)), so `l` is used here.

fn Fpo(d: f32, l: f32) -> f32 {
    return l / (d * (d * d + l * l)) + atan(l / d) / (d * d);
}

// Eq. 1.23 as published. It differs from the 2023 form −d/(d²+l²) by the constant 1/d,
// so Fwt(l2) − Fwt(l1) is the same in exact arithmetic, but both terms tend to 1/d when
// |l| ≫ d and their difference cancels (kernels/line_ltc2017_fwt.wgsl isolates this).
fn Fwt(d: f32, l: f32) -> f32 {
    return l * l / (d * (d * d + l * l));
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

// Diffuse only (`minv: none`): no transform to the diffuse configuration, no width factor.
fn method(scene: Scene) -> f32 {
    return I_diffuse_line(scene.p1, scene.p2);
}
