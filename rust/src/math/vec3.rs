//! 3-vectors as `[f64; 3]` and the few operations on them the geometry needs.

pub type V3 = [f64; 3];

/// The shortest and longest vectors normalised (`v / |v|`): within these `|v|^2` is a normal
/// f64 with room to spare, so the result is a unit vector to a few ulp. Shorter or longer
/// direction vectors (leaf normals, beam axes, up vectors) are refused where they enter.
pub const MIN_NORM: f64 = 1e-150;
pub const MAX_NORM: f64 = 1e150;

#[inline(always)]
pub fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline(always)]
pub fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[inline(always)]
pub fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline(always)]
pub fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}

#[inline(always)]
pub fn is_finite3(a: V3) -> bool {
    a.iter().all(|x| x.is_finite())
}
