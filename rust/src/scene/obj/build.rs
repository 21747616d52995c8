//! Building the mesh from the scanned text: leaf faces into disks (per patch or per face),
//! bark polygons into triangles, with the warnings.
use crate::error::{Error, Result};
use crate::math::vec3::{dot, norm, V3};
use crate::scene::obj::files::read_obj;
use crate::scene::obj::geometry::polygon_geometry;
use crate::scene::obj::geometry::transform_positions;
use crate::scene::obj::geometry::PolygonGeometry;
use crate::scene::obj::names::classify;
use crate::scene::obj::names::Labels;
use crate::scene::obj::options::ObjMesh;
use crate::scene::obj::options::ObjOptions;
use crate::scene::obj::options::Per;
use crate::scene::obj::scan::obj_err;
use crate::scene::obj::scan::positions_via_tobj;
use crate::scene::obj::scan::prescan;
use crate::scene::obj::scan::{Element, Scan};
use crate::scene::MAX_COORDINATE;
use std::collections::hash_map::Entry;
use std::collections::{HashMap, HashSet};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

/// Load an OBJ file (and the MTL files beside it): leaf faces as disks, the rest as bark
/// triangles. See the module docs and [`ObjOptions`].
///
/// Errors (`Error::Obj`, naming the file, and the line where there is one): unreadable or
/// non-UTF-8 file, broken numbers, out-of-range indices, no faces, an `mtllib` outside the
/// OBJ's folder. Bad option values give `Error::InvalidInput`.
pub fn load_obj(path: &Path, opts: &ObjOptions) -> Result<ObjMesh> {
    opts.validate()?;
    let file = path.display().to_string();
    let bytes = read_obj(path, &file)?;
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
    // (a byte-order mark, as some Windows tools write, is not part of the first statement)
    load_text(text.strip_prefix('\u{feff}').unwrap_or(text), path, opts)
}

struct LeafFace {
    pub(super) face: usize,
    pub(super) label: u32,
    pub(super) geom: PolygonGeometry,
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
    let mut sorted = sort_faces(&file, &scan, &positions, mirrored, opts)?;
    let dupes = drop_card_backs(&scan, &positions, &mut sorted.leaf_faces);
    let mut mesh = std::mem::take(&mut sorted.mesh);
    match opts.per {
        Per::Face => {
            for lf in &sorted.leaf_faces {
                let g = lf.geom;
                push_disk(&mut mesh, g.centroid, g.normal, g.area, lf.label);
            }
        }
        Per::Patch => patch_disks(&mut mesh, &file, &scan, &sorted.leaf_faces, &mut warnings),
    }
    mesh.n_degenerate_faces = sorted.few.n + sorted.repeated.n + sorted.flat.n;
    summary_warnings(&file, &scan, opts, &sorted, &dupes, &mesh, &mut warnings);
    if mesh.leaf_centers.is_empty() && mesh.bark_faces.is_empty() {
        return Err(Error::Obj(format!(
            "{file}: none of its {n_faces} faces is usable ({} degenerate); nothing to load",
            mesh.n_degenerate_faces
        )));
    }
    mesh.group_names = std::mem::take(&mut sorted.labels.names);
    mesh.warnings = warnings;
    Ok(mesh)
}

/// The faces sorted by [`sort_faces`]: the bark already triangulated into `mesh`, the leaf
/// faces for their disks, the skipped ones counted.
struct Sorted {
    mesh: ObjMesh,
    labels: Labels,
    leaf_faces: Vec<LeafFace>,
    /// Faces whose names make them leaves (usable or not).
    n_leaf_faces: usize,
    /// Skipped: fewer than 3 vertices, a repeated vertex, ~zero area; polylines.
    few: Tally,
    repeated: Tally,
    flat: Tally,
    lines: Tally,
}

