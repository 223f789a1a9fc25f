//! id: line.ltc2023_full
//! derive: line.ltc2023
//! replace: ComputeLineWidthFactor
//! source: the 2023 revision of Heitz & Hill 2017, with the width factor for any M⁻¹ (a fix)
//! minv: full

// line_ltc2023.wgsl (the 2023 listing) with one change: ComputeLineWidthFactor uses the full
// cofactor matrix, since the published one assumes the isotropic-GGX sparsity and is wrong
// for anisotropic (full) M⁻¹. Everything else is the listing.

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
