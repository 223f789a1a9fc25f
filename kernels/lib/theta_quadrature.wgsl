// The θ quadrature of the numeric integrators (cylinder_numeric.wgsl, rectangle_numeric.wgsl):
// ∫ D(cos θ·g + sin θ·ωt) cos θ dθ along one line of the light, by composite 4-point
// Gauss–Legendre in the angle θ seen from the shading point, clipped to where D > 0.
// Included at module scope (`#include "lib/theta_quadrature.wgsl"`); it reads the prelude's
// `D` and `Minv` and the including kernel's `override NL: u32` (NL/4 panels in θ, at least
// one: an override, so the panel count is a constant of the pipeline and the loop's trip
// count is known to the driver and to the cost count).

// 4-point Gauss–Legendre nodes and weights on [−1, 1].
const GL4_X0: f32 = 0.3399810435848563;
const GL4_X1: f32 = 0.8611363115940526;
const GL4_W0: f32 = 0.6521451548625461;
const GL4_W1: f32 = 0.3478548451374538;

// atan2(y, x) for y > 0 (in (0, π)) to about 2e-7 relative on any device: Vulkan lets
// atan/atan2 be off by 4096 ULP, and lavapipe's is 2.1e-5 relative off for |y/x| < 0.1 —
// exactly the small spans a thin or short light has. Cephes' atanf: octant reduction, then
// an odd degree-9 polynomial on |t| ≤ tan(π/8). The CPU port uses atan2 itself.
fn atan2_upper(y: f32, x: f32) -> f32 {
    var base = 0.0;
    var z = y / x;
    if (x <= 0.0) {
        base = 0.5 * PI;
        z = -x / y;
    }
    var t = z;
    if (z > 2.414213562373095) {
        base += 0.5 * PI;
        t = -1.0 / z;
    } else if (z > 0.4142135623730950) {
        base += 0.25 * PI;
        t = (z - 1.0) / (z + 1.0);
    }
    let q = t * t;
    return base + ((((0.0805374449538 * q - 0.138776856032) * q + 0.199777106478) * q - 0.333329491539) * q * t + t);
}

// D(ω)·cos θ at ω = cos τ·wm + sin τ·wq; cos θ = ω·g (g ⟂ ωt, ω in the plane of g, ωt).
fn theta_integrand(wm: vec3<f32>, wq: vec3<f32>, g: vec3<f32>, tau: f32) -> f32 {
    let w = cos(tau) * wm + sin(tau) * wq;
    return D(w) * dot(w, g);
}

// ∫ D(cos θ·g + sin θ·ωt) cos θ dθ along the line with unit foot direction g at distance
// rho, from s1 to s2 = s1 + L along ωt (measured from the foot), where D can be non-zero.
// The angle τ = θ − θm is taken from the bisector wm of the directions
// to the two ends, towards ωt (wq): node directions and cos θ come from dot and cross
// products; the half-span atan2(L·ρ, ρ² + s1·s2)/2 is atan2_upper, and only the clip (where
// D is 0 anyway) uses the built-in atan2. Angles θ1 + τ from atan2(s1, ρ) would carry its
// absolute error into cos θ, amplified by tan θ for a segment seen end-on, and a span
// θ2 − θ1 from two atan2 would lose digits for a short or distant one; GPU atan2 is far
// less exact than sin, cos and sqrt.
fn theta_quadrature(g: vec3<f32>, wt: vec3<f32>, rho: f32, s1: f32, s2: f32, L: f32) -> f32 {
    let wm = normalize(normalize(rho * g + s1 * wt) + normalize(rho * g + s2 * wt));
    let wq = cross(cross(g, wt), wm);
    let half = 0.5 * atan2_upper(L * rho, rho * rho + s1 * s2);
    var lo = -half;
    var hi = half;
    // D(ω) > 0 iff n·ω > 0 with n = row 2 of M⁻¹; here n·ω = a·cos τ + b·sin τ.
    let n = vec3<f32>(Minv[0][2], Minv[1][2], Minv[2][2]);
    let a = dot(n, wm);
    let b = dot(n, wq);
    if (b >= 0.0) {
        lo = max(lo, atan2(-a, b));
    } else {
        hi = min(hi, atan2(a, -b));
    }
    if (hi <= lo) {
        return 0.0;
    }
    let panels = max(NL / 4u, 1u);
    let hw = 0.5 * (hi - lo) / f32(panels);
    var I = 0.0;
    for (var k = 0u; k < panels; k++) {
        let mid = lo + (2.0 * f32(k) + 1.0) * hw;
        let dx0 = GL4_X0 * hw;
        let dx1 = GL4_X1 * hw;
        I += GL4_W0 * (theta_integrand(wm, wq, g, mid - dx0) + theta_integrand(wm, wq, g, mid + dx0))
            + GL4_W1 * (theta_integrand(wm, wq, g, mid - dx1) + theta_integrand(wm, wq, g, mid + dx1));
    }
    return I * hw;
}
