//! id: cylinder.numeric
//! target: cylinder
//! source: linelight: Gauss–Legendre quadrature of Eq. 1.2 in angles seen from the shading point
//! minv: full
//! params: NPHI=32 NL=64

override NPHI: u32 = 32;
override NL: u32 = 64;

// The rule. With x the unit vector from the origin to the axis line's closest point (at
// distance d), y = ωt × x, and δ the angle of the surface normal from −x, the side point
// p = p1 + l·ωt + R·ωn faces the origin iff −p·ωn = d·cos δ − R > 0: the same arc
// |δ| < acos(R/d) for every l (none if d ≤ R). Along the generator at δ, whose closest
// point to the origin is g at distance ρ, l = ρ·tan θ − p1·ωt turns
// max(0, −ω_p·ωn)/‖p‖² R dl into (R(d cos δ − R)/ρ²)·cos θ dθ, and R(d cos δ − R)/ρ² dδ
// is dα, α the angle of g about the axis (the 2D view angle of the cross-section). So
//     I = ∫ dα ∫ D(cos θ·ĝ(α) + sin θ·ωt) cos θ dθ,
// the integral of D over the solid angle of the visible side: no 1/‖p‖² peak is left,
// however close the origin is to the tube. α runs over ±asin(R/d), and ρ(α) =
// d cos α − sqrt(R² − d² sin² α) has a square-root end point there; α = asin((R/d)·sin u)
// removes it: sqrt(·) = R cos u, ρ = (d² − R²)/(d cos α + R cos u), dα = (R/d)·cos u/cos α du,
// all analytic for u in [−π/2, π/2]. In θ the integrand is analytic once θ is clipped to
// the half-space where D > 0 (row 2 of M⁻¹ dotted with ω > 0, as in line.numeric). The
// outer integrand is then analytic except where that plane crosses a rim (l = 0 or L):
// the arc is cut there (up to 4 cuts, in closed form). Composite 4-point Gauss–Legendre
// on each piece then converges like h⁸ in both variables. NPHI sets the density in u:
// NPHI/4 panels over [−π/2, π/2], each piece getting its share rounded (at least one);
// NL/4 panels in θ along every generator. For f32 (and GPU atan2), θ is measured from the
// bisector of its range (cyl_generator); u needs no inverse trigonometry at the nodes.
// What is left hard: when the origin nearly touches the tube (d − R ≪ R), cos α varies on
// a scale sqrt(1 − R/d) near u = ±π/2 (grazing generators) and needs larger NPHI.

const CYL_HALF_PI: f32 = 1.57079632679489661923;

// 4-point Gauss–Legendre nodes and weights on [−1, 1].
const CYL_GL_X0: f32 = 0.3399810435848563;
const CYL_GL_X1: f32 = 0.8611363115940526;
const CYL_GL_W0: f32 = 0.6521451548625461;
const CYL_GL_W1: f32 = 0.3478548451374538;

// atan2(y, x) for y > 0 (in (0, π)) to about 2e-7 relative on any device: Vulkan lets
// atan/atan2 be off by 4096 ULP, and lavapipe's is 2.1e-5 relative off for |y/x| < 0.1 —
// exactly the small spans a thin or short light has. Cephes' atanf: octant reduction, then
// an odd degree-9 polynomial on |t| ≤ tan(π/8). The CPU port uses atan2 itself.
fn cyl_angle(y: f32, x: f32) -> f32 {
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
fn cyl_integrand(wm: vec3<f32>, wq: vec3<f32>, g: vec3<f32>, tau: f32) -> f32 {
    let w = cos(tau) * wm + sin(tau) * wq;
    return D(w) * dot(w, g);
}

// ∫ D(cos θ·g + sin θ·ωt) cos θ dθ along the generator with unit foot direction g at
// distance rho, from l = s1 to s2 = s1 + L (measured from the foot), where D can be
// non-zero. The angle τ = θ − θm is taken from the bisector wm of the directions to the two
// ends, towards ωt (wq): node directions and cos θ come from dot and cross products; the
// half-span atan2(L·ρ, ρ² + s1·s2)/2 is cyl_angle, and only the clip (where D is 0
// anyway) uses the built-in atan2. Angles θ1 + τ from atan2(s1, ρ) would carry its
// absolute error into cos θ, amplified by tan θ for a segment seen end-on, and a span
// θ2 − θ1 from two atan2 would lose digits for a short or distant one; GPU atan2 is far
// less exact than sin, cos and sqrt.
fn cyl_generator(g: vec3<f32>, wt: vec3<f32>, rho: f32, s1: f32, s2: f32, L: f32) -> f32 {
    let wm = normalize(normalize(rho * g + s1 * wt) + normalize(rho * g + s2 * wt));
    let wq = cross(cross(g, wt), wm);
    let half = 0.5 * cyl_angle(L * rho, rho * rho + s1 * s2);
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
        let dx0 = CYL_GL_X0 * hw;
        let dx1 = CYL_GL_X1 * hw;
        I += CYL_GL_W0 * (cyl_integrand(wm, wq, g, mid - dx0) + cyl_integrand(wm, wq, g, mid + dx0))
            + CYL_GL_W1 * (cyl_integrand(wm, wq, g, mid - dx1) + cyl_integrand(wm, wq, g, mid + dx1));
    }
    return I * hw;
}

