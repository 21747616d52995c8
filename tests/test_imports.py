"""The package's imports: no circle between its modules, a light ``import batecho``, and the
public modules and names that load on first use."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("matplotlib", "scipy", "scipy.integrate", "dask", "zarr", "xarray", "tqdm")


def _run(code: str) -> str:
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT
    )
    return out.stdout


def test_no_import_cycle_between_modules():
    res = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "import_graph.py")], capture_output=True, text=True
    )
    assert res.returncode == 0, res.stderr
    assert "no import cycle" in res.stdout


def test_import_graph_finds_a_cycle(tmp_path):
    sys.path.insert(0, str(ROOT / "tools"))
    try:
        import import_graph
    finally:
        sys.path.pop(0)
    pkg = tmp_path / "batecho"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from .sub import b\n")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "sub" / "b.py").write_text("def f():\n    from ..a import g\n")
    problems = import_graph.check(pkg, layers=None)
    assert any("module cycle" in p and "batecho.a" in p for p in problems)
    assert any(p.startswith("subpackage cycle") for p in problems)
    layered = import_graph.check(pkg, layers=(("sub",), ("a",)))
    assert "layer: sub imports a, from a later layer" in layered


def test_import_batecho_loads_no_heavy_module():
    loaded = json.loads(
        _run(
            "import json, sys; import batecho; "
            f"print(json.dumps([m for m in {list(HEAVY)!r} if m in sys.modules]))"
        )
    )
    assert loaded == []


@pytest.mark.parametrize(
    "name", ["paper", "plotting", "scenefile", "trajectories", "treeplots", "reference"]
)
def test_public_modules_load_on_first_use(name):
    import importlib

    import batecho

    mod = getattr(batecho, name)
    assert mod is importlib.import_module(f"batecho.{name}")
    assert name in dir(batecho)


def test_every_public_name_resolves():
    import batecho

    for name in batecho.__all__:
        assert getattr(batecho, name) is not None, name
    assert batecho.SceneFile is batecho.scenefile.SceneFile
    ns: dict = {}
    exec("from batecho import *", ns)
    assert set(batecho.__all__) <= set(ns)


def test_unknown_attribute_raises_attribute_error():
    import batecho

    with pytest.raises(AttributeError, match="no_such_name"):
        batecho.no_such_name  # noqa: B018


def test_the_extension_imported_is_the_stable_abi_build():
    import batecho._core

    name = Path(batecho._core.__file__).name
    assert ".cpython-" not in name, (
        f"batecho imported {batecho._core.__file__}, not the abi3 build: delete the stale "
        "_core.cpython-*.so an older build left in python/batecho/"
    )
