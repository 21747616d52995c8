//! What an OBJ load is asked for ([`ObjOptions`]) and what it gives ([`ObjMesh`]).
use crate::error::{Error, Result};
use crate::math::vec3::{norm, V3};
use crate::scene::obj::geometry::det3;
use crate::scene::obj::geometry::linear_row;

/// Leaf patterns used when none are given: a face whose object, group or material name
/// contains one of these (case-insensitive) is a leaf face.
pub const DEFAULT_LEAF_PATTERNS: [&str; 4] = ["leaf", "leaves", "foliage", "needle"];

/// A polygon whose area is at most this times the square of its bounding-box diagonal is
/// degenerate (collinear or coincident vertices).
pub const DEGENERATE_REL_AREA: f64 = 1e-9;

/// Which OBJ axis points up. Results are always z-up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Up {
    /// The file is z-up already.
    #[default]
    Z,
    /// The file is y-up (Blender's OBJ default and many other tools): `(x, y, z) -> (x, -z, y)`.
    Y,
}

/// How leaf faces become disks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Per {
    /// One disk per connected patch of leaf faces (faces sharing a vertex position index).
    #[default]
    Patch,
    /// One disk per leaf polygon.
    Face,
}

/// Options of [`load_obj`](crate::scene::obj::load_obj).
#[derive(Debug, Clone, PartialEq)]
pub struct ObjOptions {
    /// Case-insensitive; a pattern with `*` or `?` is a glob over the whole name, any other
    /// pattern matches as a substring.
    pub leaf_patterns: Vec<String>,
    pub per: Per,
    pub up: Up,
    /// Unit scale applied after the up conversion (0.01 for a file in centimetres).
    pub scale: f64,
    /// Row-major affine transform applied after up and scale (last row `0 0 0 1`).
    pub transform: Option<[[f64; 4]; 4]>,
}

impl Default for ObjOptions {
    fn default() -> Self {
        ObjOptions {
            leaf_patterns: DEFAULT_LEAF_PATTERNS
                .iter()
                .map(|s| s.to_string())
                .collect(),
            per: Per::Patch,
            up: Up::Z,
            scale: 1.0,
            transform: None,
        }
    }
}

impl ObjOptions {
    /// Check the options: non-empty patterns, finite positive scale, and an invertible affine
    /// transform.
    pub fn validate(&self) -> Result<()> {
        for (i, p) in self.leaf_patterns.iter().enumerate() {
            if p.trim().is_empty() {
                return Err(Error::InvalidInput(format!(
                    "leaf pattern {i} is empty; it would match every name"
                )));
            }
        }
        if !(self.scale.is_finite() && self.scale > 0.0) {
            return Err(Error::InvalidInput(format!(
                "scale must be finite and > 0, got {}",
                self.scale
            )));
        }
        if let Some(t) = &self.transform {
            if !t.iter().flatten().all(|x| x.is_finite()) {
                return Err(Error::InvalidInput(format!(
                    "transform must be finite, got {t:?}"
                )));
            }
            let last = t[3];
            if last != [0.0, 0.0, 0.0, 1.0] {
                return Err(Error::InvalidInput(format!(
                    "transform must be affine (last row 0 0 0 1), got last row {last:?}"
                )));
            }
            let rows = [linear_row(t, 0), linear_row(t, 1), linear_row(t, 2)];
            let det = det3(&rows);
            let size = norm(rows[0]) * norm(rows[1]) * norm(rows[2]);
            if !(det.is_finite() && det.abs() > 1e-12 * size) {
                return Err(Error::InvalidInput(format!(
                    "transform is singular (its 3x3 part has determinant {det:e}); it would \
                     flatten the mesh"
                )));
            }
        }
        Ok(())
    }
}

/// Leaves and bark of one OBJ file, z-up, after scale and transform.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ObjMesh {
    pub leaf_centers: Vec<V3>,
    /// Unit normals.
    pub leaf_normals: Vec<V3>,
    /// `sqrt(area / pi)`.
    pub leaf_radii: Vec<f64>,
    pub leaf_areas: Vec<f64>,
    /// Index into `group_names`: the name that made the leaf a leaf (the material, group or
    /// object name, tried in that order).
    pub leaf_groups: Vec<u32>,
    /// Only the vertices used by bark faces.
    pub bark_vertices: Vec<V3>,
    /// Bark polygons, fan-triangulated; indices into `bark_vertices`.
    pub bark_faces: Vec<[u32; 3]>,
    /// Index into `group_names` for each bark triangle: the face's material name, else its
    /// group name, else its object name, else `"default"`.
    pub bark_face_groups: Vec<u32>,
    pub group_names: Vec<String>,
    /// Faces skipped as degenerate (fewer than 3 vertices, repeated vertices, ~zero area).
    pub n_degenerate_faces: usize,
    /// What was skipped or assumed, one message each, naming the file.
    pub warnings: Vec<String>,
}

impl ObjMesh {
    pub fn n_leaves(&self) -> usize {
        self.leaf_centers.len()
    }
}
