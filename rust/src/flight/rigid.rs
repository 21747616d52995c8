//! Rigid-body algebra for the vehicle: 3x3 matrices (row-major), the hat map, the vee of an
//! antisymmetric part, and the polar factor that re-orthonormalises an attitude
//! (docs/model.md §8).

use crate::math::vec3::V3;

/// A 3x3 matrix, row-major: `m[i][j]` is row i, column j.
pub type Mat3 = [[f64; 3]; 3];

/// The identity.
pub const IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// `m v`.
#[inline(always)]
pub fn mul_vec(m: &Mat3, v: V3) -> V3 {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

/// `mᵀ v` (the row vector `v m`).
#[inline(always)]
pub fn tmul_vec(m: &Mat3, v: V3) -> V3 {
    [
        v[0] * m[0][0] + v[1] * m[1][0] + v[2] * m[2][0],
        v[0] * m[0][1] + v[1] * m[1][1] + v[2] * m[2][1],
        v[0] * m[0][2] + v[1] * m[1][2] + v[2] * m[2][2],
    ]
}

/// `a b`.
#[inline(always)]
pub fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut out = [[0.0; 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    out
}

/// `aᵀ b`.
#[inline(always)]
pub fn tmul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut out = [[0.0; 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = a[0][i] * b[0][j] + a[1][i] * b[1][j] + a[2][i] * b[2][j];
        }
    }
    out
}

/// `R hat(w)`: the attitude's time derivative for body rates `w`.
#[inline(always)]
pub fn mul_hat(r: &Mat3, w: V3) -> Mat3 {
    let mut out = [[0.0; 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        let a = r[i];
        // a · hat(w), column by column: hat(w) = [[0, -w2, w1], [w2, 0, -w0], [-w1, w0, 0]]
        row[0] = a[1] * w[2] - a[2] * w[1];
        row[1] = -a[0] * w[2] + a[2] * w[0];
        row[2] = a[0] * w[1] - a[1] * w[0];
    }
    out
}

/// The vee of `(mᵀ − m)/2`'s antisymmetric part, as Lee et al.'s attitude error takes it:
/// `½ vee(mᵀ − m)`.
#[inline(always)]
pub fn half_vee_of_transpose_difference(m: &Mat3) -> V3 {
    // S = mᵀ − m; vee(S) = ½ (S21 − S12, S02 − S20, S10 − S01), and the error halves it again.
    let s = |i: usize, j: usize| m[j][i] - m[i][j];
    [
        0.5 * (0.5 * (s(2, 1) - s(1, 2))),
        0.5 * (0.5 * (s(0, 2) - s(2, 0))),
        0.5 * (0.5 * (s(1, 0) - s(0, 1))),
    ]
}

/// The columns `[c0, c1, c2]` as a matrix.
#[inline(always)]
pub fn from_columns(c0: V3, c1: V3, c2: V3) -> Mat3 {
    [
        [c0[0], c1[0], c2[0]],
        [c0[1], c1[1], c2[1]],
        [c0[2], c1[2], c2[2]],
    ]
}

/// The orthonormal polar factor `U Vᵀ` of `m = U Σ Vᵀ` (the rotation nearest to `m`), by
/// Newton's iteration `X ← (X + X⁻ᵀ)/2`, which converges quadratically from any nonsingular
/// `m` with positive determinant. `None` if `det m <= 0` or the iteration does not settle.
pub fn polar_factor(m: &Mat3) -> Option<Mat3> {
    let mut x = *m;
    for _ in 0..60 {
        let c = cofactors(&x);
        let det = x[0][0] * c[0][0] + x[0][1] * c[0][1] + x[0][2] * c[0][2];
        if !(det > 0.0) || !det.is_finite() {
            return None;
        }
        let mut next = [[0.0; 3]; 3];
        let mut change: f64 = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                next[i][j] = 0.5 * (x[i][j] + c[i][j] / det);
                change = change.max((next[i][j] - x[i][j]).abs());
            }
        }
        x = next;
        if change <= 4.0 * f64::EPSILON {
            return Some(x);
        }
    }
    None
}

/// The cofactor matrix (`det(m) m⁻ᵀ`).
#[inline(always)]
fn cofactors(m: &Mat3) -> Mat3 {
    [
        [
            m[1][1] * m[2][2] - m[1][2] * m[2][1],
            m[1][2] * m[2][0] - m[1][0] * m[2][2],
            m[1][0] * m[2][1] - m[1][1] * m[2][0],
        ],
        [
            m[0][2] * m[2][1] - m[0][1] * m[2][2],
            m[0][0] * m[2][2] - m[0][2] * m[2][0],
            m[0][1] * m[2][0] - m[0][0] * m[2][1],
        ],
        [
            m[0][1] * m[1][2] - m[0][2] * m[1][1],
            m[0][2] * m[1][0] - m[0][0] * m[1][2],
            m[0][0] * m[1][1] - m[0][1] * m[1][0],
        ],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::uniforms;

    fn max_abs_diff(a: &Mat3, b: &Mat3) -> f64 {
        let mut d: f64 = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                d = d.max((a[i][j] - b[i][j]).abs());
            }
        }
        d
    }

    fn rotation(ax: f64, ay: f64, az: f64) -> Mat3 {
        let (sx, cx) = ax.sin_cos();
        let (sy, cy) = ay.sin_cos();
        let (sz, cz) = az.sin_cos();
        let rx = [[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]];
        let ry = [[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]];
        let rz = [[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]];
        mul(&rz, &mul(&ry, &rx))
    }

    #[test]
    fn polar_factor_of_a_rotation_is_the_rotation() {
        let mut u = uniforms(3);
        for _ in 0..100 {
            let r = rotation(6.0 * u(), 6.0 * u(), 6.0 * u());
            let p = polar_factor(&r).unwrap();
            assert!(max_abs_diff(&p, &r) < 1e-15);
        }
    }

    #[test]
    fn polar_factor_removes_a_symmetric_stretch() {
        // m = R S with S symmetric positive definite has the polar factor R exactly.
        let mut u = uniforms(5);
        for _ in 0..100 {
            let r = rotation(6.0 * u(), 6.0 * u(), 6.0 * u());
            let (a, b, c) = (0.3 * u(), 0.3 * u(), 0.3 * u());
            let s = [
                [1.0 + a, 0.1 * b, 0.05 * c],
                [0.1 * b, 1.0 - b, 0.02 * a],
                [0.05 * c, 0.02 * a, 1.0 + c],
            ];
            let p = polar_factor(&mul(&r, &s)).unwrap();
            assert!(max_abs_diff(&p, &r) < 1e-14);
            assert!(max_abs_diff(&tmul(&p, &p), &IDENTITY) < 1e-15);
        }
    }

    #[test]
    fn polar_factor_refuses_a_reflection() {
        let m = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]];
        assert!(polar_factor(&m).is_none());
    }

    #[test]
    fn mul_hat_is_the_product_with_the_hat_matrix() {
        let r = rotation(0.3, -0.7, 2.0);
        let w = [0.4, -1.1, 2.5];
        let hat = [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]];
        assert!(max_abs_diff(&mul_hat(&r, w), &mul(&r, &hat)) < 1e-15);
    }
}
