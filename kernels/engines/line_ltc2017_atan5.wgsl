//! id: line.ltc2017_atan5
//! derive: line.ltc2017
//! replace: Fpo
//! source: Heitz & Hill 2017, GPU Zen, Listings 1.6 + 1.7 with atan by Eberly's degree-5 minimax polynomial (Geometric Tools, ATanEstimate, degree 5), as Unity HDRP evaluated line lights before its 2023 code (com.unity.render-pipelines.core/ShaderLibrary/AreaLighting.hlsl, FastATan of ShaderLibrary/Common.hlsl)

// kernels/line_ltc2017.wgsl with one change: atan(l/d) in Fpo is the odd polynomial
// x·(1 + x²·(c1 + c2·x²)) on |x| ≤ 1 (Eberly's minimax fit with p(1) = π/4; published
// maximum error 1.35e-3 rad), range-reduced by atan(x) = ±π/2 − atan(1/x) for |x| > 1.

const ATAN5_C1: f32 = -0.30189478312144946;
const ATAN5_C2: f32 = 0.08729294651889774;

fn Fpo(d: f32, l: f32) -> f32 {
    let x = l / d;
    let big = abs(x) > 1.0;
    let t = select(x, 1.0 / x, big);
    let t2 = t * t;
    let p = t * (1.0 + t2 * (ATAN5_C1 + t2 * ATAN5_C2));
    let atan5 = select(p, sign(x) * (0.5 * PI) - p, big);
    return l / (d * (d * d + l * l)) + atan5 / (d * d);
}
