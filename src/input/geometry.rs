//! Host-side geometry through glam. Configurations store vectors as `[f64; 3]` and M⁻¹
//! row-major (`m[row][col]`, docs/conventions.md), as their JSON is written; glam's matrices
//! are column-major, so every conversion goes through the two functions here and nowhere else.
//! (The CPU evaluator's WGSL builtins and the references' deliberate numerics are not host
//! geometry and keep their own arithmetic.)

pub use glam::{DMat3, DVec3};

/// A row-major 3×3 matrix, as configurations and DESIGN write M⁻¹.
pub type Rows = [[f64; 3]; 3];

/// The vector `[x, y, z]`.
pub fn v3(a: [f64; 3]) -> DVec3 {
    DVec3::from_array(a)
}

/// The matrix whose rows are `m[0]`, `m[1]`, `m[2]`.
pub fn mat(m: &Rows) -> DMat3 {
    DMat3::from_cols_array_2d(m).transpose()
}

/// The rows of `m`.
pub fn rows(m: DMat3) -> Rows {
    m.transpose().to_cols_array_2d()
}

/// Array adapters for code that keeps `[f64; 3]` and row-major matrices (the LTC fitter and
/// tables, whose data are written that way): glam does the arithmetic.
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    v3(a).dot(v3(b))
}

pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    v3(a).cross(v3(b)).to_array()
}

pub fn normalize(a: [f64; 3]) -> [f64; 3] {
    v3(a).normalize().to_array()
}

pub fn mat_vec(m: &Rows, v: [f64; 3]) -> [f64; 3] {
    (mat(m) * v3(v)).to_array()
}

pub fn mat_mul(a: &Rows, b: &Rows) -> Rows {
    rows(mat(a) * mat(b))
}

pub fn det(m: &Rows) -> f64 {
    mat(m).determinant()
}

pub fn inverse(m: &Rows) -> Rows {
    rows(mat(m).inverse())
}

pub fn transpose(m: &Rows) -> Rows {
    rows(mat(m).transpose())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A non-symmetric matrix keeps rows and columns apart: M·v with M from rows is the dot
    /// of each row with v, and rows(mat(m)) is m.
    #[test]
    fn rows_stay_rows() {
        let m: Rows = [[1.0, 2.0, 3.0], [0.0, 4.0, 5.0], [1.0, 0.0, 6.0]];
        let v = v3([1.0, -1.0, 2.0]);
        let mv = mat(&m) * v;
        assert_eq!(mv.to_array(), [1.0 - 2.0 + 6.0, -4.0 + 10.0, 1.0 + 12.0]);
        assert_eq!(rows(mat(&m)), m);
        // det by the rule of Sarrus: 1·24 − 2·(−5) + 3·(−4) = 22.
        assert_eq!(mat(&m).determinant(), 22.0);
        // M · M⁻¹ = I, through the row-major adapters.
        let id = mat_mul(&m, &inverse(&m));
        for (i, row) in id.iter().enumerate() {
            for (j, e) in row.iter().enumerate() {
                assert!((e - f64::from(i == j)).abs() < 1e-15, "({i}, {j}): {e}");
            }
        }
        assert_eq!(transpose(&m)[0], [1.0, 0.0, 1.0]);
        assert_eq!(mat_vec(&m, [0.0, 1.0, 0.0]), [2.0, 4.0, 0.0]);
    }
}
