"""The files an OBJ load reads: only regular files, within a size limit, an MTL only if the
file opened lies in the OBJ's folder (checked on the opened file, so a symbolic link swapped
mid-load cannot lead outside); names with control characters refused with file and line;
any blank after ``usemtl`` read as a space."""

from __future__ import annotations

import os
import threading
import warnings
from pathlib import Path

import pytest
from _isolated import call_in_child

import batecho
from batecho.trees.objfile import MAX_OBJ_BYTES

CARD = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"


def write(folder: Path, text: str, name: str = "tree.obj") -> Path:
    p = folder / name
    p.write_text(text, encoding="utf-8")
    return p


def test_a_fifo_given_as_the_obj_path_is_refused_at_once(tmp_path):
    os.mkfifo(tmp_path / "pipe.obj")
    r = call_in_child(f"batecho.load_obj({str(tmp_path / 'pipe.obj')!r})", timeout_s=60)
    assert r["raised"] == "ValueError" and "not a regular file" in r["message"], r


def test_a_fifo_named_in_mtllib_is_skipped_with_a_warning_not_waited_on(tmp_path):
    os.mkfifo(tmp_path / "pipe.mtl")
    obj = write(tmp_path, "mtllib pipe.mtl\n" + CARD + "usemtl leaf\nf 1 2 3 4\n")
    body = f"""
    import warnings
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        m = batecho.load_obj({str(obj)!r})
    assert m.n_leaves == 1
    assert any("not a regular file" in str(x.message) for x in w), [str(x.message) for x in w]
    """
    r = call_in_child(body, timeout_s=60)
    assert r["raised"] is None, r


def test_a_device_is_not_read_until_memory_runs_out():
    r = call_in_child("batecho.load_obj('/dev/zero')", timeout_s=60, memory_gb=2.0)
    assert r["raised"] == "ValueError" and "not a regular file" in r["message"], r


def test_a_file_larger_than_the_limit_is_refused_before_it_is_read(tmp_path):
    big = tmp_path / "big.obj"
    with open(big, "wb") as f:
        f.truncate(MAX_OBJ_BYTES + 1)  # sparse: nothing is written
    r = call_in_child(f"batecho.load_obj({str(big)!r})", timeout_s=60, memory_gb=2.0)
    assert r["raised"] == "ValueError" and "larger than the largest file" in r["message"], r


def test_an_mtl_link_swapped_to_point_outside_during_loads_is_never_read(tmp_path):
    inside = tmp_path / "obj"
    inside.mkdir()
    (inside / "good.mtl").write_text("newmtl leaf\nKd 0.2 0.5 0.2\n")
    outside = tmp_path / "outside.mtl"
    outside.write_text("newmtl leaf\nKd 1\n")  # a load that read it would warn of this line
    link = inside / "lib.mtl"
    obj = write(inside, "mtllib lib.mtl\n" + CARD + "usemtl leaf\nf 1 2 3 4\n")
    stop = threading.Event()

    def swap() -> None:
        targets = [str(inside / "good.mtl"), str(outside)]
        k = 0
        while not stop.is_set():
            if k % 4 < 2:  # an atomic swap of the link
                tmp = inside / "lib.tmp"
                tmp.unlink(missing_ok=True)
                os.symlink(targets[k % 2], tmp)
                os.replace(tmp, link)
            else:  # gone for a moment, then back pointing elsewhere
                link.unlink(missing_ok=True)
                os.symlink(targets[k % 2], link)
            k += 1

    os.symlink(inside / "good.mtl", link)
    t = threading.Thread(target=swap)
    t.start()
    read_outside = refused = 0
    try:
        for _ in range(2000):
            with warnings.catch_warnings(record=True) as w:
                warnings.simplefilter("always")
                try:
                    batecho.load_obj(obj)
                except ValueError as exc:
                    assert "refusing to read material library 'lib.mtl'" in str(exc)
                    refused += 1
            read_outside += any("a colour needs 3 numbers" in str(x.message) for x in w)
    finally:
        stop.set()
        t.join()
    assert read_outside == 0
    assert 0 < refused < 2000  # refused while the link pointed outside, read while inside


@pytest.mark.parametrize("char", ["\t", "\x00", "\r", "\x07"])
@pytest.mark.parametrize("key", ["o", "g", "usemtl"])
def test_a_name_with_a_control_character_is_refused_naming_file_and_line(tmp_path, key, char):
    obj = write(tmp_path, CARD + f"{key} leaf{char}x\nf 1 2 3 4\n")
    with pytest.raises(ValueError, match=rf"tree\.obj: line 5: the .* name .*U\+{ord(char):04X}"):
        batecho.load_obj(obj)


@pytest.mark.parametrize("blank", ["\x0c", "\x0b", "\u00a0", "\r", "\t"])
def test_any_blank_after_usemtl_separates_the_material_name(tmp_path, blank):
    obj = write(tmp_path, CARD + f"usemtl{blank}leaf\nf 1 2 3 4\n")
    mesh = batecho.load_obj(obj)
    assert mesh.n_leaves == 1
    assert list(mesh.group_names) == ["leaf"]


def test_a_byte_order_mark_does_not_hide_the_first_vertex(tmp_path):
    text = "v 0 0 0\nv .05 0 0\nv 0 .05 0\nv 0 0 .05\no leaf\nf 1 2 3\n"
    plain = batecho.load_obj(write(tmp_path, text, "plain.obj"))
    (tmp_path / "bom.obj").write_bytes(b"\xef\xbb\xbf" + text.encode())
    marked = batecho.load_obj(tmp_path / "bom.obj")
    assert marked.leaves.centers.tolist() == plain.leaves.centers.tolist()


def test_a_byte_order_mark_does_not_hide_the_first_name(tmp_path):
    (tmp_path / "bom.obj").write_bytes(b"\xef\xbb\xbfo leaf\n" + CARD.encode() + b"f 1 2 3 4\n")
    mesh = batecho.load_obj(tmp_path / "bom.obj")
    assert mesh.n_leaves == 1 and list(mesh.group_names) == ["leaf"]
