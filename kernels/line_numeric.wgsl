//! id: line.numeric
//! target: line
//! source: linelight: composite Gauss–Legendre quadrature of Eq. 1.6 in the angle about the line's closest point
//! minv: full
//! params: SAMPLES=64

override SAMPLES: u32 = 64;

// Why this converges fast: with p(l) = po + l·ωt, d = ‖po‖ and l = d·tan θ, Eq. 1.6 becomes
//     ∫ 2·D(ω_p)·cos θ / d dθ,   ω_p = cos θ·(po/d) + sin θ·ωt,
// over a finite interval inside (−π/2, π/2): the 1/(d²+l²) peak and any long tail are
// absorbed by the substitution, leaving a bounded integrand. D has a kink only where
// (M⁻¹ω).z changes sign; clipping to that half-space (row 2 of M⁻¹ dotted with p > 0,
// z > 0 for the diffuse material) leaves an analytic integrand, on which Gauss–Legendre
// converges geometrically in the number of panels. Sharp LTC lobes need more panels.

// 4-point Gauss–Legendre nodes and weights on [−1, 1].
const GL_X0: f32 = 0.3399810435848563;
const GL_X1: f32 = 0.8611363115940526;
const GL_W0: f32 = 0.6521451548625461;
const GL_W1: f32 = 0.3478548451374538;

fn line_integrand(po_dir: vec3<f32>, wt: vec3<f32>, d: f32, theta: f32) -> f32 {
    let wp = cos(theta) * po_dir + sin(theta) * wt;
    return 2.0 * D(wp) * cos(theta) / d;
}

fn I_line_gauss(p1: vec3<f32>, p2: vec3<f32>) -> f32 {
    let wt = normalize(p2 - p1);
    let l1 = dot(p1, wt);
    let l2 = dot(p2, wt);
    let po = p1 - l1 * wt;
    let d = length(po);
    // The line passes through the origin: ω_p ∥ ωt, the integrand is 0.
    if (d == 0.0) {
        return 0.0;
    }
    let po_dir = po / d;
    var theta1 = atan2(l1, d);
    var theta2 = atan2(l2, d);

    // D(ω) > 0 iff n·ω > 0 with n = row 2 of M⁻¹; along the line n·p ∝ a·cos θ + b·sin θ.
    let n = vec3<f32>(Minv[0][2], Minv[1][2], Minv[2][2]);
    let a = dot(n, po_dir);
    let b = dot(n, wt);
    if (b >= 0.0) {
        theta1 = max(theta1, atan2(-a, b));
    } else {
        theta2 = min(theta2, atan2(a, -b));
    }
    if (theta2 <= theta1) {
        return 0.0;
    }

    let panels = max(SAMPLES / 4u, 1u);
    let half_width = 0.5 * (theta2 - theta1) / f32(panels);
    var I = 0.0;
    for (var k = 0u; k < panels; k++) {
        let mid = theta1 + (2.0 * f32(k) + 1.0) * half_width;
        let dx0 = GL_X0 * half_width;
        let dx1 = GL_X1 * half_width;
        I += GL_W0 * (line_integrand(po_dir, wt, d, mid - dx0) + line_integrand(po_dir, wt, d, mid + dx0))
            + GL_W1 * (line_integrand(po_dir, wt, d, mid - dx1) + line_integrand(po_dir, wt, d, mid + dx1));
    }
    return I * half_width;
}

fn method(scene: Scene) -> f32 {
    return I_line_gauss(scene.p1, scene.p2);
}
