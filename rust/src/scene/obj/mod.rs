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

use crate::error::{Error, Result};
use crate::physics::pose::{cross, dot, norm, sub, V3};
use std::cell::RefCell;
use std::collections::hash_map::Entry;
use std::collections::{HashMap, HashSet};
use std::f64::consts::PI;
use std::io::Cursor;
use std::path::{Path, PathBuf};

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

/// Options of [`load_obj`].
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

/// Whether `name` matches `pattern`, case-insensitively: a glob (`*` any run, `?` any one
/// character) over the whole name when the pattern has `*` or `?`, else a substring.
pub fn pattern_matches(pattern: &str, name: &str) -> bool {
    let (p, n) = (pattern.to_lowercase(), name.to_lowercase());
    if p.contains(['*', '?']) {
        let p: Vec<char> = p.chars().collect();
        let n: Vec<char> = n.chars().collect();
        glob(&p, &n)
    } else {
        n.contains(&p)
    }
}

/// Iterative wildcard match with single-star backtracking (linear-ish, never exponential).
fn glob(p: &[char], s: &[char]) -> bool {
    let (mut pi, mut si) = (0, 0);
    let mut star: Option<(usize, usize)> = None;
    while si < s.len() {
        if pi < p.len() && (p[pi] == '?' || p[pi] == s[si]) {
            pi += 1;
            si += 1;
        } else if pi < p.len() && p[pi] == '*' {
            star = Some((pi, si));
            pi += 1;
        } else if let Some((sp, ss)) = star {
            pi = sp + 1;
            si = ss + 1;
            star = Some((sp, ss + 1));
        } else {
            return false;
        }
    }
    p[pi..].iter().all(|&c| c == '*')
}

/// Load an OBJ file (and the MTL files beside it): leaf faces as disks, the rest as bark
/// triangles. See the module docs and [`ObjOptions`].
///
/// Errors (`Error::Obj`, naming the file, and the line where there is one): unreadable or
/// non-UTF-8 file, broken numbers, out-of-range indices, no faces, an `mtllib` outside the
/// OBJ's folder. Bad option values give `Error::InvalidInput`.
pub fn load_obj(path: &Path, opts: &ObjOptions) -> Result<ObjMesh> {
    opts.validate()?;
    let file = path.display().to_string();
    let bytes = std::fs::read(path)
        .map_err(|e| Error::Obj(format!("{file}: cannot read the OBJ file: {e}")))?;
    let text = match std::str::from_utf8(&bytes) {
        Ok(t) => t,
        Err(e) => {
            let at = e.valid_up_to();
            let line = 1 + bytes[..at].iter().filter(|&&b| b == b'\n').count();
            return Err(Error::Obj(format!(
                "{file}: line {line}: not UTF-8 text (invalid byte at offset {at}); is this \
                 really a Wavefront OBJ file?"
            )));
        }
    };
    load_text(text, path, opts)
}

fn obj_err<T>(file: &str, line: usize, msg: impl std::fmt::Display) -> Result<T> {
    Err(Error::Obj(format!("{file}: line {line}: {msg}")))
}

