//! id: rectangle.numeric
//! target: rectangle
//! source: linelight: Gauss–Legendre quadrature of the thin-rectangle integral (docs/conventions.md) in angles seen from the shading point
//! minv: full
//! params: NW=8 NL=64

override NW: u32 = 8;
override NL: u32 = 64;

// The rule. The rectangle spans ωt and the width direction ωb = normalize(ωn × ωt); its
// plane has the exact normal ωn' = ωt × ωb (= ωn when ωn ⟂ ωt) and lies at signed
// distance h = p1·ωn' (zero: the origin is in the plane, ω_p·ωn = 0, the integral is 0).
// With Y the coordinate along ωb and X = l + p1·ωt along ωt, both from the origin's foot
// on the plane, |ω_p·ωn|/‖p‖² = |h|/‖p‖³. Each line of constant Y is at distance
// ρ = sqrt(h² + Y²) with unit foot direction ĝ; X = ρ·tan θ turns |h|/‖p‖³ dX into
// (|h|/ρ²)·cos θ dθ, and Y = |h|·tan ψ turns |h|/ρ² dY into dψ:
//     I = ∫ dψ ∫ D(cos θ·ĝ(ψ) + sin θ·ωt) cos θ dθ,   ĝ(ψ) = cos ψ·sign(h)ωn' + sin ψ·ωb,
// the integral of D over the rectangle's solid angle, with no 1/‖p‖² peak left however
// close the origin is to the plane. ψ runs between atan2(Y, |h|) at the two long edges.
// In θ the integrand is analytic once θ is clipped to the half-space where D > 0 (row 2
// of M⁻¹ dotted with ω > 0, as in line.numeric); in ψ it is analytic except where that
// plane crosses a short edge (X = p1·ωt or p2·ωt): the ψ range is cut there (at most 2
// cuts, in closed form). Composite 4-point Gauss–Legendre on each piece then converges
// like h⁸ in both variables. NW sets the density in ψ: NW/4 panels over the width, each
// piece getting its share rounded (at least one); NL/4 panels in θ along every line.
// For f32 (and GPU atan2), both angles are measured from the bisector of their range
// (theta_quadrature in lib/theta_quadrature.wgsl, I_rectangle_gauss).
// For a thin rectangle the ψ range is small and F(ψ) nearly constant: NW = 8 is plenty.

#include "lib/theta_quadrature.wgsl"

// ∫ D cos θ dθ along the line of the rectangle whose foot is seen in direction
// g = cos t·gm + sin t·gq; its distance is |h|/cos ψ with cos ψ = g·e.
fn rect_column(t: f32, gm: vec3<f32>, gq: vec3<f32>, e: vec3<f32>, wt: vec3<f32>, ah: f32, l1: f32, l2: f32, L: f32) -> f32 {
    let g = cos(t) * gm + sin(t) * gq;
    let rho = ah / dot(g, e);
    return theta_quadrature(g, wt, rho, l1, l2, L);
}

fn I_rectangle_gauss(p1: vec3<f32>, p2: vec3<f32>, wn_in: vec3<f32>, W: f32) -> f32 {
    let L = length(p2 - p1);
    let wt = normalize(p2 - p1);
    let wb = normalize(cross(wn_in, wt));
    let wn = cross(wt, wb);
    let h = dot(p1, wn);
    if (h == 0.0) {
        return 0.0;
    }
    let ah = abs(h);
    let e = select(-wn, wn, h > 0.0);
    let l1 = dot(p1, wt);
    let l2 = dot(p2, wt);
    let y1 = dot(p1, wb) - 0.5 * W;
    let y2 = y1 + W;
    // As in theta_quadrature: t = ψ − ψm from the bisector gm of the directions to the feet of
    // the two long edges, towards ωb (gq); the half-span is atan2_upper (ψ2 − ψ1 as a
    // difference would lose digits for a thin rectangle, and ψ1 + t from atan2 would carry
    // its error into ρ = |h|/cos ψ).
    let gm = normalize(normalize(h * wn + y1 * wb) + normalize(h * wn + y2 * wb));
    let gq = cross(cross(e, wb), gm);
    let half = 0.5 * atan2_upper(W * ah, ah * ah + y1 * y2);

    // Cuts: where the plane n·p = 0 crosses a short edge, n·(h ωn' + X ωt + Y ωb) = 0,
    // at the t of the direction to (h, Y).
    let n = vec3<f32>(Minv[0][2], Minv[1][2], Minv[2][2]);
    let nb = dot(n, wb);
    var bounds: array<f32, 4>;
    bounds[0] = -half;
    var m = 1u;
    if (nb != 0.0) {
        for (var end = 0u; end < 2u; end++) {
            let Y = -(h * dot(n, wn) + select(l1, l2, end == 1u) * dot(n, wt)) / nb;
            let c = h * wn + Y * wb;
            let t = atan2(dot(c, gq), dot(c, gm));
            if (t > -half && t < half) {
                bounds[m] = t;
                m++;
            }
        }
    }
    bounds[m] = half;
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

    let density = f32(max(NW / 4u, 1u)) / (2.0 * half);
    var I = 0.0;
    for (var piece = 0u; piece + 1u < m; piece++) {
        let v1 = bounds[piece];
        let v2 = bounds[piece + 1u];
        if (v2 <= v1) {
            continue;
        }
        let panels = max(1u, u32(floor(density * (v2 - v1) + 0.5)));
        let hw = 0.5 * (v2 - v1) / f32(panels);
        var sum = 0.0;
        for (var pk = 0u; pk < panels; pk++) {
            let mid = v1 + (2.0 * f32(pk) + 1.0) * hw;
            let dx0 = GL4_X0 * hw;
            let dx1 = GL4_X1 * hw;
            sum += GL4_W0 * (rect_column(mid - dx0, gm, gq, e, wt, ah, l1, l2, L)
                + rect_column(mid + dx0, gm, gq, e, wt, ah, l1, l2, L))
                + GL4_W1 * (rect_column(mid - dx1, gm, gq, e, wt, ah, l1, l2, L)
                + rect_column(mid + dx1, gm, gq, e, wt, ah, l1, l2, L));
        }
        I += sum * hw;
    }
    return I;
}

fn method(scene: Scene) -> f32 {
    return I_rectangle_gauss(scene.p1, scene.p2, scene.rect_normal, scene.rect_width);
}
