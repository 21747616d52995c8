//! The OBJ reader on arbitrary bytes: `load_obj` must return a mesh or an error, never panic,
//! and a mesh's leaves must be finite disks with unit normals.
#![no_main]

use batecho::scene::obj::{load_obj, ObjOptions, Per};
use libfuzzer_sys::fuzz_target;
use std::path::PathBuf;
use std::sync::OnceLock;

/// A folder of this process's own, with an MTL beside the OBJ.
fn folder() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let d = std::env::temp_dir().join(format!("batecho-cargo-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(d.join("materials.mtl"), "newmtl leaf\nKd 0.2 0.5 0.2\n").unwrap();
        d
    })
}

fuzz_target!(|data: &[u8]| {
    let path = folder().join("case.obj");
    std::fs::write(&path, data).unwrap();
    for per in [Per::Patch, Per::Face] {
        let opts = ObjOptions {
            per,
            ..ObjOptions::default()
        };
        if let Ok(mesh) = load_obj(&path, &opts) {
            for (c, n) in mesh.leaf_centers.iter().zip(&mesh.leaf_normals) {
                assert!(c.iter().all(|x| x.is_finite()), "non-finite centre {c:?}");
                let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                assert!((l - 1.0).abs() < 1e-9, "normal {n:?} is not unit");
            }
            assert!(mesh.leaf_radii.iter().all(|&r| r.is_finite() && r > 0.0));
            let nv = mesh.bark_vertices.len() as u32;
            assert!(mesh.bark_faces.iter().flatten().all(|&i| i < nv));
        }
    }
});