/// At most 80 characters of a line, for messages.
fn clip(line: &str) -> String {
    if line.chars().count() <= 80 {
        line.to_string()
    } else {
        format!("{}...", line.chars().take(77).collect::<String>())
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Element {
    Face,
    Line,
}

/// One `f` or `l` statement, as tobj will list it.
struct ScanFace {
    line: usize,
    kind: Element,
    /// Index into `Scan::name_sets`.
    names: u32,
    /// Range in `Scan::corners`.
    start: usize,
    len: usize,
}

#[derive(Clone, Default)]
struct NameSet {
    object: Option<String>,
    group: Option<String>,
    material: Option<String>,
}

#[derive(Default)]
struct Scan {
    n_positions: usize,
    faces: Vec<ScanFace>,
    /// File-wide 0-based position index of every corner of every face.
    corners: Vec<u32>,
    name_sets: Vec<NameSet>,
}

/// The text after the keyword, trimmed; `None` when empty.
fn rest_of<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    let r = line[key.len()..].trim();
    (!r.is_empty()).then_some(r)
}

fn parse_number(tok: &str, line: &str) -> std::result::Result<f64, String> {
    tok.parse::<f64>()
        .map_err(|_| format!("'{tok}' is not a number in '{}'", clip(line)))
}

/// Check a `v` line the way tobj reads it: 3 numbers, or 4 (x y z w, w != 0) or 6 (x y z r g b).
fn check_vertex(line: &str, toks: &[&str]) -> std::result::Result<(), String> {
    if !matches!(toks.len(), 3 | 4 | 6) {
        return Err(format!(
            "a vertex needs 3 numbers (x y z), or 4 (x y z w) or 6 (x y z r g b); got {}: '{}'",
            toks.len(),
            clip(line)
        ));
    }
    for (k, t) in toks.iter().enumerate() {
        let x = parse_number(t, line)?;
        if k < 4 && !x.is_finite() {
            return Err(format!("'{t}' is not a finite number in '{}'", clip(line)));
        }
        if k == 3 && toks.len() == 4 && x == 0.0 {
            return Err(format!("vertex weight w is 0 in '{}'", clip(line)));
        }
    }
    Ok(())
}

fn check_numbers(
    line: &str,
    toks: &[&str],
    need: usize,
    what: &str,
) -> std::result::Result<(), String> {
    if toks.len() < need {
        return Err(format!(
            "{what} needs {need} numbers, got {}: '{}'",
            toks.len(),
            clip(line)
        ));
    }
    for t in &toks[..need] {
        parse_number(t, line)?;
    }
    Ok(())
}

/// Parse one face corner (`v`, `v/vt`, `v//vn`, `v/vt/vn`, negative = relative); check every
/// index against what is defined before this line. Returns the 0-based position index.
fn parse_corner(tok: &str, counts: [usize; 3]) -> std::result::Result<usize, String> {
    const WHAT: [(&str, &str); 3] = [
        ("vertex", "vertices"),
        ("texture coordinate", "texture coordinates"),
        ("normal", "normals"),
    ];
    let parts: Vec<&str> = tok.split('/').collect();
    if parts.len() > 3 || parts[0].is_empty() {
        return Err(format!(
            "'{tok}' is not a face corner (expected v, v/vt, v//vn or v/vt/vn)"
        ));
    }
    let mut pos = 0;
    for (k, part) in parts.iter().enumerate() {
        if part.is_empty() {
            continue;
        }
        let (one, many) = WHAT[k];
        let x: i64 = part.parse().map_err(|_| {
            format!("'{tok}' is not a face corner: '{part}' is not an integer index")
        })?;
        let n = counts[k];
        let idx = if x > 0 {
            (x - 1) as u64
        } else if x < 0 {
            let back = x.unsigned_abs();
            if back > n as u64 {
                return Err(format!(
                    "relative {one} index {x} in '{tok}' reaches before the first {one} (only \
                     {n} {many} are defined before this line)"
                ));
            }
            n as u64 - back
        } else {
            return Err(format!(
                "{one} index 0 in '{tok}' is invalid (OBJ indices start at 1)"
            ));
        };
        if idx >= n as u64 {
            return Err(format!(
                "face refers to {one} {x} ('{tok}'), but only {n} {many} are defined before \
                 this line"
            ));
        }
        if k == 0 {
            pos = idx as usize;
        }
    }
    Ok(pos)
}

/// Why an `mtllib` path is refused, or where it lies (inside the OBJ's folder).
fn resolve_mtllib(obj_dir: &Path, name: &str) -> std::result::Result<PathBuf, String> {
    let b = name.as_bytes();
    let drive = b.len() >= 2 && b[0].is_ascii_alphabetic() && b[1] == b':';
    let p = Path::new(name);
    if p.is_absolute() || p.has_root() || name.starts_with(['/', '\\']) || drive {
        return Err("it is an absolute path".into());
    }
    if name.split(['/', '\\']).any(|c| c == "..") {
        return Err("it leads out of the OBJ's folder ('..')".into());
    }
    let full = obj_dir.join(p);
    if full.exists() {
        let dir = obj_dir
            .canonicalize()
            .map_err(|e| format!("the OBJ's folder cannot be resolved: {e}"))?;
        let real = full
            .canonicalize()
            .map_err(|e| format!("it cannot be resolved: {e}"))?;
        if !real.starts_with(&dir) {
            return Err(format!(
                "it resolves to {}, outside the OBJ's folder (a symbolic link?)",
                real.display()
            ));
        }
        return Ok(real);
    }
    Ok(full)
}

fn refusal(name: &str, why: &str) -> String {
    format!(
        "refusing to read material library '{name}': {why}; only MTL files in the OBJ's own \
         folder are read"
    )
}

/// The pre-scan: validates every `v`/`vt`/`vn`/`f`/`l`/`usemtl`/`mtllib` line (with line
/// numbers), records the names and file-wide position indices of every face, and refuses
/// `mtllib` paths outside the OBJ's folder.
fn prescan(text: &str, file: &str, obj_dir: &Path) -> Result<Scan> {
    let mut scan = Scan::default();
    let mut counts = [0usize; 3];
    let mut names = NameSet::default();
    let mut current: Option<u32> = None;
    let mut toks: Vec<&str> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let ln = i + 1;
        let line = raw.trim();
        let mut words = line.split_whitespace();
        let Some(key) = words.next() else { continue };
        toks.clear();
        match key {
            "v" => {
                toks.extend(words);
                check_vertex(line, &toks).or_else(|m| obj_err(file, ln, m))?;
                counts[0] += 1;
                if counts[0] > u32::MAX as usize {
                    return obj_err(file, ln, "more than 2^32 - 1 vertices are not supported");
                }
            }
            "vt" => {
                toks.extend(words);
                check_numbers(line, &toks, 2, "a texture coordinate (vt)")
                    .or_else(|m| obj_err(file, ln, m))?;
                counts[1] += 1;
            }
            "vn" => {
                toks.extend(words);
                check_numbers(line, &toks, 3, "a normal (vn)").or_else(|m| obj_err(file, ln, m))?;
                counts[2] += 1;
            }
            "f" | "l" => {
                let set = match current {
                    Some(s) => s,
                    None => {
                        scan.name_sets.push(names.clone());
                        let s = (scan.name_sets.len() - 1) as u32;
                        current = Some(s);
                        s
                    }
                };
                let start = scan.corners.len();
                for tok in words {
                    let v = parse_corner(tok, counts).or_else(|m| obj_err(file, ln, m))?;
                    scan.corners.push(v as u32);
                }
                let kind = if key == "f" {
                    Element::Face
                } else {
                    Element::Line
                };
                let len = scan.corners.len() - start;
                scan.faces.push(ScanFace {
                    line: ln,
                    kind,
                    names: set,
                    start,
                    len,
                });
            }
            "o" => {
                names.object = rest_of(line, key).map(str::to_string);
                names.group = None;
                current = None;
            }
            "g" => {
                names.group = rest_of(line, key).map(str::to_string);
                current = None;
            }
            "usemtl" => {
                let Some(m) = rest_of(line, key) else {
                    return obj_err(file, ln, "'usemtl' without a material name");
                };
                names.material = Some(m.to_string());
                current = None;
            }
            "mtllib" => {
                if let Some(name) = rest_of(line, key) {
                    if let Err(why) = resolve_mtllib(obj_dir, name) {
                        return obj_err(file, ln, refusal(name, &why));
                    }
                }
            }
            _ => {}
        }
    }
    scan.n_positions = counts[0];
    Ok(scan)
}

