//! Reading the files: the light pre-scan of the OBJ text (line numbers, names, corner
//! indices), the MTL files beside it, and the positions from tobj.
use crate::error::{Error, Result};
use crate::math::vec3::V3;
use crate::scene::obj::files::{read_mtl, MtlRefusal};
use std::cell::RefCell;
use std::io::Cursor;
use std::path::{Path, PathBuf};

pub(super) fn obj_err<T>(file: &str, line: usize, msg: impl std::fmt::Display) -> Result<T> {
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
pub(super) enum Element {
    Face,
    Line,
}

/// One `f` or `l` statement, as tobj will list it.
pub(super) struct ScanFace {
    pub(super) line: usize,
    pub(super) kind: Element,
    /// Index into `Scan::name_sets`.
    pub(super) names: u32,
    /// Range in `Scan::corners`.
    pub(super) start: usize,
    pub(super) len: usize,
}

#[derive(Clone, Default)]
pub(super) struct NameSet {
    pub(super) object: Option<String>,
    pub(super) group: Option<String>,
    pub(super) material: Option<String>,
}

#[derive(Default)]
pub(super) struct Scan {
    pub(super) n_positions: usize,
    pub(super) faces: Vec<ScanFace>,
    /// File-wide 0-based position index of every corner of every face.
    pub(super) corners: Vec<u32>,
    pub(super) name_sets: Vec<NameSet>,
}

/// The text after the keyword, trimmed; `None` when empty.
fn rest_of<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    let r = line[key.len()..].trim();
    (!r.is_empty()).then_some(r)
}

/// An `o`, `g` or `usemtl` name, refused when it holds a control character (a name is written
/// back as an OBJ name and matched against leaf patterns; spaces inside it are kept).
fn name_of<'a>(line: &'a str, key: &str) -> std::result::Result<Option<&'a str>, String> {
    let Some(name) = rest_of(line, key) else {
        return Ok(None);
    };
    match name.chars().find(|c| c.is_control()) {
        Some(c) => Err(format!(
            "the {} name {:?} holds the control character U+{:04X}; names must be printable",
            match key {
                "o" => "object",
                "g" => "group",
                _ => "material",
            },
            clip(name),
            c as u32
        )),
        None => Ok(Some(name)),
    }
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
pub(super) fn prescan(text: &str, file: &str, obj_dir: &Path) -> Result<Scan> {
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
                names.object = name_of(line, key)
                    .or_else(|m| obj_err(file, ln, m))?
                    .map(str::to_string);
                names.group = None;
                current = None;
            }
            "g" => {
                names.group = name_of(line, key)
                    .or_else(|m| obj_err(file, ln, m))?
                    .map(str::to_string);
                current = None;
            }
            "usemtl" => {
                let Some(m) = name_of(line, key).or_else(|m| obj_err(file, ln, m))? else {
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
    dir: &Path,
    name: &str,
    file: &str,
    warnings: &mut Vec<String>,
    refused: &mut Option<String>,
) -> tobj::MTLLoadResult {
    let fail = Err(tobj::LoadError::OpenFileFailed);
    let bytes = match read_mtl(full, dir) {
        Ok(b) => b,
        Err(MtlRefusal::NotFound) => {
            warnings.push(format!(
                "{file}: material library '{name}' not found in the OBJ's folder; faces are \
                 still classified by their usemtl names"
            ));
            return fail;
        }
        Err(MtlRefusal::Outside(why)) => {
            refused.get_or_insert(format!("{file}: {}", refusal(name, &why)));
            return fail;
        }
        Err(MtlRefusal::Unreadable(e)) => {
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
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
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
pub(super) fn positions_via_tobj(
    text: &str,
    file: &str,
    obj_dir: &Path,
    scan: &Scan,
    warnings: &mut Vec<String>,
) -> Result<Vec<V3>> {
    // tobj splits lines at spaces only; feed it every other blank (tab, form feed, vertical
    // tab, CR, NBSP, ...) as a space, and lines without leading blanks, as the pre-scan reads
    // them (the names are taken from the pre-scan anyway).
    let odd_blank = |c: char| c.is_whitespace() && c != ' ' && c != '\n';
    let cleaned;
    let text =
        if text.contains(odd_blank) || text.lines().any(|l| l.starts_with(char::is_whitespace)) {
            cleaned = text
                .lines()
                .map(|l| l.trim_start().replace(odd_blank, " "))
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
        let checked = resolve_mtllib(obj_dir, &name).and_then(|full| {
            let dir = obj_dir
                .canonicalize()
                .map_err(|e| format!("the OBJ's folder cannot be resolved: {e}"))?;
            Ok((full, dir))
        });
        match checked {
            Err(why) => {
                refused
                    .borrow_mut()
                    .get_or_insert(format!("{file}: {}", refusal(&name, &why)));
                Err(tobj::LoadError::OpenFileFailed)
            }
            Ok((full, dir)) => load_mtl_file(
                &full,
                &dir,
                &name,
                file,
                &mut mtl_warnings.borrow_mut(),
                &mut refused.borrow_mut(),
            ),
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
