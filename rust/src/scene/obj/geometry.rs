//! Polygon geometry (area, unit normal, area centroid) and the placement of positions
//! (up axis, scale, transform).
use crate::math::vec3::{cross, dot, norm, sub, V3};
use crate::scene::obj::options::ObjOptions;
use crate::scene::obj::options::Up;
use crate::scene::obj::options::DEGENERATE_REL_AREA;

/// Area, unit normal and area centroid of a polygon.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolygonGeometry {
    pub area: f64,
    /// Unit normal, counter-clockwise winding seen from its tip.
    pub normal: V3,
    pub centroid: V3,
}

/// Area, normal (Newell's method, as the sum of fan cross products about the first vertex)
/// and area-weighted centroid (signed fan triangles) of a polygon. Exact for planar polygons,
/// convex or not; for a non-planar one it is the projection onto its best-fit plane. `None`
/// for fewer than 3 vertices, non-finite coordinates or ~zero area ([`DEGENERATE_REL_AREA`]).
pub fn polygon_geometry(points: &[V3]) -> Option<PolygonGeometry> {
    if points.len() < 3 {
        return None;
    }
    let o = points[0];
    let (mut lo, mut hi) = (o, o);
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let diag2 = dot(sub(hi, lo), sub(hi, lo));
    let mut n = [0.0; 3];
    for w in points[1..].windows(2) {
        let c = cross(sub(w[0], o), sub(w[1], o));
        n = [n[0] + c[0], n[1] + c[1], n[2] + c[2]];
    }
    let len = norm(n);
    let area = 0.5 * len;
    if !(area.is_finite() && diag2.is_finite() && area > DEGENERATE_REL_AREA * diag2) {
        return None;
    }
    let unit = [n[0] / len, n[1] / len, n[2] / len];
    let (mut wsum, mut acc) = (0.0, [0.0; 3]);
    for w in points[1..].windows(2) {
        let (a, b) = (sub(w[0], o), sub(w[1], o));
        let wt = dot(cross(a, b), unit);
        wsum += wt;
        for k in 0..3 {
            acc[k] += wt * (a[k] + b[k]) / 3.0;
        }
    }
    if !(wsum.is_finite() && wsum > 0.0) {
        return None;
    }
    let centroid = [
        o[0] + acc[0] / wsum,
        o[1] + acc[1] / wsum,
        o[2] + acc[2] / wsum,
    ];
    Some(PolygonGeometry {
        area,
        normal: unit,
        centroid,
    })
}

pub(super) fn linear_row(t: &[[f64; 4]; 4], i: usize) -> V3 {
    [t[i][0], t[i][1], t[i][2]]
}

pub(super) fn det3(m: &[V3; 3]) -> f64 {
    dot(m[0], cross(m[1], m[2]))
}

/// Up conversion, then scale, then the affine transform. Returns whether the transform
/// mirrors (then recomputed normals are flipped to equal the inverse-transpose rule).
pub(super) fn transform_positions(positions: &mut [V3], opts: &ObjOptions) -> bool {
    let s = opts.scale;
    for p in positions.iter_mut() {
        let q = match opts.up {
            Up::Z => *p,
            Up::Y => [p[0], -p[2], p[1]],
        };
        let q = [q[0] * s, q[1] * s, q[2] * s];
        *p = match &opts.transform {
            None => q,
            Some(t) => {
                let r = |i: usize| t[i][0] * q[0] + t[i][1] * q[1] + t[i][2] * q[2] + t[i][3];
                [r(0), r(1), r(2)]
            }
        };
    }
    match &opts.transform {
        None => false,
        Some(t) => det3(&[linear_row(t, 0), linear_row(t, 1), linear_row(t, 2)]) < 0.0,
    }
}