/// Every face by its names: leaf faces kept with their geometry, bark polygons fan-triangulated
/// into the mesh with their own vertices, degenerate faces and polylines counted. An error
/// where a vertex is not finite after the scale and transform.
fn sort_faces(
    file: &str,
    scan: &Scan,
    positions: &[V3],
    mirrored: bool,
    opts: &ObjOptions,
) -> Result<Sorted> {
    let classes: Vec<(bool, String)> = scan
        .name_sets
        .iter()
        .map(|s| classify(s, &opts.leaf_patterns))
        .collect();
    let mut out = Sorted {
        mesh: ObjMesh::default(),
        labels: Labels::default(),
        leaf_faces: Vec::new(),
        n_leaf_faces: 0,
        few: Tally::default(),
        repeated: Tally::default(),
        flat: Tally::default(),
        lines: Tally::default(),
    };
    let mesh = &mut out.mesh;
    let mut bark_index = vec![u32::MAX; scan.n_positions];
    let mut pts: Vec<V3> = Vec::new();
    for (fi, f) in scan.faces.iter().enumerate() {
        if f.kind == Element::Line {
            out.lines.add(f.line);
            continue;
        }
        let (is_leaf, name) = &classes[f.names as usize];
        out.n_leaf_faces += usize::from(*is_leaf);
        let idx = &scan.corners[f.start..f.start + f.len];
        if idx.len() < 3 {
            out.few.add(f.line);
            continue;
        }
        if has_repeat(idx) {
            out.repeated.add(f.line);
            continue;
        }
        pts.clear();
        pts.extend(idx.iter().map(|&g| positions[g as usize]));
        if let Some(bad) = pts.iter().find(|p| !p.iter().all(|x| x.is_finite())) {
            return obj_err(
                file,
                f.line,
                format!(
                    "a vertex of this face is not finite after scale/transform: {bad:?} (scale \
                     or transform too large?)"
                ),
            );
        }
        // (as leaves and branches are bounded: beyond that, a face's area may overflow)
        if let Some(bad) = pts
            .iter()
            .find(|p| p.iter().any(|x| x.abs() > MAX_COORDINATE))
        {
            return obj_err(
                file,
                f.line,
                format!(
                    "a vertex of this face lies beyond {MAX_COORDINATE:e} m after \
                     scale/transform: {bad:?} (scale or transform too large?)"
                ),
            );
        }
        let Some(mut geom) = polygon_geometry(&pts) else {
            out.flat.add(f.line);
            continue;
        };
        if mirrored {
            geom.normal = [-geom.normal[0], -geom.normal[1], -geom.normal[2]];
        }
        let label = out.labels.get(name);
        if *is_leaf {
            out.leaf_faces.push(LeafFace {
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
    Ok(out)
}

/// Keep the back of a double-sided card (the same vertex positions as an earlier leaf face)
/// out of the leaf faces; the count of those dropped.
fn drop_card_backs(scan: &Scan, positions: &[V3], leaf_faces: &mut Vec<LeafFace>) -> Tally {
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
    dupes
}

/// A leaf disk of area `area` at `c`, unit normal `n`, in group `label`.
fn push_disk(mesh: &mut ObjMesh, c: V3, n: V3, area: f64, label: u32) {
    mesh.leaf_centers.push(c);
    mesh.leaf_normals.push(n);
    mesh.leaf_radii.push((area / PI).sqrt());
    mesh.leaf_areas.push(area);
    mesh.leaf_groups.push(label);
}

/// One disk per patch of leaf faces (connected through shared vertices within one group), in
/// the order of their first face: the patch's area, its area centroid, and its area-weighted
/// normal with each face turned to the side of the largest face's. A patch whose normals
/// cancel is skipped with a warning.
fn patch_disks(
    mesh: &mut ObjMesh,
    file: &str,
    scan: &Scan,
    leaf_faces: &[LeafFace],
    warnings: &mut Vec<String>,
) {
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
        push_disk(mesh, c, n, area, faces[0].label);
    }
}

/// The warnings that sum up a load: degenerate faces skipped, card backs counted once,
/// polylines ignored, no leaf faces (with the names in the file) or no leaves from them.
fn summary_warnings(
    file: &str,
    scan: &Scan,
    opts: &ObjOptions,
    sorted: &Sorted,
    dupes: &Tally,
    mesh: &ObjMesh,
    warnings: &mut Vec<String>,
) {
    if mesh.n_degenerate_faces > 0 {
        let mut parts = Vec::new();
        for (t, what) in [
            (&sorted.few, "with fewer than 3 vertices"),
            (&sorted.repeated, "with a repeated vertex"),
            (&sorted.flat, "with ~zero area"),
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
    let lines = &sorted.lines;
    if lines.n > 0 {
        warnings.push(format!(
            "{file}: {} polyline element{} (l) ignored; only faces (f) are loaded ({})",
            lines.n,
            if lines.n > 1 { "s" } else { "" },
            lines.at()
        ));
    }
    let n_leaf_faces = sorted.n_leaf_faces;
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
}
