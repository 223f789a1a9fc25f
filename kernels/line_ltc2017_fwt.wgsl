//! id: line.ltc2017_fwt
//! derive: line.ltc2017
//! replace: Fwt
//! source: Heitz & Hill 2017, GPU Zen, Listings 1.6 + 1.7; Fwt (Eq. 1.23) as corrected in the 2023 revision

// The only change from line_ltc2017.wgsl: Eq. 1.23 as corrected in the 2023 revision.
// It differs from the published l²/(d(d²+l²)) by the constant 1/d, so the result is the
// same in exact arithmetic; this form does not cancel when |l| ≫ d.
fn Fwt(d: f32, l: f32) -> f32 {
    return -d / (d * d + l * l);
}