/// Read one MTL file through tobj. Every problem is a warning: materials only name faces, and
/// the names come from the `usemtl` lines anyway.
fn load_mtl_file(
    full: &Path,
    name: &str,
    file: &str,
    warnings: &mut Vec<String>,
) -> tobj::MTLLoadResult {
    let fail = Err(tobj::LoadError::OpenFileFailed);
    let bytes = match std::fs::read(full) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            warnings.push(format!(
                "{file}: material library '{name}' not found in the OBJ's folder; faces are \
                 still classified by their usemtl names"
            ));
            return fail;
        }
        Err(e) => {
            warnings.push(format!(
                "{file}: cannot read material library '{name}': {e}; faces are still classified \
                 by their usemtl names"
            ));
            return fail;
        }
    };
    let Ok(text) = std::str::from_utf8(&bytes) else {
        warnings.push(format!(
            "{file}: material library '{name}' is not UTF-8 text; ignored"
        ));
        return fail;
    };
    // tobj panics on a colour line with fewer than 3 numbers; refuse those first.
    for (i, line) in text.lines().enumerate() {
        let mut w = line.split_whitespace();
        if matches!(w.next(), Some("Ka" | "Kd" | "Ks" | "Ke")) && w.count() < 3 {
            warnings.push(format!(
                "{file}: material library '{name}' line {}: a colour needs 3 numbers: '{}'; \
                 library ignored",
                i + 1,
                clip(line.trim())
            ));
            return fail;
        }
    }
    match tobj::load_mtl_buf(&mut Cursor::new(text.as_bytes())) {
        Ok(m) => Ok(m),
        Err(e) => {
            warnings.push(format!(
                "{file}: material library '{name}' could not be parsed ({e}); ignored"
            ));
            Err(e)
        }
    }
}

/// Parse with tobj and return the position of every file-wide vertex index used by a face
/// (NaN for unused ones), checking that tobj's faces line up with the pre-scan.
fn positions_via_tobj(
    text: &str,
    file: &str,
    obj_dir: &Path,
    scan: &Scan,
    warnings: &mut Vec<String>,
) -> Result<Vec<V3>> {
    // tobj splits `usemtl`/`mtllib`/`o`/`g` names at the first space only; feed it tabs as
    // spaces and lines without leading blanks (names are taken from the pre-scan anyway).
    let cleaned;
    let text = if text.contains('\t') || text.lines().any(|l| l.starts_with(char::is_whitespace)) {
        cleaned = text
            .lines()
            .map(|l| l.trim_start().replace('\t', " "))
            .collect::<Vec<_>>()
            .join("\n");
        cleaned.as_str()
    } else {
        text
    };
    // All false: faces keep their arity (no triangulation), positions keep their own index,
    // and points and lines stay in, so that tobj's faces line up one to one with the pre-scan.
    let options = tobj::LoadOptions::default();
    let mtl_warnings = RefCell::new(Vec::new());
    let refused = RefCell::new(None::<String>);
    let loader = |p: &Path| -> tobj::MTLLoadResult {
        let name = p.to_string_lossy();
        if name.trim().is_empty() {
            mtl_warnings
                .borrow_mut()
                .push(format!("{file}: an 'mtllib' line names no file; ignored"));
            return Err(tobj::LoadError::OpenFileFailed);
        }
        match resolve_mtllib(obj_dir, &name) {
            Err(why) => {
                refused
                    .borrow_mut()
                    .get_or_insert(format!("{file}: {}", refusal(&name, &why)));
                Err(tobj::LoadError::OpenFileFailed)
            }
            Ok(full) => load_mtl_file(&full, &name, file, &mut mtl_warnings.borrow_mut()),
        }
    };
    let parsed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        tobj::load_obj_buf(&mut Cursor::new(text.as_bytes()), &options, loader)
    }));
    warnings.extend(mtl_warnings.into_inner());
    if let Some(msg) = refused.into_inner() {
        return Err(Error::Obj(msg));
    }
    let models = match parsed {
        Err(_) => {
            return Err(Error::Obj(format!(
                "{file}: tobj failed (panicked) while parsing this file"
            )))
        }
        Ok(Err(e)) => {
            let hint = match e {
                tobj::LoadError::FaceColorOutOfBounds => {
                    " (some vertices carry colours, x y z r g b, and others do not)"
                }
                _ => "",
            };
            return Err(Error::Obj(format!(
                "{file}: tobj could not parse the file: {e}{hint}"
            )));
        }
        Ok(Ok((models, _materials))) => models,
    };
    let mismatch = || {
        Error::Obj(format!(
            "{file}: tobj's faces do not line up with the file's f/l lines (unsupported OBJ \
             construct?)"
        ))
    };
    let mut positions = vec![[f64::NAN; 3]; scan.n_positions];
    let mut k = 0usize;
    for model in &models {
        let mesh = &model.mesh;
        let n_faces = if mesh.face_arities.is_empty() {
            mesh.indices.len() / 3
        } else {
            mesh.face_arities.len()
        };
        let mut offset = 0usize;
        for f in 0..n_faces {
            let arity = mesh.face_arities.get(f).map_or(3, |&a| a as usize);
            let sf = scan.faces.get(k).ok_or_else(mismatch)?;
            let local = mesh
                .indices
                .get(offset..offset + arity)
                .ok_or_else(mismatch)?;
            if sf.len != arity {
                return Err(mismatch());
            }
            for (&li, &g) in local.iter().zip(&scan.corners[sf.start..sf.start + sf.len]) {
                let li = li as usize;
                let p = mesh
                    .positions
                    .get(3 * li..3 * li + 3)
                    .ok_or_else(mismatch)?;
                positions[g as usize] = [p[0], p[1], p[2]];
            }
            offset += arity;
            k += 1;
        }
    }
    if k != scan.faces.len() {
        return Err(mismatch());
    }
    Ok(positions)
}

