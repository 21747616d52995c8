//! Tests of OBJ loading: geometry, patterns, patches, transforms, errors and warnings.
use crate::error::{Error, Result};
use crate::math::vec3::V3;
use crate::scene::obj::build::load_obj;
use crate::scene::obj::geometry::polygon_geometry;
use crate::scene::obj::names::pattern_matches;
use crate::scene::obj::options::ObjMesh;
use crate::scene::obj::options::ObjOptions;
use crate::scene::obj::options::Per;
use crate::scene::obj::options::Up;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

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
    let text = "o leaf\nv 9 9 9\nf 1 1 1\no trunk\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\n\
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

#[test]
fn a_name_with_a_control_character_is_an_error_naming_file_and_line() {
    for (key, name) in [("o", "leaf\tx"), ("g", "a\u{0}b"), ("usemtl", "c\rd")] {
        let text = format!("v 0 0 0\nv 1 0 0\nv 0 1 0\n{key} {name}\nf 1 2 3\n");
        let s = load("ctrl", &text, &ObjOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            s.contains("line 4") && s.contains("control character"),
            "{s}"
        );
    }
}

#[test]
fn any_blank_after_usemtl_separates_the_name() {
    for blank in ['\u{c}', '\u{b}', '\u{a0}', '\t'] {
        let text = format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl{blank}leaf\nf 1 2 3\n");
        let m = load("blank", &text, &ObjOptions::default()).unwrap();
        assert_eq!(m.n_leaves(), 1, "{blank:?}");
    }
}

#[cfg(unix)]
#[test]
fn what_is_not_a_regular_file_is_refused_at_once() {
    let dir = write_files("fifo", &[("x.txt", "")])
        .parent()
        .unwrap()
        .to_path_buf();
    let fifo = dir.join("pipe.obj");
    let _ = std::fs::remove_file(&fifo);
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    for path in [fifo.as_path(), Path::new("/dev/zero"), dir.as_path()] {
        let s = load_obj(path, &ObjOptions::default())
            .unwrap_err()
            .to_string();
        assert!(s.contains("not a regular file"), "{s}");
    }
}

#[test]
fn a_file_over_the_size_limit_is_refused_before_it_is_read() {
    let big = write_files("big", &[("big.obj", "")]);
    std::fs::File::create(&big)
        .unwrap()
        .set_len(crate::scene::obj::MAX_OBJ_BYTES + 1)
        .unwrap();
    let s = load_obj(&big, &ObjOptions::default())
        .unwrap_err()
        .to_string();
    assert!(s.contains("larger than the largest file"), "{s}");
}

#[cfg(unix)]
#[test]
fn an_mtl_linked_from_outside_the_folder_is_refused_as_opened() {
    let outside = write_files("outside", &[("x.mtl", "newmtl leaf\n")]);
    let obj = write_files(
        "linked",
        &[(
            "m.obj",
            "mtllib x.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        )],
    );
    let link = obj.parent().unwrap().join("x.mtl");
    let _ = std::fs::remove_file(&link);
    std::os::unix::fs::symlink(&outside, &link).unwrap();
    let s = load_obj(&obj, &ObjOptions::default())
        .unwrap_err()
        .to_string();
    assert!(s.contains("refusing") && s.contains("outside"), "{s}");
}