// (dα/du)·∫ D cos θ dθ along the generator seen at u, α = asin((R/d)·sin u).
fn cyl_column(u: f32, x: vec3<f32>, y: vec3<f32>, wt: vec3<f32>, d: f32, R: f32, l1: f32, l2: f32, L: f32) -> f32 {
    let k = R / d;
    let gap2 = (d - R) * (d + R);
    let su = sin(u);
    let cu = cos(u);
    let sa = k * su;
    // cos α = sqrt(1 − k² sin² u), without cancellation near k sin u = 1.
    let ca = sqrt(cu * cu + gap2 / (d * d) * su * su);
    let rho = gap2 / (d * ca + R * cu);
    let g = ca * x + sa * y;
    return k * cu / ca * cyl_generator(g, wt, rho, l1, l2, L);
}

fn I_cylinder_gauss(p1: vec3<f32>, p2: vec3<f32>, R: f32) -> f32 {
    let L = length(p2 - p1);
    let wt = normalize(p2 - p1);
    let l1 = dot(p1, wt);
    let l2 = dot(p2, wt);
    let po = p1 - l1 * wt;
    let d = length(po);
    // Within R of the axis line (beyond an end): no point of the side faces the origin.
    if (d <= R) {
        return 0.0;
    }
    let x = po / d;
    let y = cross(wt, x);

    // Cuts: where the plane n·p = 0 crosses a rim, n·(po + s·ωt) − R cos δ n·x +
    // R sin δ n·y = 0, i.e. A + B cos δ + C sin δ = 0, on the facing arc |δ| < β.
    let n = vec3<f32>(Minv[0][2], Minv[1][2], Minv[2][2]);
    let beta = acos(R / d);
    let B = -R * dot(n, x);
    let C = R * dot(n, y);
    let H = sqrt(B * B + C * C);
    var bounds: array<f32, 6>;
    bounds[0] = -CYL_HALF_PI;
    var m = 1u;
    for (var e = 0u; e < 2u; e++) {
        let A = dot(n, po) + select(l1, l2, e == 1u) * dot(n, wt);
        if (H > abs(A)) {
            let psi = atan2(C, B);
            let c = acos(-A / H);
            for (var s = 0u; s < 2u; s++) {
                var delta = select(psi - c, psi + c, s == 1u);
                if (delta > PI) {
                    delta -= 2.0 * PI;
                }
                if (delta < -PI) {
                    delta += 2.0 * PI;
                }
                if (abs(delta) < beta) {
                    // The rim point's u: sin α / k = d sin δ / ρ.
                    let gx = d - R * cos(delta);
                    let gy = R * sin(delta);
                    bounds[m] = asin(clamp(d * sin(delta) / sqrt(gx * gx + gy * gy), -1.0, 1.0));
                    m++;
                }
            }
        }
    }
    bounds[m] = CYL_HALF_PI;
    m++;
    for (var i = 1u; i < m; i++) {
        let v = bounds[i];
        var j = i;
        while (j > 0u && bounds[j - 1u] > v) {
            bounds[j] = bounds[j - 1u];
            j--;
        }
        bounds[j] = v;
    }

    let density = f32(max(NPHI / 4u, 1u)) / PI;
    var I = 0.0;
    for (var piece = 0u; piece + 1u < m; piece++) {
        let u1 = bounds[piece];
        let u2 = bounds[piece + 1u];
        if (u2 <= u1) {
            continue;
        }
        let panels = max(1u, u32(floor(density * (u2 - u1) + 0.5)));
        let hw = 0.5 * (u2 - u1) / f32(panels);
        var sum = 0.0;
        for (var pk = 0u; pk < panels; pk++) {
            let mid = u1 + (2.0 * f32(pk) + 1.0) * hw;
            let dx0 = CYL_GL_X0 * hw;
            let dx1 = CYL_GL_X1 * hw;
            sum += CYL_GL_W0 * (cyl_column(mid - dx0, x, y, wt, d, R, l1, l2, L)
                + cyl_column(mid + dx0, x, y, wt, d, R, l1, l2, L))
                + CYL_GL_W1 * (cyl_column(mid - dx1, x, y, wt, d, R, l1, l2, L)
                + cyl_column(mid + dx1, x, y, wt, d, R, l1, l2, L));
        }
        I += sum * hw;
    }
    return I;
}

fn method(scene: Scene) -> f32 {
    return I_cylinder_gauss(scene.p1, scene.p2, scene.radius);
}