fn linear_row(t: &[[f64; 4]; 4], i: usize) -> V3 {
    [t[i][0], t[i][1], t[i][2]]
}

fn det3(m: &[V3; 3]) -> f64 {
    dot(m[0], cross(m[1], m[2]))
}

/// Up conversion, then scale, then the affine transform. Returns whether the transform
/// mirrors (then recomputed normals are flipped to equal the inverse-transpose rule).
fn transform_positions(positions: &mut [V3], opts: &ObjOptions) -> bool {
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

/// A face's leaf/bark class and its group label.
fn classify(set: &NameSet, patterns: &[String]) -> (bool, String) {
    let names = [&set.material, &set.group, &set.object];
    for name in names.into_iter().flatten() {
        if patterns.iter().any(|p| pattern_matches(p, name)) {
            return (true, name.clone());
        }
    }
    let label = names.into_iter().flatten().next().cloned();
    (false, label.unwrap_or_else(|| "default".to_string()))
}

#[derive(Default)]
struct Labels {
    names: Vec<String>,
    index: HashMap<String, u32>,
}

impl Labels {
    fn get(&mut self, name: &str) -> u32 {
        if let Some(&i) = self.index.get(name) {
            return i;
        }
        let i = self.names.len() as u32;
        self.names.push(name.to_string());
        self.index.insert(name.to_string(), i);
        i
    }
}

struct LeafFace {
    face: usize,
    label: u32,
    geom: PolygonGeometry,
}

fn has_repeat(idx: &[u32]) -> bool {
    if idx.len() <= 16 {
        (1..idx.len()).any(|i| idx[..i].contains(&idx[i]))
    } else {
        let mut s = idx.to_vec();
        s.sort_unstable();
        s.windows(2).any(|w| w[0] == w[1])
    }
}

fn find(parent: &mut [usize], mut x: usize) -> usize {
    while parent[x] != x {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    x
}

/// A count of skipped faces with the first few line numbers.
#[derive(Default)]
struct Tally {
    n: usize,
    lines: Vec<usize>,
}

impl Tally {
    fn add(&mut self, line: usize) {
        self.n += 1;
        if self.lines.len() < 5 {
            self.lines.push(line);
        }
    }

    fn at(&self) -> String {
        let l: Vec<String> = self.lines.iter().map(|x| x.to_string()).collect();
        let more = if self.n > self.lines.len() {
            ", ..."
        } else {
            ""
        };
        format!(
            "line{} {}{more}",
            if self.n > 1 { "s" } else { "" },
            l.join(", ")
        )
    }
}

fn load_text(text: &str, path: &Path, opts: &ObjOptions) -> Result<ObjMesh> {
    let file = path.display().to_string();
    let obj_dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if text.trim().is_empty() {
        return Err(Error::Obj(format!(
            "{file}: the file is empty; expected a Wavefront OBJ mesh (v and f lines)"
        )));
    }
    let scan = prescan(text, &file, &obj_dir)?;
    let n_faces = scan
        .faces
        .iter()
        .filter(|f| f.kind == Element::Face)
        .count();
    if n_faces == 0 {
        return Err(Error::Obj(format!(
            "{file}: no faces: the file has {} vertices but no 'f' lines",
            scan.n_positions
        )));
    }
    let mut warnings = Vec::new();
    let mut positions = positions_via_tobj(text, &file, &obj_dir, &scan, &mut warnings)?;
    let mirrored = transform_positions(&mut positions, opts);
    let classes: Vec<(bool, String)> = scan
        .name_sets
        .iter()
        .map(|s| classify(s, &opts.leaf_patterns))
        .collect();

    let mut labels = Labels::default();
    let mut mesh = ObjMesh::default();
    let (mut few, mut repeated, mut flat, mut lines) = (
        Tally::default(),
        Tally::default(),
        Tally::default(),
        Tally::default(),
    );
    let mut leaf_faces: Vec<LeafFace> = Vec::new();
    let mut n_leaf_faces = 0usize;
    let mut bark_index = vec![u32::MAX; scan.n_positions];
    let mut pts: Vec<V3> = Vec::new();
    for (fi, f) in scan.faces.iter().enumerate() {
        if f.kind == Element::Line {
            lines.add(f.line);
            continue;
        }
        let (is_leaf, name) = &classes[f.names as usize];
        n_leaf_faces += usize::from(*is_leaf);
        let idx = &scan.corners[f.start..f.start + f.len];
        if idx.len() < 3 {
            few.add(f.line);
            continue;
        }
        if has_repeat(idx) {
            repeated.add(f.line);
            continue;
        }
        pts.clear();
        pts.extend(idx.iter().map(|&g| positions[g as usize]));
        if let Some(bad) = pts.iter().find(|p| !p.iter().all(|x| x.is_finite())) {
            return obj_err(
                &file,
                f.line,
                format!(
                    "a vertex of this face is not finite after scale/transform: {bad:?} (scale \
                     or transform too large?)"
                ),
            );
        }
        let Some(mut geom) = polygon_geometry(&pts) else {
            flat.add(f.line);
            continue;
        };
        if mirrored {
            geom.normal = [-geom.normal[0], -geom.normal[1], -geom.normal[2]];
        }
        let label = labels.get(name);
        if *is_leaf {
            leaf_faces.push(LeafFace {
                face: fi,
                label,
                geom,
            });
            continue;
        }
        let mut corner = |g: u32| -> Result<u32> {
            let b = &mut bark_index[g as usize];
            if *b == u32::MAX {
                if mesh.bark_vertices.len() >= u32::MAX as usize {
                    return Err(Error::Obj(format!(
                        "{file}: more than 2^32 - 1 bark vertices are not supported"
                    )));
                }
                *b = mesh.bark_vertices.len() as u32;
                mesh.bark_vertices.push(positions[g as usize]);
            }
            Ok(*b)
        };
        let first = corner(idx[0])?;
        let mut prev = corner(idx[1])?;
        for &g in &idx[2..] {
            let next = corner(g)?;
            mesh.bark_faces.push([first, prev, next]);
            mesh.bark_face_groups.push(label);
            prev = next;
        }
    }

    // The back of a double-sided card (same vertex positions as an earlier leaf face) once.
    let mut seen: HashSet<Vec<[u64; 3]>> = HashSet::new();
    let mut dupes = Tally::default();
    leaf_faces.retain(|lf| {
        let f = &scan.faces[lf.face];
        let mut key: Vec<[u64; 3]> = scan.corners[f.start..f.start + f.len]
            .iter()
            .map(|&g| positions[g as usize].map(|x| (x + 0.0).to_bits()))
            .collect();
        key.sort_unstable();
        let fresh = seen.insert(key);
        if !fresh {
            dupes.add(f.line);
        }
        fresh
    });

    let push_disk = |mesh: &mut ObjMesh, c: V3, n: V3, area: f64, label: u32| {
        mesh.leaf_centers.push(c);
        mesh.leaf_normals.push(n);
        mesh.leaf_radii.push((area / PI).sqrt());
        mesh.leaf_areas.push(area);
        mesh.leaf_groups.push(label);
    };
    match opts.per {
        Per::Face => {
            for lf in &leaf_faces {
                let g = lf.geom;
                push_disk(&mut mesh, g.centroid, g.normal, g.area, lf.label);
            }
        }
        Per::Patch => {
            let mut parent: Vec<usize> = (0..leaf_faces.len()).collect();
            let mut first: HashMap<(u32, u32), usize> = HashMap::new();
            for (k, lf) in leaf_faces.iter().enumerate() {
                let f = &scan.faces[lf.face];
                for &g in &scan.corners[f.start..f.start + f.len] {
                    match first.entry((lf.label, g)) {
                        Entry::Occupied(e) => {
                            let (a, b) = (find(&mut parent, k), find(&mut parent, *e.get()));
                            if a != b {
                                parent[a.max(b)] = a.min(b);
                            }
                        }
                        Entry::Vacant(e) => {
                            e.insert(k);
                        }
                    }
                }
            }
            // Patches in the order of their first face.
            let mut patch_of_root: HashMap<usize, usize> = HashMap::new();
            let mut patches: Vec<Vec<usize>> = Vec::new();
            for k in 0..leaf_faces.len() {
                let r = find(&mut parent, k);
                let p = *patch_of_root.entry(r).or_insert_with(|| {
                    patches.push(Vec::new());
                    patches.len() - 1
                });
                patches[p].push(k);
            }
            for members in &patches {
                let faces: Vec<&LeafFace> = members.iter().map(|&k| &leaf_faces[k]).collect();
                let largest = faces.iter().fold(faces[0], |best, f| {
                    if f.geom.area > best.geom.area {
                        f
                    } else {
                        best
                    }
                });
                let nl = largest.geom.normal;
                let c0 = faces[0].geom.centroid;
                let (mut area, mut acc, mut nsum) = (0.0, [0.0; 3], [0.0; 3]);
                for f in &faces {
                    let g = f.geom;
                    let s = if dot(g.normal, nl) < 0.0 { -1.0 } else { 1.0 };
                    area += g.area;
                    for k in 0..3 {
                        acc[k] += g.area * (g.centroid[k] - c0[k]);
                        nsum[k] += s * g.area * g.normal[k];
                    }
                }
                let len = norm(nsum);
                if !(len.is_finite() && len > 1e-12 * area) {
                    warnings.push(format!(
                        "{file}: the leaf patch of {} faces starting at line {} has no net \
                         orientation (its face normals cancel); skipped",
                        faces.len(),
                        scan.faces[faces[0].face].line
                    ));
                    continue;
                }
                let c = [
                    c0[0] + acc[0] / area,
                    c0[1] + acc[1] / area,
                    c0[2] + acc[2] / area,
                ];
                let n = [nsum[0] / len, nsum[1] / len, nsum[2] / len];
                push_disk(&mut mesh, c, n, area, faces[0].label);
            }
        }
    }

    mesh.n_degenerate_faces = few.n + repeated.n + flat.n;
    if mesh.n_degenerate_faces > 0 {
        let mut parts = Vec::new();
        for (t, what) in [
            (&few, "with fewer than 3 vertices"),
            (&repeated, "with a repeated vertex"),
            (&flat, "with ~zero area"),
        ] {
            if t.n > 0 {
                parts.push(format!("{} {what} ({})", t.n, t.at()));
            }
        }
        warnings.push(format!(
            "{file}: {} degenerate face{} skipped: {}",
            mesh.n_degenerate_faces,
            if mesh.n_degenerate_faces > 1 { "s" } else { "" },
            parts.join("; ")
        ));
    }
    if dupes.n > 0 {
        warnings.push(format!(
            "{file}: {} leaf face{} repeat the vertex positions of an earlier leaf face (the back \
             of a double-sided card) and counted once ({})",
            dupes.n,
            if dupes.n > 1 { "s" } else { "" },
            dupes.at()
        ));
    }
    if lines.n > 0 {
        warnings.push(format!(
            "{file}: {} polyline element{} (l) ignored; only faces (f) are loaded ({})",
            lines.n,
            if lines.n > 1 { "s" } else { "" },
            lines.at()
        ));
    }
    if n_leaf_faces == 0 {
        let mut seen_names: Vec<&str> = Vec::new();
        for s in &scan.name_sets {
            for n in [&s.object, &s.group, &s.material].into_iter().flatten() {
                if !seen_names.contains(&n.as_str()) && seen_names.len() < 12 {
                    seen_names.push(n);
                }
            }
        }
        warnings.push(format!(
            "{file}: no leaf faces: no object, group or material name matches the leaf patterns \
             {:?} (names in the file: {:?}); everything was loaded as bark",
            opts.leaf_patterns, seen_names
        ));
    } else if mesh.leaf_centers.is_empty() {
        warnings.push(format!(
            "{file}: none of its {n_leaf_faces} leaf faces gave a leaf (all degenerate or \
             cancelling); no leaves"
        ));
    }
    if mesh.leaf_centers.is_empty() && mesh.bark_faces.is_empty() {
        return Err(Error::Obj(format!(
            "{file}: none of its {n_faces} faces is usable ({} degenerate); nothing to load",
            mesh.n_degenerate_faces
        )));
    }
    mesh.group_names = labels.names;
    mesh.warnings = warnings;
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    fn close3(a: V3, b: V3, tol: f64) -> bool {
        (0..3).all(|k| close(a[k], b[k], tol))
    }

    /// Write `files` (name, text) into a fresh temporary folder; returns the first path.
    fn write_files(tag: &str, files: &[(&str, &str)]) -> PathBuf {
        let dir = std::env::temp_dir()
            .join(format!("batecho-obj-test-{}-{tag}", std::process::id()))
            .join("models");
        fs::create_dir_all(&dir).unwrap();
        for (name, text) in files {
            fs::write(dir.join(name), text).unwrap();
        }
        dir.join(files[0].0)
    }

    fn load(tag: &str, text: &str, opts: &ObjOptions) -> Result<ObjMesh> {
        load_obj(&write_files(tag, &[("m.obj", text)]), opts)
    }

    fn per_face() -> ObjOptions {
        ObjOptions {
            per: Per::Face,
            ..Default::default()
        }
    }

    #[test]
    fn triangle_area_normal_centroid() {
        let g = polygon_geometry(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]).unwrap();
        assert!(close(g.area, 0.5, 1e-15));
        assert!(close3(g.normal, [0.0, 0.0, 1.0], 1e-15));
        assert!(close3(g.centroid, [1.0 / 3.0, 1.0 / 3.0, 0.0], 1e-15));
    }

    #[test]
    fn tilted_rectangle_geometry() {
        // A 2 x 1 rectangle in the plane x = z; its winding gives the normal (1, 0, -1)/sqrt 2.
        let s = 2f64.sqrt();
        let pts = [
            [0.0, 0.0, 0.0],
            [0.0, 2.0, 0.0],
            [1.0 / s, 2.0, 1.0 / s],
            [1.0 / s, 0.0, 1.0 / s],
        ];
        let g = polygon_geometry(&pts).unwrap();
        assert!(close(g.area, 2.0, 1e-14));
        assert!(close3(g.normal, [1.0 / s, 0.0, -1.0 / s], 1e-14));
        assert!(close3(g.centroid, [0.5 / s, 1.0, 0.5 / s], 1e-14));
    }

    #[test]
    fn regular_pentagon_area() {
        let pts: Vec<V3> = (0..5)
            .map(|k| {
                let t = 2.0 * PI * k as f64 / 5.0;
                [3.0 + t.cos(), -1.0 + t.sin(), 2.0]
            })
            .collect();
        let g = polygon_geometry(&pts).unwrap();
        let want = 2.5 * (2.0 * PI / 5.0).sin();
        assert!(close(g.area, want, 1e-14));
        assert!(close3(g.centroid, [3.0, -1.0, 2.0], 1e-14));
        assert!(close3(g.normal, [0.0, 0.0, 1.0], 1e-15));
    }

    #[test]
    fn nonconvex_polygon_uses_area_centroid() {
        // An L of three unit squares, starting at its reflex corner.
        let pts = [
            [1.0, 1.0, 0.0],
            [1.0, 2.0, 0.0],
            [0.0, 2.0, 0.0],
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 1.0, 0.0],
        ];
        let g = polygon_geometry(&pts).unwrap();
        assert!(close(g.area, 3.0, 1e-14));
        assert!(close3(g.centroid, [5.0 / 6.0, 5.0 / 6.0, 0.0], 1e-14));
    }

    #[test]
    fn collinear_polygon_is_degenerate() {
        assert!(polygon_geometry(&[[0.0; 3], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0]]).is_none());
        assert!(polygon_geometry(&[[0.0; 3], [1.0, 1.0, 1.0]]).is_none());
        assert!(polygon_geometry(&[[0.0; 3], [1.0, 0.0, 0.0], [f64::NAN, 1.0, 0.0]]).is_none());
    }

    #[test]
    fn patterns_substring_and_glob() {
        assert!(!pattern_matches("leaf", "Tree_LEAVES_1"));
        assert!(pattern_matches("leaves", "Tree_LEAVES_1"));
        assert!(pattern_matches("Leaf", "maple_leaf.001"));
        assert!(pattern_matches("tree_*", "Tree_Leaves"));
        assert!(!pattern_matches("tree_?", "Tree_Leaves"));
        assert!(pattern_matches("*_lea?es", "Birch_Leaves"));
        assert!(!pattern_matches("*leaves", "leaves_b"));
    }

    const TWO_PATCHES: &str = "\
o leaf
v 0 0 0
v 1 0 0
v 0 1 0
v 1 1 0
v 5 0 0
v 6 0 0
v 5 1 0
f 1 2 3
f 2 4 3
f 5 6 7
";

    #[test]
    fn patch_connectivity_by_shared_vertex() {
        let m = load("patches", TWO_PATCHES, &ObjOptions::default()).unwrap();
        assert_eq!(m.n_leaves(), 2);
        assert!(close(m.leaf_areas[0], 1.0, 1e-15));
        assert!(close3(m.leaf_centers[0], [0.5, 0.5, 0.0], 1e-15));
        assert!(close(m.leaf_radii[0], (1.0 / PI).sqrt(), 1e-15));
        assert!(close(m.leaf_areas[1], 0.5, 1e-15));
        let f = load("patches-face", TWO_PATCHES, &per_face()).unwrap();
        assert_eq!(f.n_leaves(), 3);
        assert!(m.bark_faces.is_empty() && m.bark_vertices.is_empty());
        assert_eq!(m.group_names, vec!["leaf".to_string()]);
    }

    #[test]
    fn double_sided_card_counts_once_and_keeps_its_normal() {
        // Front and back quads on the same vertices, then a back copy on separate vertices.
        let text = "g leaf\nv 0 0 0\nv 2 0 0\nv 2 1 0\nv 0 1 0\nf 1 2 3 4\nf 4 3 2 1\n\
                    v 0 0 0\nv 2 0 0\nv 2 1 0\nv 0 1 0\nf 8 7 6 5\n";
        let m = load("card", text, &ObjOptions::default()).unwrap();
        assert_eq!(m.n_leaves(), 1);
        assert!(close(m.leaf_areas[0], 2.0, 1e-15));
        assert!(close3(m.leaf_normals[0], [0.0, 0.0, 1.0], 1e-15));
        assert!(
            m.warnings.iter().any(|w| w.contains("double-sided")),
            "{:?}",
            m.warnings
        );
    }

    #[test]
    fn folded_card_flips_faces_to_the_largest() {
        // Two triangles sharing an edge, wound oppositely; the larger one points +z.
        let text = "o leaf\nv 0 0 0\nv 2 0 0\nv 0 2 0\nv -1 0 0\nf 1 2 3\nf 1 3 4\n";
        let m = load("folded", text, &ObjOptions::default()).unwrap();
        assert_eq!(m.n_leaves(), 1);
        assert!(close(m.leaf_areas[0], 3.0, 1e-15));
        assert!(close3(m.leaf_normals[0], [0.0, 0.0, 1.0], 1e-15));
    }

    #[test]
    fn y_up_maps_to_z_up() {
        let text = "o leaf\nv 0 0 0\nv 1 0 0\nv 0 0 -1\nf 1 2 3\n";
        // Y-up: the triangle lies in y = 0 (ground); z-up: it must lie in z = 0.
        let opts = ObjOptions {
            up: Up::Y,
            ..Default::default()
        };
        let m = load("yup", text, &opts).unwrap();
        assert!(close3(
            m.leaf_centers[0],
            [1.0 / 3.0, 1.0 / 3.0, 0.0],
            1e-15
        ));
        // In the file the normal is (0, +1, 0) (up); after conversion (0, 0, +1).
        assert!(close3(m.leaf_normals[0], [0.0, 0.0, 1.0], 1e-15));
        let tall = "o leaf\nv 0 0 0\nv 1 0 0\nv 0 5 0\nf 1 2 3\n";
        let m = load("yup-tall", tall, &opts).unwrap();
        assert!(close3(
            m.leaf_centers[0],
            [1.0 / 3.0, 0.0, 5.0 / 3.0],
            1e-15
        ));
    }

    #[test]
    fn transform_scales_radius_and_mirror_keeps_normal_rule() {
        let text = "o leaf\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        let t = [
            [2.0, 0.0, 0.0, 1.0],
            [0.0, 3.0, 0.0, 0.0],
            [0.0, 0.0, -1.0, 5.0],
            [0.0, 0.0, 0.0, 1.0],
        ];
        let opts = ObjOptions {
            scale: 0.5,
            transform: Some(t),
            ..Default::default()
        };
        let m = load("xf", text, &opts).unwrap();
        assert!(close(m.leaf_areas[0], 0.5 * 0.25 * 6.0, 1e-15));
        assert!(close3(
            m.leaf_centers[0],
            [1.0 + 1.0 / 3.0, 0.5, 5.0],
            1e-15
        ));
        // Inverse-transpose of diag(2, 3, -1) maps +z to -z.
        assert!(close3(m.leaf_normals[0], [0.0, 0.0, -1.0], 1e-15));
    }

    #[test]
    fn bark_is_fan_triangulated_with_its_own_vertices() {
        let text =
            "o leaf\nv 9 9 9\nf 1 1 1\no trunk\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\n\
                    usemtl wood\nf 2 3 4 5 6\n";
        let m = load("bark", text, &ObjOptions::default()).unwrap();
        assert_eq!(m.bark_faces, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
        assert_eq!(m.bark_vertices.len(), 5);
        assert_eq!(m.group_names[m.bark_face_groups[0] as usize], "wood");
        assert_eq!(m.n_degenerate_faces, 1);
    }

    #[test]
    fn errors_name_file_and_line() {
        let e = load(
            "num",
            "v 0 0 0\nv 1.0 abc 2\nf 1 2 1\n",
            &ObjOptions::default(),
        )
        .unwrap_err();
        let s = e.to_string();
        assert!(
            s.contains("m.obj") && s.contains("line 2") && s.contains("'abc'"),
            "{s}"
        );
        let e = load(
            "idx",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n",
            &ObjOptions::default(),
        );
        let s = e.unwrap_err().to_string();
        assert!(
            s.contains("line 4") && s.contains("vertex 7") && s.contains("only 3"),
            "{s}"
        );
        let s = load("empty", "", &ObjOptions::default())
            .unwrap_err()
            .to_string();
        assert!(s.contains("empty"), "{s}");
        let s = load("nof", "v 0 0 0\n", &ObjOptions::default())
            .unwrap_err()
            .to_string();
        assert!(s.contains("no faces"), "{s}");
        let missing = std::env::temp_dir().join("batecho-no-such-file.obj");
        let s = load_obj(&missing, &ObjOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            s.contains("batecho-no-such-file.obj") && s.contains("cannot read"),
            "{s}"
        );
    }

    #[test]
    fn mtllib_outside_folder_is_refused() {
        for (tag, lib) in [("dotdot", "../secret.mtl"), ("abs", "/etc/passwd")] {
            let text = format!("mtllib {lib}\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
            let s = load(tag, &text, &ObjOptions::default())
                .unwrap_err()
                .to_string();
            assert!(
                s.contains("refusing") && s.contains(lib) && s.contains("line 1"),
                "{s}"
            );
        }
    }

    #[test]
    fn missing_mtl_warns_and_keeps_usemtl_names() {
        let text = "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nusemtl Bark\nf 1 2 3\n\
                    usemtl Tree_Leaves\nf 2 4 3\n";
        let m = load("nomtl", text, &ObjOptions::default()).unwrap();
        assert_eq!(m.n_leaves(), 1);
        assert_eq!(m.bark_faces.len(), 1);
        assert_eq!(m.group_names[m.leaf_groups[0] as usize], "Tree_Leaves");
        assert!(
            m.warnings.iter().any(|w| w.contains("gone.mtl")),
            "{:?}",
            m.warnings
        );
    }

    #[test]
    fn malformed_mtl_does_not_panic() {
        let obj = "mtllib bad.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl mossy\nf 1 2 3\n";
        let p = write_files(
            "badmtl",
            &[("m.obj", obj), ("bad.mtl", "newmtl mossy\nKd 0.5\n")],
        );
        let m = load_obj(&p, &ObjOptions::default()).unwrap();
        assert_eq!(m.n_leaves(), 0);
        assert!(
            m.warnings.iter().any(|w| w.contains("bad.mtl")),
            "{:?}",
            m.warnings
        );
    }

    #[test]
    fn all_degenerate_is_an_error_and_degenerate_leaves_warn() {
        let text = "o leaf\nv 0 0 0\nv 1 1 1\nv 2 2 2\nf 1 2 3\nf 1 1 2\n";
        let s = load("alldeg", text, &ObjOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            s.contains("none of its 2 faces is usable (2 degenerate)"),
            "{s}"
        );
        let text = "o leaf\nv 0 0 0\nv 1 1 1\nv 2 2 2\nv 0 1 0\nf 1 2 3\no bark\nf 1 2 4\n";
        let m = load("degleaf", text, &ObjOptions::default()).unwrap();
        assert_eq!(
            (m.n_leaves(), m.bark_faces.len(), m.n_degenerate_faces),
            (0, 1, 1)
        );
        assert!(
            m.warnings
                .iter()
                .any(|w| w.contains("none of its 1 leaf faces")),
            "{:?}",
            m.warnings
        );
    }

    #[test]
    fn options_are_validated() {
        let bad = ObjOptions {
            scale: 0.0,
            ..Default::default()
        };
        assert!(matches!(bad.validate(), Err(Error::InvalidInput(_))));
        let mut t = [[0.0; 4]; 4];
        t[3][3] = 1.0;
        let bad = ObjOptions {
            transform: Some(t),
            ..Default::default()
        };
        assert!(bad.validate().unwrap_err().to_string().contains("singular"));
        let bad = ObjOptions {
            leaf_patterns: vec![" ".into()],
            ..Default::default()
        };
        assert!(bad.validate().is_err());
    }
}
