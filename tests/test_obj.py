"""OBJ loading (Rust core, tobj): leaves as disks, bark as triangles, errors, round trips."""

from __future__ import annotations

import math
import sys
import types
import warnings
from pathlib import Path

import numpy as np
import pytest

from batecho import _core
from batecho.trees.leaves import Leaves
from batecho.trees.objfile import (
    DEFAULT_LEAF_PATTERNS,
    Mesh,
    ObjWarning,
    leaf_cards,
    load_obj,
    write_obj,
)

FIXTURES = Path(__file__).resolve().parent / "fixtures" / "obj"
TREES = Path(__file__).resolve().parent / "data" / "trees-cc0"  # CC0 meshes, see LICENSE.txt

PENTAGON_AREA = 2.5 * math.sin(2 * math.pi / 5)


def fixture(name: str) -> Path:
    return FIXTURES / name


def load_quiet(path, **kw) -> Mesh:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ObjWarning)
        return load_obj(path, **kw)


def newell(points: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Reference polygon geometry: area, unit normal, area centroid (fan about vertex 0)."""
    o = points[0]
    cr = np.cross(points[1:-1] - o, points[2:] - o)
    n = cr.sum(axis=0)
    length = np.linalg.norm(n)
    unit = n / length
    w = cr @ unit
    cent = o + (w[:, None] * (points[1:-1] - o + points[2:] - o) / 3).sum(axis=0) / w.sum()
    return 0.5 * length, unit, cent


def raw_faces(path: Path) -> tuple[np.ndarray, list[list[int]]]:
    verts, faces = [], []
    for line in path.read_text().splitlines():
        w = line.split()
        if w and w[0] == "v":
            verts.append([float(x) for x in w[1:4]])
        elif w and w[0] == "f":
            faces.append([int(t.split("/")[0]) - 1 for t in w[1:]])
    return np.array(verts), faces


# --- known polygons ----------------------------------------------------------------------


def test_triangle_disk_has_exact_centroid_normal_radius():
    m = load_obj(fixture("polygons.obj"), per="face")
    lv = m.leaves
    np.testing.assert_allclose(lv.centers[0], [1 / 3, 1 / 3, 0], atol=1e-15)
    np.testing.assert_allclose(lv.normals[0], [0, 0, 1], atol=1e-15)
    assert m.leaf_areas[0] == pytest.approx(0.5, abs=1e-15)
    assert lv.radii[0] == pytest.approx(math.sqrt(0.5 / math.pi), rel=1e-15)


def test_quad_disk_follows_winding_normal():
    lv = load_obj(fixture("polygons.obj"), per="face").leaves
    np.testing.assert_allclose(lv.centers[1], [1, 5, 0.5], atol=1e-15)
    np.testing.assert_allclose(lv.normals[1], [0, -1, 0], atol=1e-15)
    assert lv.radii[1] == pytest.approx(math.sqrt(2 / math.pi), rel=1e-15)


def test_pentagon_disk_area_and_centre():
    m = load_obj(fixture("polygons.obj"), per="face")
    assert m.leaf_areas[2] == pytest.approx(PENTAGON_AREA, rel=1e-14)
    np.testing.assert_allclose(m.leaves.centers[2], [10, 0, 2], atol=1e-14)
    np.testing.assert_allclose(m.leaves.normals[2], [0, 0, 1], atol=1e-15)


def test_nonconvex_polygon_uses_area_centroid_not_vertex_mean():
    m = load_obj(fixture("polygons.obj"), per="face")
    assert m.leaf_areas[3] == pytest.approx(3.0, rel=1e-15)
    np.testing.assert_allclose(m.leaves.centers[3], [20 + 5 / 6, 5 / 6, 0], atol=1e-14)


def test_radius_is_sqrt_area_over_pi():
    m = load_obj(fixture("polygons.obj"), per="face")
    np.testing.assert_allclose(m.leaves.radii, np.sqrt(m.leaf_areas / np.pi), rtol=1e-15)


def test_disks_match_numpy_reference_geometry():
    verts, faces = raw_faces(fixture("polygons.obj"))
    m = load_obj(fixture("polygons.obj"), per="face")
    for i, f in enumerate(faces):
        area, normal, cent = newell(verts[f])
        assert m.leaf_areas[i] == pytest.approx(area, rel=1e-13)
        np.testing.assert_allclose(m.leaves.normals[i], normal, atol=1e-13)
        np.testing.assert_allclose(m.leaves.centers[i], cent, atol=1e-13)


# --- grouping by o / g / usemtl -----------------------------------------------------------


def test_groups_classify_leaves_and_bark_by_g():
    m = load_obj(fixture("groups.obj"))
    names = [m.group_names[g] for g in m.leaf_groups]
    assert names == ["Leaves_A", "Leaves_A", "Foliage_top"]
    assert {m.group_names[g] for g in m.bark_face_groups} == {"trunk"}
    assert m.bark_faces.shape == (2, 3)


def test_patch_joins_faces_sharing_a_vertex():
    m = load_obj(fixture("groups.obj"), per="patch")
    assert m.n_leaves == 3
    np.testing.assert_allclose(m.leaves.centers[0], [1.5, 1.5, 2], atol=1e-15)
    assert m.leaf_areas[0] == pytest.approx(1.0, rel=1e-15)
    np.testing.assert_allclose(m.leaves.normals[0], [0, 0, 1], atol=1e-15)


def test_face_mode_gives_one_disk_per_polygon():
    assert load_obj(fixture("groups.obj"), per="face").n_leaves == 4
    assert load_obj(fixture("groups.obj"), per="patch").n_leaves == 3


def test_patches_do_not_cross_groups():
    m = load_obj(fixture("groups.obj"), per="patch")
    top = m.group_names.index("Foliage_top")
    assert list(m.leaf_groups).count(top) == 1
    np.testing.assert_allclose(
        m.leaves.normals[2], [0, -1 / math.sqrt(2), 1 / math.sqrt(2)], atol=1e-15
    )


def test_objects_classify_by_o():
    m = load_obj(fixture("objects.obj"))
    assert [m.group_names[g] for g in m.leaf_groups] == ["Leaf.001", "Leaf.002"]
    bark = [m.group_names[g] for g in m.bark_face_groups]
    assert bark == ["Trunk", "Trunk", "Branch"]
    assert m.leaf_areas[1] == pytest.approx(0.01, rel=1e-12)


def test_materials_classify_by_usemtl():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = load_obj(fixture("materials.obj"))
    assert m.group_names == ("Bark", "Tree_Leaves")
    assert [m.group_names[g] for g in m.leaf_groups] == ["Tree_Leaves"]
    assert [m.group_names[g] for g in m.bark_face_groups] == ["Bark", "Bark", "Bark"]


def test_missing_mtl_warns_and_still_uses_usemtl_names():
    with pytest.warns(ObjWarning, match="not_here.mtl"):
        m = load_obj(fixture("missing_mtl.obj"))
    assert [m.group_names[g] for g in m.leaf_groups] == ["Tree_Leaves"]
    assert [m.group_names[g] for g in m.bark_face_groups] == ["Bark"]


def test_custom_patterns_substring_is_case_insensitive():
    m = load_obj(fixture("objects.obj"), leaf_patterns=["TRUNK"])
    assert [m.group_names[g] for g in m.leaf_groups] == ["Trunk"]
    assert m.bark_faces.shape == (4, 3)


def test_custom_glob_pattern_matches_whole_name():
    m = load_obj(fixture("objects.obj"), leaf_patterns=["leaf.00?"])
    assert m.n_leaves == 2
    with pytest.warns(ObjWarning, match="no leaf faces"):
        m = load_obj(fixture("objects.obj"), leaf_patterns=["leaf.0?"])
    assert m.leaves is None


def test_default_patterns_are_exported():
    assert DEFAULT_LEAF_PATTERNS == ("leaf", "leaves", "foliage", "needle")


def test_no_leaf_faces_gives_none_and_a_warning():
    with pytest.warns(ObjWarning, match="no leaf faces"):
        m = load_obj(fixture("objects.obj"), leaf_patterns=["acorn"])
    assert m.leaves is None
    assert m.leaf_areas.shape == (0,) and m.leaf_groups.shape == (0,)
    assert m.bark_faces.shape == (6, 3)


# --- double-sided cards and degenerate faces ---------------------------------------------


def test_double_sided_card_is_one_disk_of_its_own_area():
    with pytest.warns(ObjWarning, match="double-sided"):
        m = load_obj(fixture("double_sided.obj"))
    assert m.n_leaves == 3
    np.testing.assert_allclose(m.leaf_areas, [0.02, 0.02, 0.02], rtol=1e-12)


def test_oppositely_wound_card_faces_do_not_cancel():
    m = load_quiet(fixture("double_sided.obj"))
    np.testing.assert_allclose(m.leaves.normals[1], [0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(m.leaves.centers[1], [1.1, 0.05, 1], atol=1e-15)


def test_all_normals_are_unit():
    for name in ["polygons.obj", "groups.obj", "double_sided.obj", "objects.obj"]:
        m = load_quiet(fixture(name))
        np.testing.assert_allclose(np.linalg.norm(m.leaves.normals, axis=1), 1.0, atol=1e-15)


def test_degenerate_faces_are_counted_and_skipped():
    with pytest.warns(ObjWarning, match="4 degenerate faces skipped") as rec:
        m = load_obj(fixture("degenerate.obj"), per="face")
    assert m.n_degenerate_faces == 4
    assert m.n_leaves == 1
    assert m.bark_faces.shape == (1, 3)
    msg = str(rec[0].message)
    assert msg.startswith(str(fixture("degenerate.obj")))
    assert "1 with fewer than 3 vertices (line 18)" in msg
    assert "1 with a repeated vertex (line 16)" in msg
    assert "2 with ~zero area (lines 14, 21)" in msg
    assert np.isfinite(m.leaves.centers).all() and np.isfinite(m.bark_vertices).all()


def test_degenerate_bark_vertices_are_not_kept():
    m = load_quiet(fixture("degenerate.obj"))
    np.testing.assert_allclose(m.bark_vertices, [[5, 0, 0], [6, 0, 0], [5, 0, 1]])


# --- up axis, scale, transform --------------------------------------------------------------


def test_y_up_maps_to_z_up():
    m = load_obj(fixture("yup.obj"), up="y")
    np.testing.assert_allclose(m.leaves.centers[0], [1 / 3, 1 / 3, 2], atol=1e-15)
    np.testing.assert_allclose(m.leaves.normals[0], [0, 0, 1], atol=1e-15)
    lo, hi = m.bounds()
    assert lo[2] == pytest.approx(0) and hi[2] == pytest.approx(3)


def test_z_up_leaves_file_coordinates_alone():
    m = load_obj(fixture("yup.obj"), up="z")
    np.testing.assert_allclose(m.leaves.centers[0], [1 / 3, 2, -1 / 3], atol=1e-15)


def test_up_accepts_upper_case():
    a = load_obj(fixture("yup.obj"), up="Y")
    b = load_obj(fixture("yup.obj"), up="y")
    np.testing.assert_array_equal(a.leaves.centers, b.leaves.centers)


def test_scale_scales_centres_radii_and_areas():
    a = load_obj(fixture("polygons.obj"), per="face")
    b = load_obj(fixture("polygons.obj"), per="face", scale=0.01)
    np.testing.assert_allclose(b.leaves.centers, 0.01 * a.leaves.centers, atol=1e-15)
    np.testing.assert_allclose(b.leaves.radii, 0.01 * a.leaves.radii, rtol=1e-13)
    np.testing.assert_allclose(b.leaf_areas, 1e-4 * a.leaf_areas, rtol=1e-13)
    np.testing.assert_allclose(b.leaves.normals, a.leaves.normals, atol=1e-15)


def test_transform_follows_inverse_transpose_and_area_change():
    t = np.array(
        [[2.0, 0.3, 0.0, 1.0], [0.0, 1.5, -0.4, -2.0], [0.2, 0.0, 0.7, 3.0], [0.0, 0.0, 0.0, 1.0]]
    )
    a = load_obj(fixture("polygons.obj"), per="face")
    b = load_obj(fixture("polygons.obj"), per="face", transform=t)
    lin = t[:3, :3]
    want_n = a.leaves.normals @ np.linalg.inv(lin)  # (A^-T n) as rows
    want_n /= np.linalg.norm(want_n, axis=1)[:, None]
    np.testing.assert_allclose(b.leaves.normals, want_n, atol=1e-13)
    np.testing.assert_allclose(b.leaves.centers, a.leaves.centers @ lin.T + t[:3, 3], atol=1e-12)
    # Area scales by |det A| |A^-T n|.
    factor = abs(np.linalg.det(lin)) * np.linalg.norm(a.leaves.normals @ np.linalg.inv(lin), axis=1)
    np.testing.assert_allclose(b.leaf_areas, a.leaf_areas * factor, rtol=1e-12)
    np.testing.assert_allclose(b.leaves.radii, a.leaves.radii * np.sqrt(factor), rtol=1e-12)


def test_mirror_transform_keeps_inverse_transpose_sign():
    t = np.diag([1.0, 1.0, -1.0, 1.0])
    m = load_obj(fixture("polygons.obj"), per="face", transform=t)
    np.testing.assert_allclose(m.leaves.normals[0], [0, 0, -1], atol=1e-15)


def test_transform_applies_after_up_and_scale():
    t = np.eye(4)
    t[:3, 3] = [10, 20, 30]
    m = load_obj(fixture("yup.obj"), up="y", scale=2.0, transform=t)
    np.testing.assert_allclose(m.leaves.centers[0], [10 + 2 / 3, 20 + 2 / 3, 34], atol=1e-13)


# --- errors ------------------------------------------------------------------------------------


def test_broken_number_error_names_file_line_and_token():
    with pytest.raises(ValueError, match=r"broken_number\.obj: line 3: 'abc' is not a number"):
        load_obj(fixture("broken_number.obj"))


def test_out_of_range_index_error_names_file_and_line():
    with pytest.raises(
        ValueError, match=r"bad_index\.obj: line 6: face refers to vertex 9 .*only 4 vertices"
    ):
        load_obj(fixture("bad_index.obj"))


def test_mtllib_escape_is_refused():
    with pytest.raises(
        ValueError,
        match=r"mtllib_escape\.obj: line 2: refusing to read material "
        r"library '\.\./\.\./secret\.mtl'",
    ):
        load_obj(fixture("mtllib_escape.obj"))


def test_absolute_mtllib_is_refused():
    with pytest.raises(ValueError, match=r"line 2: refusing .*'/etc/passwd'.*absolute path"):
        load_obj(fixture("mtllib_absolute.obj"))


def test_mtllib_symlink_out_of_folder_is_refused(tmp_path):
    outside = tmp_path / "secret.mtl"
    outside.write_text("newmtl leaf\n")
    folder = tmp_path / "model"
    folder.mkdir()
    try:
        (folder / "link.mtl").symlink_to(outside)
    except OSError:
        pytest.skip("cannot create symbolic links here")
    (folder / "m.obj").write_text("mtllib link.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(ValueError, match="outside the OBJ's folder"):
        load_obj(folder / "m.obj")


def test_mtl_in_own_folder_is_read(tmp_path):
    (tmp_path / "m.mtl").write_text("newmtl leafy\nKd 0 1 0\n")
    (tmp_path / "m.obj").write_text(
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl leafy\nf 1 2 3\n"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = load_obj(tmp_path / "m.obj")
    assert m.group_names == ("leafy",)


def test_empty_file_is_an_error():
    with pytest.raises(ValueError, match=r"empty\.obj: the file is empty"):
        load_obj(fixture("empty.obj"))


def test_file_without_faces_is_an_error():
    with pytest.raises(ValueError, match=r"no_faces\.obj: no faces: the file has 3 vertices"):
        load_obj(fixture("no_faces.obj"))


def test_missing_file_raises_file_not_found():
    with pytest.raises(FileNotFoundError, match="nope.obj"):
        load_obj(fixture("nope.obj"))


def test_non_utf8_garbage_is_an_error(tmp_path):
    p = tmp_path / "garbage.obj"
    p.write_bytes(b"v 0 0 0\n\xff\xfe\x00\x81binary\n")
    with pytest.raises(ValueError, match=r"garbage\.obj: line 2: not UTF-8 text"):
        load_obj(p)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", "line 4: vertex index 0 .* invalid"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n", "line 4: relative vertex index -4"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n", "line 4: face refers to texture"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", "line 4: 'x' is not a face corner"),
        ("v 0 0\n", "line 1: a vertex needs 3 numbers"),
        ("v 0 0 nan\n", "line 1: 'nan' is not a finite number"),
        ("v 0 0 0 0\n", "line 1: vertex weight w is 0"),
        ("vn 0 0\n", r"line 1: a normal \(vn\) needs 3 numbers"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl\nf 1 2 3\n", "line 4: 'usemtl' without a material"),
    ],
)
def test_malformed_lines_name_file_and_line(tmp_path, text, match):
    p = tmp_path / "bad.obj"
    p.write_text(text)
    with pytest.raises(ValueError, match=r"bad\.obj: " + match):
        load_obj(p)


def test_a_leaf_too_far_out_is_refused_naming_the_file_and_line(tmp_path):
    p = tmp_path / "far.obj"
    p.write_text("o leaf\nv 0 0 0\nv 1e16 0 0\nv 0 1e16 0\nf 1 2 3\n")
    with pytest.raises(ValueError, match=r"far\.obj.*line 5.*beyond 1e15 m"):
        load_obj(p)


def test_a_bark_face_too_far_out_is_refused_naming_the_file_and_line(tmp_path):
    # (a vertex at 1e300 made the face's area overflow: it was skipped as "~zero area")
    p = tmp_path / "far.obj"
    p.write_text("o trunk\nv 0 0 0\nv 1e300 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(ValueError, match=r"far\.obj.*line 5.*beyond 1e15 m"):
        load_obj(p)


def test_relative_indices_load(tmp_path):
    p = tmp_path / "rel.obj"
    p.write_text("o leaf\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n")
    m = load_obj(p)
    np.testing.assert_allclose(m.leaves.centers[0], [1 / 3, 1 / 3, 0], atol=1e-15)


def test_tabs_and_crlf_are_accepted(tmp_path):
    p = tmp_path / "tabs.obj"
    p.write_bytes(b"o\tleaf one\r\nv 0 0 0\r\nv\t1 0 0\r\nv 0 1 0\r\n  f 1 2 3\r\n")
    m = load_obj(p)
    assert m.group_names == ("leaf one",)


def test_polylines_are_ignored_with_a_warning(tmp_path):
    p = tmp_path / "lines.obj"
    p.write_text("o leaf\nv 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\nf 1 2 3\n")
    with pytest.warns(ObjWarning, match=r"polyline element \(l\) ignored"):
        m = load_obj(p)
    assert m.n_leaves == 1


# --- argument validation -----------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "exc", "match"),
    [
        ({"up": "x"}, ValueError, "up must be one of"),
        ({"per": "leaf"}, ValueError, "per must be one of"),
        ({"scale": 0.0}, ValueError, "scale must be finite and > 0"),
        ({"scale": float("nan")}, ValueError, "scale"),
        ({"scale": "big"}, TypeError, "scale must be a real number"),
        ({"leaf_patterns": "leaf"}, TypeError, "list of strings"),
        ({"leaf_patterns": ["leaf", ""]}, ValueError, r"leaf_patterns\[1\] is empty"),
        ({"leaf_patterns": [3]}, TypeError, r"leaf_patterns\[0\] must be a str"),
        ({"transform": np.eye(3)}, ValueError, r"shape \(4, 4\)"),
        ({"transform": np.diag([1.0, 1.0, 0.0, 1.0])}, ValueError, "singular"),
        ({"transform": np.ones((4, 4))}, ValueError, "affine"),
    ],
)
def test_bad_arguments_raise_clear_errors(kwargs, exc, match):
    with pytest.raises(exc, match=match):
        load_obj(fixture("polygons.obj"), **kwargs)


def test_path_must_be_path_like():
    with pytest.raises(TypeError, match="path must be a str or path-like"):
        load_obj(42)


def test_core_rejects_bad_options_with_value_error():
    with pytest.raises(ValueError, match="scale must be finite"):
        _core.load_obj(str(fixture("polygons.obj")), None, "patch", "z", -1.0, None)
    with pytest.raises(ValueError, match="per must be"):
        _core.load_obj(str(fixture("polygons.obj")), None, "disk", "z", 1.0, None)


def test_core_returns_documented_tuple():
    out = _core.load_obj(str(fixture("groups.obj")), None, "patch", "z", 1.0, None)
    assert len(out) == 11
    c, n, r, a, lg, bv, bf, bg, names, ndeg, warns = out
    assert c.shape == (3, 3) and n.shape == (3, 3) and r.shape == (3,) and a.shape == (3,)
    assert lg.dtype == np.int64 and bf.dtype == np.int64 and bg.dtype == np.int64
    assert bv.shape == (4, 3) and bf.shape == (2, 3) and bg.shape == (2,)
    assert names == ["trunk", "Leaves_A", "Foliage_top"] and ndeg == 0 and warns == []


# --- Mesh ----------------------------------------------------------------------------------------


def test_mesh_arrays_are_read_only_with_documented_dtypes():
    m = load_obj(fixture("groups.obj"))
    assert m.bark_vertices.dtype == np.float64 and m.bark_faces.dtype == np.int64
    for arr in (m.bark_vertices, m.bark_faces, m.leaf_areas, m.leaf_groups, m.bark_face_groups):
        assert not arr.flags.writeable
    assert isinstance(m.leaves, Leaves)
    assert m.source == fixture("groups.obj")


def test_bounds_cover_bark_and_disk_extents():
    m = load_obj(fixture("groups.obj"))
    lo, hi = m.bounds()
    np.testing.assert_allclose(lo, [0, 0, 0], atol=1e-15)
    # The Leaves_A disk (unit area, normal +z, centre (1.5, 1.5, 2)) reaches 1/sqrt(pi) in x, y.
    r = 1 / math.sqrt(math.pi)
    assert hi[0] == pytest.approx(max(1.5 + r, 5 + 1 / 3 + math.sqrt(0.5 / math.pi)))
    assert hi[2] == pytest.approx(3.0)


def test_mesh_from_generated_geometry_gets_default_groups():
    lv = Leaves([[0, 0, 1], [1, 0, 1]], [[0, 0, 1], [0, 1, 0]], [0.1, 0.2])
    m = Mesh(lv, bark_vertices=[[0, 0, 0], [1, 0, 0], [0, 1, 0]], bark_faces=[[0, 1, 2]])
    assert m.group_names == ("leaves", "bark")
    np.testing.assert_allclose(m.leaf_areas, np.pi * np.array([0.01, 0.04]))
    assert list(m.leaf_groups) == [0, 0] and list(m.bark_face_groups) == [1]


def test_mesh_rejects_out_of_range_faces():
    with pytest.raises(ValueError, match="bark_faces indices"):
        Mesh(None, bark_vertices=np.zeros((3, 3)), bark_faces=[[0, 1, 3]])


# --- writing and round trips --------------------------------------------------------------------


def test_leaf_cards_have_disk_area_centre_and_normal():
    lv = Leaves([[1, 2, 3], [0, 0, 0]], [[1, 1, 1], [0, 0, -1]], [0.3, 0.05])
    cards = leaf_cards(lv, 8)
    for i in range(2):
        area, normal, cent = newell(cards[i])
        assert area == pytest.approx(math.pi * lv.radii[i] ** 2, rel=1e-14)
        np.testing.assert_allclose(normal, lv.normals[i], atol=1e-15)
        np.testing.assert_allclose(cent, lv.centers[i], atol=1e-15)


def test_round_trip_gives_same_disks(tmp_path):
    m = load_obj(fixture("groups.obj"))
    back = load_obj(m.to_obj(tmp_path / "out.obj"), per="patch")
    assert back.n_leaves == m.n_leaves
    np.testing.assert_allclose(back.leaves.centers, m.leaves.centers, atol=1e-9)
    np.testing.assert_allclose(back.leaves.normals, m.leaves.normals, atol=1e-9)
    np.testing.assert_allclose(back.leaves.radii, m.leaves.radii, rtol=1e-9)


def test_round_trip_keeps_bark_triangles_and_group_names(tmp_path):
    m = load_quiet(fixture("objects.obj"))
    out = m.to_obj(tmp_path / "out.obj")
    assert (tmp_path / "out.mtl").is_file()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        back = load_obj(out)
    np.testing.assert_array_equal(back.bark_vertices, m.bark_vertices)
    np.testing.assert_array_equal(back.bark_faces, m.bark_faces)
    assert [back.group_names[g] for g in back.bark_face_groups] == [
        m.group_names[g] for g in m.bark_face_groups
    ]
    assert {back.group_names[g] for g in back.leaf_groups} == {"leaves"}


def test_write_obj_writes_several_named_groups(tmp_path):
    lv = Leaves([[0, 0, 1], [1, 0, 1], [2, 0, 1]], [[0, 0, 1]] * 3, [0.1, 0.1, 0.1])
    p = write_obj(
        tmp_path / "forest.obj",
        [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]],
        [[0, 1, 2], [1, 3, 2]],
        lv,
        bark_groups=[0, 1],
        bark_group_names=["trunk_1", "trunk_2"],
        leaf_groups=[0, 1, 1],
        leaf_group_names=["leaves_1", "leaves_2"],
        comment="two trees",
    )
    text = p.read_text()
    assert text.startswith("# two trees")
    assert "g trunk_2" in text and "usemtl leaves_2" in text
    m = load_obj(p)
    assert [m.group_names[g] for g in m.leaf_groups] == ["leaves_1", "leaves_2", "leaves_2"]
    assert [m.group_names[g] for g in m.bark_face_groups] == ["trunk_1", "trunk_2"]
    mtl = (tmp_path / "forest.mtl").read_text()
    assert mtl.count("newmtl") == 4


def test_write_obj_warns_when_a_bark_group_looks_like_leaves(tmp_path):
    with pytest.warns(ObjWarning, match="default leaf patterns"):
        write_obj(
            tmp_path / "x.obj",
            [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
            [[0, 1, 2]],
            bark_group_names=["leafy_bark"],
        )


def test_write_obj_refuses_bad_names(tmp_path):
    with pytest.raises(ValueError, match="control characters"):
        write_obj(
            tmp_path / "x.obj",
            [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
            [[0, 1, 2]],
            bark_group_names=["bark\nf 1 2 3"],
        )


# --- trimesh interop ---------------------------------------------------------------------------


def test_to_trimesh_without_trimesh_raises_clear_import_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "trimesh", None)
    m = load_obj(fixture("groups.obj"))
    with pytest.raises(ImportError, match="optional package 'trimesh'"):
        m.to_trimesh()


def test_to_trimesh_passes_bark_and_leaf_cards(monkeypatch):
    fake = types.ModuleType("trimesh")

    class Trimesh:
        def __init__(self, vertices, faces, process, metadata):
            self.vertices, self.faces, self.process, self.metadata = (
                vertices,
                faces,
                process,
                metadata,
            )

    fake.Trimesh = Trimesh
    monkeypatch.setitem(sys.modules, "trimesh", fake)
    m = load_obj(fixture("groups.obj"))
    tm = m.to_trimesh(sides=6)
    assert tm.vertices.shape == (4 + 3 * 6, 3)
    assert tm.faces.shape == (2 + 3 * 4, 3) and tm.faces.max() == len(tm.vertices) - 1
    assert tm.process is False and len(tm.metadata["face_groups"]) == len(tm.faces)


# --- the real CC0 trees ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("name", "height", "n_patch", "n_face", "leaf_group"),
    [("Tree_2", 5.43, 28, 336, "Tree_Leaves"), ("Birch_1", 9.48, 46, 552, "Birch_Leaves")],
)
def test_cc0_tree_loads_with_plausible_leaves(name, height, n_patch, n_face, leaf_group):
    patch = load_quiet(TREES / f"{name}.obj", up="y")
    face = load_quiet(TREES / f"{name}.obj", up="y", per="face")
    assert patch.n_leaves == n_patch and face.n_leaves == n_face
    assert {patch.group_names[g] for g in patch.leaf_groups} == {leaf_group}
    for m in (patch, face):
        assert np.isfinite(m.leaves.centers).all()
        np.testing.assert_allclose(np.linalg.norm(m.leaves.normals, axis=1), 1.0, atol=1e-12)
        assert (m.leaves.radii > 0).all() and np.isfinite(m.leaves.radii).all()
    assert patch.leaf_areas.sum() == pytest.approx(face.leaf_areas.sum(), rel=1e-12)


@pytest.mark.parametrize("name", ["Tree_2", "Birch_1"])
def test_cc0_tree_is_z_up_with_its_height(name):
    verts, _ = raw_faces(TREES / f"{name}.obj")
    m = load_quiet(TREES / f"{name}.obj", up="y", per="face")
    lo, hi = m.bounds()
    assert lo[2] == pytest.approx(verts[:, 1].min(), abs=1e-9)  # the base: bark vertices
    assert hi[2] - lo[2] == pytest.approx(np.ptp(verts[:, 1]), rel=0.03)
    # Horizontal extent: x stays x, y is the file's -z; disks stay within the mesh (+3 %).
    assert lo[0] >= verts[:, 0].min() - 0.03 * np.ptp(verts[:, 0])
    assert hi[0] <= verts[:, 0].max() + 0.03 * np.ptp(verts[:, 0])
    assert lo[1] >= -verts[:, 2].max() - 0.03 * np.ptp(verts[:, 2])
    assert hi[1] <= -verts[:, 2].min() + 0.03 * np.ptp(verts[:, 2])
    # Bark vertices map exactly.
    assert m.bark_vertices[:, 2].max() <= verts[:, 1].max()


def test_cc0_tree_2_is_about_5_4_units_tall():
    m = load_quiet(TREES / "Tree_2.obj", up="y", per="face")
    lo, hi = m.bounds()
    assert 5.2 < hi[2] - lo[2] < 5.6


def test_birch_degenerate_bark_faces_are_reported():
    with pytest.warns(ObjWarning, match="3 degenerate faces skipped"):
        m = load_obj(TREES / "Birch_1.obj", up="y")
    assert m.n_degenerate_faces == 3


@pytest.mark.parametrize("name", ["Tree_2", "Birch_1"])
def test_cc0_tree_round_trip_gives_same_disks(tmp_path, name):
    m = load_quiet(TREES / f"{name}.obj", up="y")
    back = load_obj(m.to_obj(tmp_path / f"{name}.obj"), per="patch")
    np.testing.assert_allclose(back.leaves.centers, m.leaves.centers, atol=1e-9)
    np.testing.assert_allclose(back.leaves.normals, m.leaves.normals, atol=1e-9)
    np.testing.assert_allclose(back.leaves.radii, m.leaves.radii, rtol=1e-9)
    np.testing.assert_allclose(back.bark_vertices, m.bark_vertices, atol=0)
    np.testing.assert_array_equal(back.bark_faces, m.bark_faces)
