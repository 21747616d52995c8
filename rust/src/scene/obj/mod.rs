//! OBJ loading (tobj): leaves as disks (centre, unit normal, radius) and the bark mesh.
//!
//! Users bring tree meshes from Blender or any CAD tool. Each face is a leaf or bark face by
//! the name of its object (`o`), group (`g`) or material (`usemtl`), matched against
//! [`ObjOptions::leaf_patterns`]. Leaf faces become disks, one per connected patch of leaf
//! faces ([`Per::Patch`]) or one per polygon ([`Per::Face`]); bark polygons become triangles.
//!
//! tobj parses the geometry. A light pre-scan of the same text gives what tobj does not keep:
//! line numbers for error messages, the `o`/`g`/`usemtl` names of every face (tobj keeps a
//! material only when its MTL file loads) and the file-wide position index of every corner
//! (patch connectivity). Only the OBJ and the MTL files in the OBJ's own folder are read.
//!
//! A face's names are the last `o`, `g` and `usemtl` before it; an `o` line clears the group
//! (a `g` of an earlier object does not carry over), a material carries over as in OBJ.

pub mod build;
pub mod files;
pub mod geometry;
pub mod names;
pub mod options;
pub mod scan;

pub use build::load_obj;
pub use files::MAX_OBJ_BYTES;
pub use geometry::{polygon_geometry, PolygonGeometry};
pub use names::pattern_matches;
pub use options::{ObjMesh, ObjOptions, Per, Up, DEFAULT_LEAF_PATTERNS, DEGENERATE_REL_AREA};

#[cfg(test)]
mod tests;
