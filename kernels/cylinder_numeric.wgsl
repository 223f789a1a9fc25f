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
// bisector of its range (theta_quadrature, lib/theta_quadrature.wgsl); u needs no inverse
// trigonometry at the nodes.
// What is left hard: when the origin nearly touches the tube (d − R ≪ R), cos α varies on
// a scale sqrt(1 − R/d) near u = ±π/2 (grazing generators) and needs larger NPHI.

const CYL_HALF_PI: f32 = 1.57079632679489661923;

#include "lib/theta_quadrature.wgsl"

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
    return k * cu / ca * theta_quadrature(g, wt, rho, l1, l2, L);
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
            let dx0 = GL4_X0 * hw;
            let dx1 = GL4_X1 * hw;
            sum += GL4_W0 * (cyl_column(mid - dx0, x, y, wt, d, R, l1, l2, L)
                + cyl_column(mid + dx0, x, y, wt, d, R, l1, l2, L))
                + GL4_W1 * (cyl_column(mid - dx1, x, y, wt, d, R, l1, l2, L)
                + cyl_column(mid + dx1, x, y, wt, d, R, l1, l2, L));
        }
        I += sum * hw;
    }
    return I;
}

fn method(scene: Scene) -> f32 {
    return I_cylinder_gauss(scene.p1, scene.p2, scene.radius);
}
