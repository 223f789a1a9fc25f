//! id: line.ltc2023_full
//! target: line
//! source: the 2023 revision of Heitz & Hill 2017, with the width factor for any M⁻¹ (a fix)
//! minv: full

// The 2023 HLSL listing (line_ltc2023.wgsl) with one change: ComputeLineWidthFactor uses
// the full cofactor matrix, since the published one assumes the isotropic-GGX sparsity
// and is wrong for anisotropic (full) M⁻¹. Everything else is the listing, where
// rcp(x) = 1.0 / x, rsqrt = inverseSqrt, mul(invM, v) = invM * v, `c ? t : f` =
// rcp(x) = 1.0 / x, rsqrt = inverseSqrt, mul(invM, v) = invM * v, `c ? t : f` =
// select(f, t, c). HLSL invM[r][c] is row r, column c; WGSL's column-major invM[c][r].
// `as` is a WGSL reserved word, so the listing's `as` is `as_` here.

const INV_PI: f32 = 0.3183098861;

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
    // Guard against numerical errors.
    let dt = min(1.0, (ns + t1 * t2) * mr);
    let i3 = acos(dt) * (Nz * nr); // angle * cos(θ) / r^2

    // Guard against numerical errors.
    return INV_PI * max(0.0, i12 + i3);
}

// Computes 1 / length(mul(transpose(inverse(invM)), normalize(ortho))) for any invertible invM.
fn ComputeLineWidthFactor(invM: mat3x3<f32>, ortho: vec3<f32>, orthoSq: f32) -> f32 {
    // transpose(inverse(invM)) = 1 / determinant(invM) * cofactor(invM), and row i of the
    // cofactor matrix is the cross product of the other two rows (cyclically).
    let rows = transpose(invM);
    let cof0 = cross(rows[1], rows[2]);
    let cof1 = cross(rows[2], rows[0]);
    let cof2 = cross(rows[0], rows[1]);

    let det = dot(rows[0], cof0);
    let X = vec3<f32>(dot(cof0, ortho), dot(cof1, ortho), dot(cof2, ortho)); // mul(cof, ortho)

    // 1 / length(1/s * X) = abs(s) / length(X).
    return abs(det) * inverseSqrt(dot(X, X) * orthoSq) * orthoSq; // rsqrt(x^2) * x^2 = x
}

fn I_ltc_line(invM: mat3x3<f32>, center: vec3<f32>, axis: vec3<f32>, halfLength: f32) -> f32 {
    let ortho = cross(center, axis);
    let orthoSq = dot(ortho, ortho);

    // Check whether the line passes through the origin.
    var quit = (orthoSq == 0.0);

    // Check whether the light is entirely below the surface.
    // We must test twice, since a linear transformation
    // may bring the light above the surface (a side-effect).
    quit = quit || (center.z + halfLength * abs(axis.z) <= 0.0);

    // Transform into the diffuse configuration.
    // This is a sparse matrix multiplication.
    // Pay attention to the multiplication order
    // (in case your matrices are transposed).
    let C = invM * center;
    let A = invM * axis;

    // Check whether the light is entirely below the surface.
    // We must test twice, since a linear transformation
    // may bring the light below the surface (as expected).
    quit = quit || (C.z + halfLength * abs(A.z) <= 0.0);

    var result = 0.0;

    if (!quit) {
        let w = ComputeLineWidthFactor(invM, ortho, orthoSq);

        result = I_diffuse_line(C, A, halfLength) * w;
    }

    return result;
}

// The listing takes the light as centre, unit axis and half length, the way a shipped
// engine stores a line light; here they are derived from the end points.
fn method(scene: Scene) -> f32 {
    let center = (scene.p1 + scene.p2) * 0.5;
    let axis = normalize(scene.p2 - scene.p1);
    let halfLength = length(scene.p2 - scene.p1) * 0.5;
    return I_ltc_line(Minv, center, axis, halfLength);
}
