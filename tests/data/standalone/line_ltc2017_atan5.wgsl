//! id: line.ltc2017_atan5
//! target: line
//! source: Heitz & Hill 2017, GPU Zen, Listings 1.6 + 1.7 with atan by Eberly's degree-5 minimax polynomial (Geometric Tools, ATanEstimate, degree 5), as Unity HDRP evaluated line lights before its 2023 code (com.unity.render-pipelines.core/ShaderLibrary/AreaLighting.hlsl, FastATan of ShaderLibrary/Common.hlsl)
//! minv: full

// kernels/line_ltc2017.wgsl with one change: atan(l/d) in Fpo is the odd polynomial
// x·(1 + x²·(c1 + c2·x²)) on |x| ≤ 1 (Eberly's minimax fit with p(1) = π/4; published
// maximum error 1.35e-3 rad), range-reduced by atan(x) = ±π/2 − atan(1/x) for |x| > 1.

const ATAN5_C1: f32 = -0.30189478312144946;
const ATAN5_C2: f32 = 0.08729294651889774;

fn atan5(x: f32) -> f32 {
    let big = abs(x) > 1.0;
    let t = select(x, 1.0 / x, big);
    let t2 = t * t;
    let p = t * (1.0 + t2 * (ATAN5_C1 + t2 * ATAN5_C2));
    return select(p, sign(x) * (0.5 * PI) - p, big);
}

fn Fpo(d: f32, l: f32) -> f32 {
    return l / (d * (d * d + l * l)) + atan5(l / d) / (d * d);
}

fn Fwt(d: f32, l: f32) -> f32 {
    return l * l / (d * (d * d + l * l));
}

fn I_diffuse_line(p1_in: vec3<f32>, p2_in: vec3<f32>) -> f32 {
    var p1 = p1_in;
    var p2 = p2_in;
    let wt = normalize(p2 - p1);
    if (p1.z <= 0.0 && p2.z <= 0.0) {
        return 0.0;
    }
    if (p1.z < 0.0) {
        p1 = (p1 * p2.z - p2 * p1.z) / (p2.z - p1.z);
    }
    if (p2.z < 0.0) {
        p2 = (-p1 * p2.z + p2 * p1.z) / (-p2.z + p1.z);
    }
    let l1 = dot(p1, wt);
    let l2 = dot(p2, wt);
    let po = p1 - l1 * wt;
    let d = length(po);
    let I = (Fpo(d, l2) - Fpo(d, l1)) * po.z + (Fwt(d, l2) - Fwt(d, l1)) * wt.z;
    return I / PI;
}

fn I_ltc_line(p1: vec3<f32>, p2: vec3<f32>) -> f32 {
    let p1o = Minv * p1;
    let p2o = Minv * p2;
    let I_diffuse = I_diffuse_line(p1o, p2o);
    let ortho = normalize(cross(p1, p2));
    let w = 1.0 / length(inverse3(transpose(Minv)) * ortho);
    return w * I_diffuse;
}

fn method(scene: Scene) -> f32 {
    return I_ltc_line(scene.p1, scene.p2);
}
