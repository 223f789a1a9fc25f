//! id: line.ltc2023_fix
//! derive: line.ltc2023_full
//! replace: I_diffuse_line
//! source: the 2023 revision of Heitz & Hill 2017 with two fixes: width factor for any M⁻¹, angle by atan2

// line_ltc2023_full.wgsl (the 2023 listing with the full width factor) with one more
// change, in I_diffuse_line: the subtended angle by atan2 instead of acos (see the `Fix:`
// comment below). The rest of the function is the listing's.

// This function assumes that inputs are well-behaved, e.i.
// that the line does not pass through the origin and
// that the light is (at least partially) above the surface.
fn I_diffuse_line(C: vec3<f32>, A: vec3<f32>, hl: f32) -> f32 {
    // Solve C.z + h * A.z = 0.
    let h = -C.z * (1.0 / A.z); // May be Inf, but never NaN

    // Clip the line segment against the z-plane if necessary.
    let h2 = select(min(hl, h), max(hl, h), A.z >= 0.0); // P2 = C + h2 * A
    let h1 = select(min(-hl, h), max(-hl, h), A.z >= 0.0); // P1 = C + h1 * A

    // Normalize the tangent.
    let as_ = dot(A, A); // |A|^2
    let ar = inverseSqrt(as_); // 1/|A|
    let a = as_ * ar; // |A|
    let T = A * ar; // A/|A|

    // Orthogonal 2D coordinates:
    // P(n, t) = n * N + t * T.
    let tc = dot(T, C); // C = n * N + tc * T
    let P0 = C - tc * T; // P(n, 0) = n * N
    let ns = dot(P0, P0); // |P0|^2

    let nr = inverseSqrt(ns); // 1/|P0|
    let n = ns * nr; // |P0|
    let Nz = P0.z * nr; // N.z = P0.z/|P0|

    // P(n, t) - C = P0 + t * T - P0 - tc * T
    // = (t - tc) * T = h * A = (h * a) * T.
    let t2 = tc + h2 * a; // P2.t
    let t1 = tc + h1 * a; // P1.t
    let s2 = ns + t2 * t2; // |P2|^2
    let s1 = ns + t1 * t1; // |P1|^2
    let mr = inverseSqrt(s1 * s2); // 1/(|P1|*|P2|)
    let r2 = s1 * (mr * mr); // 1/|P2|^2
    let r1 = s2 * (mr * mr); // 1/|P1|^2

    // I = (i1 + i2 + i3) / Pi.
    // i1 =  N.z * (P2.t / |P2|^2 - P1.t / |P1|^2).
    // i2 = -T.z * (P2.n / |P2|^2 - P1.n / |P1|^2).
    // i3 =  N.z * ArcCos[Dot[P1, P2] / (|P1| * |P2|)] / |P0|.
    let i12 = (Nz * t2 - (T.z * n)) * r2 - (Nz * t1 - (T.z * n)) * r1;
    // Fix: the angle between P1 and P2 as atan2(|P1 × P2|, P1 · P2) = atan2(n (t2 − t1), ns + t1 t2).
    // The listing's acos of a cosine near 1 loses ~ε/Δ² for a small angle Δ (a short or far
    // light); atan2 keeps a few ULP at every angle, and needs no clamp.
    let i3 = atan2(n * (t2 - t1), ns + t1 * t2) * (Nz * nr); // angle * cos(θ) / r^2

    // Guard against numerical errors.
    return INV_PI * max(0.0, i12 + i3);
}
