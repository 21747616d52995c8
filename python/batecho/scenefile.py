"""Scene files: a scene, a sonar, a flight and the outputs wanted, described in TOML.

``batecho simulate SCENE.toml`` reads one (see ``examples/flight.toml``)::

    seed = 7                      # every random draw (leaves, trees, tree positions)

    [scene]                       # kind = "leaf_box" | "obj" | "tree" | "forest"
    kind = "forest"
    n_trees = 3                   # forest: the paper's IPP conditioned on 3 trees
    [scene.tree]                  # parameters of batecho.trees.grow_tree

    [sonar]                       # any batecho.Sonar parameter
    beamwidth_deg = 30

    [flight]                      # path = "circle" | "line" | "figure_eight" | "waypoints"
    path = "circle"               # around the mean tree position by default
    radius = 6.2
    altitude = 5.0
    heading = "center"
    mode = "flown"                # or "kinematic"
    quadrotor = "crazyflie"
    pulse_rate_hz = 10            # or n_pulses = 15
    [flight.mount]                # batecho.SonarMount
    pitch_deg = -5

    [output]
    plots = ["scene", "impulses", "echo_image", "spectrogram"]

Every key is checked: an unknown key, a value of the wrong type or out of its choices raises
:class:`ScenefileError` naming the file, the table and the key. Lengths in metres, times in
seconds, angles in degrees (keys ending ``_deg``), frequencies in Hz.
"""

from __future__ import annotations

import dataclasses
import difflib
import json
import math
import os
import time
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .leaves import Leaves
from .poses import Poses
from .scene import Scene
from .sonar import Beam, Sonar

__all__ = [
    "PLOTS",
    "FlightPlan",
    "RunResult",
    "SceneFile",
    "ScenefileError",
    "SimulationSetup",
    "run_scenefile",
    "sample_indices",
    "setup_scenefile",
    "simulate_options",
    "sonar_params",
]

#: The plots a scene file may ask for in ``[output] plots``.
PLOTS = ("scene", "impulses", "echo_image", "spectrogram", "spectrum")


class ScenefileError(ValueError):
    """A problem in a scene file: the message names the file, the table and the key."""


_REQUIRED = object()
_OMIT = object()  # not given and not passed on: the library's own default applies


@dataclass(frozen=True)
class _Opt:
    kind: str
    default: Any = _OMIT
    choices: tuple = ()
    doc: str = ""


def _table(fields: dict[str, _Opt]) -> _Opt:
    return _Opt("table", {}, doc="", choices=(fields,))


# ----------------------------------------------------------------------------- the schema

_BEAM = {
    "beamwidth_deg": _Opt("float", doc="full -3 dB width, deg"),
    "sigma_deg": _Opt("float_or_pair", doc="Gaussian sigma, deg, or [sigma_az, sigma_el]"),
    "rotation_deg": _Opt("float"),
    "center_deg": _Opt("pair", doc="[az0, el0], deg"),
    "amplitude": _Opt("float"),
}
_ATMOSPHERE = {
    "temperature_c": _Opt("float"),
    "relative_humidity": _Opt("float"),
    "pressure_pa": _Opt("float"),
}
_SONAR = {
    "beamwidth_deg": _Opt("float", doc="full -3 dB beamwidth, deg (default 30)"),
    "horseshoe_bat_khz": _Opt("float", doc="beamwidth from the horseshoe-bat fit at this kHz"),
    "fs": _Opt("float"),
    "n_samples": _Opt("int_or_auto", doc='record length, or "auto" (from the farthest leaf)'),
    "record_tail_s": _Opt("float", doc='with n_samples = "auto": ring-down after the last echo'),
    "band_hz": _Opt("pair"),
    "sound_speed": _Opt("float"),
    "lobe": _Opt("str", choices=("detectable", "cone")),
    "threshold_db": _Opt("float"),
    "cone_half_angle_deg": _Opt("float"),
    "max_range_m": _Opt("float"),
    "r0_m": _Opt("float"),
    "p0_pa": _Opt("float"),
    "p_ref_pa": _Opt("float"),
    "leaf_model": _Opt("str", choices=("paper", "physical_optics")),
    "spreading": _Opt("bool"),
    "gain": _Opt("float"),
    "window": _Opt("str", choices=("hann", "rect")),
    "min_range_m": _Opt("float"),
    "too_close": _Opt("str", choices=("raise", "skip")),
    "min_ka": _Opt("float"),
    "beam": _table(_BEAM),
    "receiver": _table(_BEAM),
    "absorption": _table(_ATMOSPHERE),
}
_SCENE_KINDS = ("leaf_box", "obj", "tree", "forest")
_TREE_MODELS = ("grow_tree", "lsystem")
_SCENE = {
    "kind": _Opt("str", _REQUIRED, choices=_SCENE_KINDS),
    # leaf_box
    "density_per_m3": _Opt("float"),
    "box": _Opt("box", doc="[[x0, x1], [y0, y1], [z0, z1]], m"),
    "radius_mean_m": _Opt("float"),
    "radius_sd_m": _Opt("float"),
    "normal_angle_mean_deg": _Opt("float"),
    "normal_angle_sd_deg": _Opt("float"),
    # obj
    "path": _Opt("str"),
    "leaf_patterns": _Opt("strs"),
    "up": _Opt("str", choices=("z", "y")),
    "per": _Opt("str", choices=("patch", "face")),
    "scale": _Opt("float"),
    "offset": _Opt("vec3", doc="translation applied after loading, m"),
    # tree and forest
    "model": _Opt("str", "grow_tree", choices=_TREE_MODELS),
    "position": _Opt("vec2", doc="tree position (x, y), m"),
    "positions": _Opt("points2", doc="tree positions [[x, y], ...], m"),
    "n_trees": _Opt("int", doc="condition the IPP on this many trees"),
    "intensity": _Opt("intensity", doc='"paper" or a table of squared-exponential bumps'),
    "window": _Opt("window", doc="[xmin, xmax, ymin, ymax], m"),
    "tree": _Opt("table", {}, doc="parameters of the tree model"),
    "variants": _Opt("int", doc="grow this many trees and reuse them (instancing)"),
    "scale_sd": _Opt("float", doc="tree sizes exp(scale_sd z), z ~ N(0, 1)"),
}
_SCENE_KEYS_BY_KIND = {
    "leaf_box": {
        "density_per_m3",
        "box",
        "radius_mean_m",
        "radius_sd_m",
        "normal_angle_mean_deg",
        "normal_angle_sd_deg",
    },
    "obj": {"path", "leaf_patterns", "up", "per", "scale", "offset"},
    "tree": {"model", "position", "tree"},
    "forest": {
        "model",
        "positions",
        "n_trees",
        "intensity",
        "window",
        "tree",
        "variants",
        "scale_sd",
    },
}
_PATHS = ("circle", "line", "figure_eight", "waypoints")
_HEADINGS = ("velocity", "center", "look_at", "fixed")
_MOUNT = {
    "offset": _Opt("vec3", doc="body frame, m"),
    "pitch_deg": _Opt("float"),
    "yaw_deg": _Opt("float"),
    "roll_deg": _Opt("float"),
}
_FLIGHT = {
    "path": _Opt("str", "circle", choices=_PATHS),
    "mode": _Opt("str", "kinematic", choices=("kinematic", "flown")),
    "center": _Opt("vec2", doc="circle / figure-eight centre (x, y), m; default the scene's"),
    "radius": _Opt("float", doc="m; default 6.2 (circle), 3.1 (figure eight)"),
    "altitude": _Opt("float", 5.0),
    "heading": _Opt("str", "velocity", choices=_HEADINGS),
    "target": _Opt("vec3", doc="look-at point / end of a line, m"),
    "yaw_deg": _Opt("float"),
    "start_angle_deg": _Opt("float", 0.0),
    "start": _Opt("vec3", doc="start of a line, m"),
    "stop_distance": _Opt("float", 1.0),
    "points": _Opt("points3", doc="waypoints [[x, y, z], ...], m"),
    "closed": _Opt("bool", False),
    "speed": _Opt("float", 2.0),
    "n_pulses": _Opt("int"),
    "pulse_rate_hz": _Opt("float"),
    "duration": _Opt("float"),
    "quadrotor": _Opt("str", "crazyflie", choices=("crazyflie", "research")),
    "dt": _Opt("float", 0.002),
    "mount": _table(_MOUNT),
}
_FLIGHT_ONLY = {
    "center": ("circle", "figure_eight"),
    "radius": ("circle", "figure_eight"),
    "start_angle_deg": ("circle", "figure_eight"),
    "start": ("line",),
    "stop_distance": ("line",),
    "points": ("waypoints",),
    "closed": ("waypoints",),
}
_OUTPUT = {
    "plots": _Opt("plots", ["scene", "impulses", "echo_image", "spectrogram"]),
    "npz": _Opt("bool", True),
    "impulse": _Opt("bool", True, doc="store the impulse responses in the NPZ"),
    "obj": _Opt("bool", False, doc="write the scene as scene.obj"),
    "dpi": _Opt("int", 120),
    "sample_points": _Opt("int", 4, doc="pulses whose impulse responses and lobes are drawn"),
    "max_scene_points": _Opt("int", 6000),
}
_TOP = {
    "seed": _Opt("int", 0),
    "description": _Opt("str", ""),
    "method": _Opt("str", "exact", choices=("exact", "fast", "auto")),
    "tol": _Opt("float", 1e-12, doc="relative L2 error of the spectrum for method fast/auto"),
    "scene": _table(_SCENE),
    "sonar": _table(_SONAR),
    "flight": _table(_FLIGHT),
    "output": _table(_OUTPUT),
}


# ------------------------------------------------------------------------------- checking


def _tname(v: Any) -> str:
    if isinstance(v, bool):
        return "a boolean"
    if isinstance(v, int):
        return "an integer"
    if isinstance(v, float):
        return "a number"
    if isinstance(v, str):
        return "a string"
    if isinstance(v, list):
        return "an array"
    if isinstance(v, dict):
        return "a table"
    return type(v).__name__


def _is_num(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _fail(where: str, key: str, msg: str) -> ScenefileError:
    return ScenefileError(f"[{where}] {key}: {msg}")


def _nums(v: Any, n: int | None, where: str, key: str, what: str) -> list[float]:
    if not isinstance(v, list) or not all(_is_num(x) for x in v) or (n and len(v) != n):
        raise _fail(where, key, f"expected {what}, got {v!r} ({_tname(v)})")
    out = [float(x) for x in v]
    if not all(math.isfinite(x) for x in out):
        raise _fail(where, key, f"values must be finite, got {v!r}")
    return out


def _points(v: Any, dim: int, where: str, key: str) -> list[list[float]]:
    what = f"an array of [{', '.join('xyz'[:dim])}] points"
    if not isinstance(v, list) or not v:
        raise _fail(where, key, f"expected {what}, got {v!r} ({_tname(v)})")
    return [_nums(p, dim, where, key, what) for p in v]


def _check_value(opt: _Opt, v: Any, where: str, key: str) -> Any:
    k = opt.kind
    if k == "float":
        if not _is_num(v) or not math.isfinite(float(v)):
            raise _fail(where, key, f"expected a number, got {v!r} ({_tname(v)})")
        return float(v)
    if k == "int":
        if isinstance(v, bool) or not isinstance(v, int):
            raise _fail(where, key, f"expected an integer, got {v!r} ({_tname(v)})")
        return v
    if k == "int_or_auto":
        if v == "auto":
            return v
        if isinstance(v, bool) or not isinstance(v, int):
            raise _fail(where, key, f'expected an integer or "auto", got {v!r} ({_tname(v)})')
        return v
    if k == "bool":
        if not isinstance(v, bool):
            raise _fail(where, key, f"expected true or false, got {v!r} ({_tname(v)})")
        return v
    if k == "str":
        if not isinstance(v, str):
            raise _fail(where, key, f"expected a string, got {v!r} ({_tname(v)})")
        if opt.choices and v not in opt.choices:
            raise _fail(
                where, key, f"{v!r} is not one of {', '.join(repr(c) for c in opt.choices)}"
            )
        return v
    if k == "strs":
        if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
            raise _fail(where, key, f"expected an array of strings, got {v!r}")
        return list(v)
    if k == "plots":
        if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
            raise _fail(where, key, f"expected an array of plot names, got {v!r}")
        bad = [x for x in v if x not in PLOTS]
        if bad:
            raise _fail(where, key, f"unknown plot {bad[0]!r}; choose from {', '.join(PLOTS)}")
        return list(v)
    if k == "vec2":
        return _nums(v, 2, where, key, "[x, y]")
    if k == "vec3":
        return _nums(v, 3, where, key, "[x, y, z]")
    if k == "pair":
        return _nums(v, 2, where, key, "two numbers")
    if k == "float_or_pair":
        if _is_num(v):
            return float(v)
        return _nums(v, 2, where, key, "a number or two numbers")
    if k == "window":
        return _nums(v, 4, where, key, "[xmin, xmax, ymin, ymax]")
    if k == "box":
        what = "[[x0, x1], [y0, y1], [z0, z1]]"
        if not isinstance(v, list) or len(v) != 3:
            raise _fail(where, key, f"expected {what}, got {v!r} ({_tname(v)})")
        return [_nums(p, 2, where, key, what) for p in v]
    if k == "points2":
        return _points(v, 2, where, key)
    if k == "points3":
        return _points(v, 3, where, key)
    if k == "intensity":
        if v == "paper":
            return v
        if isinstance(v, dict):
            allowed = {"centers", "length_scales", "weights"}
            _unknown(v, allowed, f"{where}.{key}")
            missing = allowed - set(v)
            if missing:
                raise _fail(where, key, f"missing {', '.join(sorted(missing))}")
            out = {"centers": _points(v["centers"], 2, f"{where}.{key}", "centers")}
            ls = v["length_scales"]
            out["length_scales"] = (
                _nums(ls, None, f"{where}.{key}", "length_scales", "an array of numbers (m)")
                if ls and all(_is_num(x) for x in ls)
                else _points(ls, 2, f"{where}.{key}", "length_scales")
            )
            out["weights"] = _nums(
                v["weights"], None, f"{where}.{key}", "weights", "an array of numbers (per m^2)"
            )
            return out
        raise _fail(where, key, f'expected "paper" or a table, got {v!r} ({_tname(v)})')
    if k == "table":
        if not isinstance(v, dict):
            raise _fail(where, key, f"expected a table, got {v!r} ({_tname(v)})")
        if opt.choices:
            return _check_table(v, opt.choices[0], f"{where}.{key}" if where else key)
        return dict(v)
    raise AssertionError(k)  # pragma: no cover


def _unknown(d: Mapping, allowed, where: str) -> None:
    for key in d:
        if key not in allowed:
            near = difflib.get_close_matches(key, list(allowed), n=1)
            hint = f' (did you mean "{near[0]}"?)' if near else ""
            label = f"[{where}]" if where else "top level"
            raise ScenefileError(
                f'{label}: unknown key "{key}"{hint}; allowed: {", ".join(sorted(allowed))}'
            )


def _check_table(d: Mapping, schema: dict[str, _Opt], where: str) -> dict[str, Any]:
    _unknown(d, schema, where)
    out: dict[str, Any] = {}
    for key, opt in schema.items():
        if key in d:
            out[key] = _check_value(opt, d[key], where, key)
        elif opt.default is _REQUIRED:
            raise ScenefileError(f'[{where}]: missing key "{key}"')
        elif opt.default is not _OMIT:
            dflt = opt.default
            out[key] = (
                _check_table({}, opt.choices[0], f"{where}.{key}" if where else key)
                if opt.kind == "table" and opt.choices
                else (dict(dflt) if isinstance(dflt, dict) else dflt)
            )
    return out


def _validate(doc: dict) -> dict[str, Any]:
    if "scene" not in doc:
        _unknown(doc, _TOP, "")
        raise ScenefileError(
            'missing table [scene] (with kind = "leaf_box", "obj", "tree" or "forest")'
        )
    cfg = _check_table(doc, _TOP, "")
    sc = cfg["scene"]
    kind = sc["kind"]
    for key in doc["scene"]:
        if key != "kind" and key not in _SCENE_KEYS_BY_KIND[kind]:
            raise ScenefileError(
                f'[scene] {key}: not used with kind = "{kind}"; keys for this kind: '
                f"{', '.join(sorted(_SCENE_KEYS_BY_KIND[kind]))}"
            )
    if kind == "obj" and "path" not in sc:
        raise ScenefileError('[scene]: kind = "obj" needs path = "tree.obj"')
    if kind == "forest" and "positions" in sc and ("n_trees" in sc or "intensity" in sc):
        raise ScenefileError("[scene]: give positions, or n_trees/intensity, not both")
    if kind == "forest" and "n_trees" in sc and sc["n_trees"] < 1:
        raise ScenefileError(f"[scene] n_trees: must be >= 1, got {sc['n_trees']}")
    fl = cfg["flight"]
    given = set(doc.get("flight", {}))
    for key, paths in _FLIGHT_ONLY.items():
        if key in given and fl["path"] not in paths:
            raise ScenefileError(
                f"[flight] {key}: only used with path = {' or '.join(repr(p) for p in paths)}, "
                f'not "{fl["path"]}"'
            )
    if fl["mode"] == "kinematic" and ({"quadrotor", "dt"} & given):
        raise ScenefileError('[flight] quadrotor, dt: only used with mode = "flown"')
    if "n_pulses" in fl and "pulse_rate_hz" in fl:
        raise ScenefileError("[flight]: give n_pulses or pulse_rate_hz, not both")
    if "n_pulses" in fl and fl["n_pulses"] < 1:
        raise ScenefileError(f"[flight] n_pulses: must be >= 1, got {fl['n_pulses']}")
    if "n_pulses" not in fl and "pulse_rate_hz" not in fl:
        fl["n_pulses"] = 15
    if fl["path"] == "line" and "start" not in fl:
        raise ScenefileError('[flight]: path = "line" needs start = [x, y, z]')
    if fl["path"] == "waypoints" and "points" not in fl:
        raise ScenefileError('[flight]: path = "waypoints" needs points = [[x, y, z], ...]')
    if fl["heading"] == "fixed" and "yaw_deg" not in fl:
        raise ScenefileError('[flight]: heading = "fixed" needs yaw_deg')
    if "yaw_deg" in fl and fl["heading"] != "fixed":
        raise ScenefileError('[flight] yaw_deg: only used with heading = "fixed"')
    for key in ("sample_points", "dpi", "max_scene_points"):
        if cfg["output"][key] < 1:
            raise ScenefileError(f"[output] {key}: must be >= 1, got {cfg['output'][key]}")
    return cfg


# --------------------------------------------------------------------------- scene files


@dataclass
class SceneFile:
    """A validated scene file: ``config`` holds each table with its defaults filled in."""

    config: dict[str, Any]
    text: str = ""
    path: Path | None = None

    @property
    def base_dir(self) -> Path:
        """Relative paths in the file (an OBJ) are taken from the file's folder."""
        return self.path.parent if self.path is not None else Path.cwd()

    @property
    def seed(self) -> int:
        return int(self.config["seed"])

    @classmethod
    def from_string(cls, text: str, path: str | os.PathLike | None = None) -> SceneFile:
        """Parse TOML ``text`` (``path``: where it came from, for messages and relative paths)."""
        name = str(path) if path is not None else "<string>"
        try:
            doc = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ScenefileError(f"{name}: invalid TOML: {exc}") from None
        try:
            cfg = _validate(doc)
        except ScenefileError as exc:
            raise ScenefileError(f"{name}: {exc}") from None
        return cls(cfg, text, None if path is None else Path(path))

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any], base_dir: str | os.PathLike | None = None):
        """Check a scene description given as a dict (the parsed TOML); relative paths are
        taken from ``base_dir`` (default: the working folder)."""
        try:
            cfg = _validate(dict(doc))
        except ScenefileError as exc:
            raise ScenefileError(f"<dict>: {exc}") from None
        path = None if base_dir is None else Path(base_dir) / "<dict>"
        return cls(cfg, "", path)

    @classmethod
    def from_path(cls, path: str | os.PathLike) -> SceneFile:
        """Read and check a scene file."""
        p = Path(path)
        if not p.exists():
            raise FileNotFoundError(f"scene file not found: {p}")
        if p.is_dir():
            raise ScenefileError(f"{p} is a folder, not a scene file")
        try:
            text = p.read_text(encoding="utf-8")
        except UnicodeDecodeError as exc:
            raise ScenefileError(f"{p}: not UTF-8 text ({exc})") from None
        return cls.from_string(text, p)

    def _err(self, msg: str) -> ScenefileError:
        name = str(self.path) if self.path is not None else "<string>"
        return ScenefileError(f"{name}: {msg}")

    # -- building ----------------------------------------------------------------------
    def build_sonar(self) -> Sonar:
        """The :class:`batecho.Sonar` of ``[sonar]``."""
        cfg = dict(self.config["sonar"])
        kw: dict[str, Any] = {}
        for key, val in cfg.items():
            if key in ("beam", "receiver"):
                if val:
                    try:
                        kw[key] = Beam(
                            **{k: tuple(v) if isinstance(v, list) else v for k, v in val.items()}
                        )
                    except (TypeError, ValueError) as exc:
                        raise self._err(f"[sonar.{key}] {exc}") from None
            elif key == "absorption":
                if val:
                    from .absorption import Atmosphere

                    try:
                        kw[key] = Atmosphere(**val)
                    except (TypeError, ValueError) as exc:
                        raise self._err(f"[sonar.absorption] {exc}") from None
            elif key == "band_hz":
                kw[key] = tuple(val)
            else:
                kw[key] = val
        hb = kw.pop("horseshoe_bat_khz", None)
        try:
            if hb is not None:
                if "beamwidth_deg" in kw or "beam" in kw:
                    raise ValueError("give horseshoe_bat_khz or beamwidth_deg / [sonar.beam]")
                return Sonar.horseshoe_bat(hb, **kw)
            return Sonar(**kw)
        except (TypeError, ValueError) as exc:
            raise self._err(f"[sonar] {exc}") from None

    def build_scene(self, rng: np.random.Generator) -> tuple[Any, Leaves, np.ndarray | None]:
        """``(scene object, leaves, tree positions (t, 2) or None)`` of ``[scene]``; the scene
        object is what gets drawn (a forest with its bark, an OBJ mesh, or the leaves)."""
        sc = self.config["scene"]
        kind = sc["kind"]
        try:
            if kind == "leaf_box":
                from .examples import canonical_leaf_box

                kw = {k: v for k, v in sc.items() if k in _SCENE_KEYS_BY_KIND["leaf_box"]}
                if "box" in kw:
                    kw["box"] = tuple(tuple(b) for b in kw["box"])
                leaves = canonical_leaf_box(rng, **kw)
                return leaves, leaves, None
            if kind == "obj":
                from .meshio import load_obj

                p = Path(sc["path"])
                p = p if p.is_absolute() else self.base_dir / p
                if not p.exists():
                    raise self._err(f"[scene] path: OBJ file not found: {p}")
                T = None
                if any(sc.get("offset", (0.0, 0.0, 0.0))):
                    T = np.eye(4)
                    T[:3, 3] = sc["offset"]
                mesh = load_obj(
                    p,
                    leaf_patterns=sc.get("leaf_patterns"),
                    up=sc.get("up", "z"),
                    per=sc.get("per", "patch"),
                    scale=sc.get("scale", 1.0),
                    transform=T,
                )
                if mesh.leaves is None:
                    raise self._err(f"[scene] path: {p} has no leaf faces (see leaf_patterns)")
                return mesh, mesh.leaves, None
            from .paper import draw_tree_positions, make_forest

            model, params = sc.get("model", "grow_tree"), dict(sc.get("tree", {}))
            if kind == "tree":
                pos = np.asarray([sc.get("position", [0.0, 0.0])])
            elif "positions" in sc:
                pos = np.asarray(sc["positions"])
            else:
                lam = _intensity(sc.get("intensity", "paper"))
                from .ipp import PAPER_WINDOW, sample_ipp

                window = tuple(sc.get("window", PAPER_WINDOW))
                if "n_trees" in sc:
                    pos = draw_tree_positions(sc["n_trees"], rng, lam, window)
                else:
                    pos = sample_ipp(lam, window, rng)
                    if len(pos) == 0:
                        raise self._err(
                            "[scene]: the IPP draw holds no tree; set n_trees, or another seed"
                        )
            extra = {k: sc[k] for k in ("variants", "scale_sd") if k in sc}
            try:
                forest = make_forest(pos, rng, model, params, **extra)
            except TypeError as exc:
                raise self._err(f"[scene.tree] {exc}") from None
            return forest, forest.leaves, pos
        except RuntimeError as exc:
            raise self._err(f'[scene] kind = "{kind}": {exc}') from None
        except (TypeError, ValueError) as exc:
            if isinstance(exc, ScenefileError):
                raise
            raise self._err(f"[scene] {exc}") from None

    def build_flight(self, center_xy: np.ndarray) -> FlightPlan:
        """The pulse poses of ``[flight]``; ``center_xy`` is the scene's centre (m), the
        default centre of circles and figure eights and the default look-at target."""
        try:
            return _flight_plan(self.config["flight"], np.asarray(center_xy, dtype=np.float64))
        except ScenefileError as exc:
            raise self._err(str(exc)) from None
        except (TypeError, ValueError) as exc:
            raise self._err(f"[flight] {exc}") from None


def _intensity(spec: Any):
    from .ipp import SquaredExponentialMixture, paper_intensity

    if spec == "paper":
        return paper_intensity()
    return SquaredExponentialMixture(
        centers=np.asarray(spec["centers"]),
        length_scales=np.asarray(spec["length_scales"]),
        weights=np.asarray(spec["weights"]),
    )


# ------------------------------------------------------------------------------- flights


@dataclass
class FlightPlan:
    """Pulse poses and what to draw: ``poses``; ``pulse_times`` (p,) s or None (kinematic
    pulses placed by count); ``path_points`` (k, 3) m, the flown or planned path; ``x`` and
    ``x_label``, the echo image's axis; ``flight``, the :class:`batecho.Flight` when flown;
    ``closed`` whether the path is a loop."""

    poses: Poses
    pulse_times: np.ndarray | None
    path_points: np.ndarray
    x: np.ndarray
    x_label: str
    closed: bool
    flight: Any = None
    trajectory: Any = None


def _flight_plan(fl: dict[str, Any], center_xy: np.ndarray) -> FlightPlan:
    from . import trajectories as tj
    from .quadrotor import Quadrotor, SonarMount

    path, mode = fl["path"], fl["mode"]
    z = fl["altitude"]
    heading = fl["heading"]
    center = np.asarray(fl.get("center", center_xy), dtype=np.float64)
    target = fl.get("target")
    head_kw: dict[str, Any] = {"heading": heading}
    if heading in ("center", "look_at") and target is not None:
        head_kw["target"] = target
    if heading == "fixed":
        head_kw["yaw_deg"] = fl["yaw_deg"]
    if path == "figure_eight" and heading in ("center", "look_at") and target is None:
        raise ScenefileError(
            '[flight] heading: "center" looks at the middle of a figure eight, which is on the '
            "path; give target = [x, y, z] (e.g. above the middle) or another heading"
        )
    if heading in ("center", "look_at") and target is None and path == "waypoints":
        head_kw["target"] = [center_xy[0], center_xy[1], z]
    mount = SonarMount(**fl["mount"]) if fl.get("mount") else None
    closed = path in ("circle", "figure_eight") or (path == "waypoints" and fl["closed"])
    default_target = np.array([center_xy[0], center_xy[1], z])
    if path == "circle":
        radius = fl.get("radius", 6.2)
        traj = tj.Circle(
            center, radius, z, fl["speed"], start_angle_deg=fl["start_angle_deg"], **head_kw
        )
    elif path == "figure_eight":
        radius = fl.get("radius", 3.1)
        traj = tj.FigureEight(
            center, radius, z, speed=fl["speed"], start_angle_deg=fl["start_angle_deg"], **head_kw
        )
    elif path == "line":
        start = np.asarray(fl["start"], dtype=np.float64)
        tgt = np.asarray(target if target is not None else default_target, dtype=np.float64)
        length = float(np.linalg.norm(tgt - start))
        if not length > fl["stop_distance"]:
            raise ScenefileError(
                f"[flight] start: {length:.3g} m from the target, not more than "
                f"stop_distance = {fl['stop_distance']:g} m"
            )
        end = tgt - fl["stop_distance"] * (tgt - start) / length
        kw = dict(head_kw)
        if heading in ("center", "look_at"):
            kw = {"heading": "look_at", "target": tgt}
        traj = tj.Line(start, end, fl["speed"], **kw)
    else:
        traj = tj.Waypoints(fl["points"], fl["speed"], closed=fl["closed"], **head_kw)
    duration = fl.get("duration", traj.duration)
    flight = None
    if mode == "flown":
        quad = Quadrotor.crazyflie() if fl["quadrotor"] == "crazyflie" else Quadrotor.research()
        flight = quad.fly(traj, duration, dt=fl["dt"])
    if "pulse_rate_hz" in fl:
        rate = fl["pulse_rate_hz"]
        times = flight.pulse_times(rate) if flight is not None else traj.times(rate, duration)
    else:
        n = fl["n_pulses"]
        times = (
            duration * np.arange(n) / n
            if closed
            else (np.linspace(0.0, duration, n) if n > 1 else np.zeros(1))
        )
    if flight is not None:
        poses = flight.poses(times, mount=mount)
        step = max(1, len(flight.positions) // 2000)
        path_pts = np.asarray(flight.positions[::step])
        return FlightPlan(poses, times, path_pts, times, "pulse time (s)", closed, flight, traj)
    path_pts = np.asarray(traj.position(np.linspace(0.0, duration, 400)))
    if "n_pulses" in fl and path in ("circle", "line", "figure_eight"):
        # Kinematic pulses by count: the paper's equal angles (circle), equal spacing (line).
        n = fl["n_pulses"]
        if path == "circle":
            poses = tj.circle(
                center, radius, z, n, start_angle_deg=fl["start_angle_deg"], **head_kw
            )
            x = (fl["start_angle_deg"] + 360.0 * np.arange(n) / n) % 360.0
            xl = "angle on the circle (deg)"
        elif path == "figure_eight":
            poses = tj.figure_eight(
                center, radius, z, n, start_angle_deg=fl["start_angle_deg"], **head_kw
            )
            x, xl = np.arange(n, dtype=np.float64), "pulse"
        else:
            kw = {"heading": "look_at" if heading in ("center", "look_at") else heading}
            if heading == "fixed":
                kw["yaw_deg"] = fl["yaw_deg"]
            tgt = np.asarray(target if target is not None else default_target)
            poses = tj.line_to(fl["start"], tgt, n, stop_distance=fl["stop_distance"], **kw)
            x = np.linalg.norm(poses.positions - poses.positions[0], axis=1)
            xl = "distance flown (m)"
        if mount is not None:
            poses = mount.pose(poses.positions, poses.rotations)
        return FlightPlan(poses, None, path_pts, x, xl, closed, None, traj)
    poses = traj.poses(times, mount=mount)
    return FlightPlan(poses, times, path_pts, times, "pulse time (s)", closed, None, traj)


# ------------------------------------------------------------------------------- running


def sonar_params(sonar: Sonar) -> dict[str, Any]:
    """A :class:`batecho.Sonar`'s parameters as a dict that is also a valid ``[sonar]`` table
    (None values left out; ``beam``/``receiver``/``absorption`` as sub-tables)."""
    out: dict[str, Any] = {}
    for f in dataclasses.fields(sonar):
        if f.name.startswith("_"):
            continue
        v = getattr(sonar, f.name)
        if v is None:
            continue
        if f.name in ("beam", "receiver", "absorption"):
            sub = {
                g.name: list(getattr(v, g.name))
                if isinstance(getattr(v, g.name), tuple)
                else getattr(v, g.name)
                for g in dataclasses.fields(v)
                if getattr(v, g.name) is not None
            }
            out[f.name] = sub
        elif isinstance(v, tuple):
            out[f.name] = list(v)
        else:
            out[f.name] = v
    if sonar.beam is not None and sonar.beam.beamwidth_deg is not None:
        defaults = Beam(beamwidth_deg=sonar.beam.beamwidth_deg)
        if sonar.beam == defaults:
            out.pop("beam")
            out["beamwidth_deg"] = sonar.beam.beamwidth_deg
    return out


def simulate_options(method: str = "exact", tol: float = 1e-12) -> dict[str, Any]:
    """Keyword arguments for :func:`batecho.simulate`: none for the default exact sum (so
    that any version of ``simulate`` takes them), else ``method`` and ``tol``."""
    if method == "exact" and tol == 1e-12:
        return {}
    return {"method": method, "tol": float(tol)}


@dataclass
class SimulationSetup:
    """Everything built from a scene file, ready to simulate and to record."""

    scenefile: SceneFile
    scene_object: Any
    scene: Scene
    tree_positions: np.ndarray | None
    center_xy: np.ndarray
    sonar: Sonar
    plan: FlightPlan
    timings_s: dict[str, float] = field(default_factory=dict)


def setup_scenefile(sf: SceneFile) -> SimulationSetup:
    """Build the scene, the sonar and the flight of a scene file (seeded by its ``seed``)."""
    rng = np.random.default_rng(sf.seed)
    t0 = time.perf_counter()
    obj, leaves, pos = sf.build_scene(rng)
    t1 = time.perf_counter()
    scene = Scene(leaves)
    t2 = time.perf_counter()
    sonar = sf.build_sonar()
    if pos is not None and len(pos):
        center = np.asarray(pos, dtype=np.float64).mean(axis=0)
    else:
        lo, hi = leaves.bounds()
        center = 0.5 * (lo[:2] + hi[:2])
    plan = sf.build_flight(center)
    t3 = time.perf_counter()
    return SimulationSetup(
        sf,
        obj,
        scene,
        pos,
        center,
        sonar,
        plan,
        {"scene_s": t1 - t0, "bvh_s": t2 - t1, "flight_s": t3 - t2},
    )


def sample_indices(p: int, k: int, closed: bool) -> np.ndarray:
    """``k`` pulse indices spread over ``p`` pulses (a loop: ``p j / k``; else both ends)."""
    k = max(1, min(int(k), p))
    if closed:
        return np.unique((p * np.arange(k) // k).astype(np.int64))
    return np.unique(np.linspace(0, p - 1, k).round().astype(np.int64))


@dataclass
class RunResult:
    """What :func:`run_scenefile` did: the echoes, the files written and the timings (s)."""

    setup: SimulationSetup
    echoes: Any
    files: list[Path]
    timings_s: dict[str, float]


def run_scenefile(
    sf: SceneFile,
    out_dir: str | os.PathLike,
    *,
    plots: bool = True,
    progress: Callable[[str], None] | None = None,
) -> RunResult:
    """Build, simulate and write the outputs of a scene file into ``out_dir``.

    Writes ``echoes.npz`` (``[output] npz``) with keys ``spectrum``, ``freqs``, ``band_bins``
    (first and last band bin: ``impulse = 2 irfft(Y, n_samples)`` with ``Y`` zero outside
    them), ``impulse`` (unless ``impulse = false``), ``times``, ``n_leaves``, ``positions``,
    ``forward``, ``up``, ``left``, ``pulse_times`` (empty for pulses placed by count),
    ``sample_indices``, ``tree_positions``, ``path_points``, ``seed``, ``config_toml`` (the
    file as given), ``config_json`` (every table with its defaults), ``sonar_json``,
    ``scene_json``, ``batecho_version`` and, when flown, ``flight_times``,
    ``flight_positions``, ``flight_reference_positions``; the PNG plots of ``[output] plots``
    (``scene_3d.png``, ``impulses.png``, ``echo_image.png``, ``spectrogram.png``,
    ``spectrum.png``) and, with ``[output] obj = true``, ``scene.obj``. ``progress(message)``
    is told of each step.
    """
    from . import _core
    from .echoes import simulate

    say = progress or (lambda msg: None)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    say("building the scene and the flight")
    st = setup_scenefile(sf)
    cfg = sf.config
    oc = cfg["output"]
    say(f"simulating {len(st.plan.poses)} pulses on {st.scene.n_leaves} leaves")
    t0 = time.perf_counter()
    try:
        echoes = simulate(
            st.scene, st.sonar, st.plan.poses, **simulate_options(cfg["method"], cfg["tol"])
        )
    except ValueError as exc:
        raise ScenefileError(f"{sf.path or '<string>'}: simulating: {exc}") from None
    timings = dict(st.timings_s, simulate_s=time.perf_counter() - t0)
    files: list[Path] = []
    p = len(echoes)
    idx = sample_indices(p, oc["sample_points"], st.plan.closed)
    if oc["npz"]:
        say("writing echoes.npz")
        scene_desc = {
            "kind": cfg["scene"]["kind"],
            "n_leaves": st.scene.n_leaves,
            "center_xy": st.center_xy.tolist(),
            "tree_positions": None if st.tree_positions is None else st.tree_positions.tolist(),
        }
        arrays: dict[str, Any] = {
            "spectrum": echoes.spectrum,
            "freqs": echoes.freqs,
            "band_bins": np.asarray(st.sonar.bins),
            "times": echoes.times,
            "n_leaves": echoes.n_leaves,
            "positions": echoes.poses.positions,
            "forward": echoes.poses.forward,
            "up": echoes.poses.up,
            "left": echoes.poses.left,
            "pulse_times": np.zeros(0) if st.plan.pulse_times is None else st.plan.pulse_times,
            "sample_indices": idx,
            "tree_positions": np.zeros((0, 2)) if st.tree_positions is None else st.tree_positions,
            "path_points": st.plan.path_points,
            "seed": sf.seed,
            "config_toml": sf.text,
            "config_json": json.dumps(cfg, sort_keys=True),
            "sonar_json": json.dumps(sonar_params(st.sonar), sort_keys=True),
            "scene_json": json.dumps(scene_desc, sort_keys=True),
            "batecho_version": _core.__version__,
        }
        if oc["impulse"]:
            arrays["impulse"] = echoes.impulse
        if st.plan.flight is not None:
            fl = st.plan.flight
            arrays["flight_times"] = fl.times
            arrays["flight_positions"] = fl.positions
            arrays["flight_reference_positions"] = fl.reference_positions
        np.savez(out / "echoes.npz", **arrays)
        files.append(out / "echoes.npz")
    if oc["obj"]:
        say("writing scene.obj")
        files.append(_write_scene_obj(st, out / "scene.obj"))
    if plots and oc["plots"]:
        files += _plots(st, echoes, idx, out, oc, say)
    return RunResult(st, echoes, files, timings)


def _write_scene_obj(st: SimulationSetup, path: Path) -> Path:
    obj = st.scene_object
    if callable(getattr(obj, "to_obj", None)):
        return Path(obj.to_obj(path) or path)
    from .meshio import write_obj

    return write_obj(path, leaves=st.scene.leaves)


def _plots(st: SimulationSetup, echoes, idx, out: Path, oc: dict, say) -> list[Path]:
    import matplotlib.pyplot as plt

    from .echoes import lobe_members
    from .plotting import (
        plot_echo_image,
        plot_impulses,
        plot_scene_3d,
        plot_spectrogram,
        plot_spectrum,
    )

    files = []
    dpi = oc["dpi"]
    best = int(idx[np.argmax(echoes.n_leaves[idx])])

    def save(fig, name):
        fig.savefig(out / name, dpi=dpi)
        plt.close(fig)
        files.append(out / name)

    bw = st.sonar.beam.beamwidth_deg
    beam = f"{bw:g} deg beam" if bw is not None else "custom beam"
    for name in oc["plots"]:
        say(f"plotting {name}")
        if name == "scene":
            members = [lobe_members(st.scene, st.sonar, st.plan.poses[int(i)]) for i in idx]
            fig = plot_scene_3d(
                st.scene_object,
                st.plan.poses,
                st.sonar,
                members=members,
                trajectory=st.plan.path_points,
                lobe_poses=idx,
                max_points=oc["max_scene_points"],
                title=f"{st.scene.n_leaves:,} leaves, {len(echoes)} pulses, lobes of pulses "
                f"{', '.join(str(int(i)) for i in idx)} ({beam})",
            )
            save(fig, "scene_3d.png")
        elif name == "impulses":
            fig = plot_impulses(
                echoes,
                idx,
                titles=[
                    f"pulse {int(i)}: {int(echoes.n_leaves[i])} leaves in the lobe" for i in idx
                ],
            )
            save(fig, "impulses.png")
        elif name == "echo_image":
            x = st.plan.x
            order_ok = len(np.unique(x)) == len(x)
            fig = plot_echo_image(
                echoes,
                x=x if order_ok else None,
                xlabel=st.plan.x_label if order_ok else "pulse",
                title=f"Echo envelopes along the flight ({beam})",
            )
            save(fig, "echo_image.png")
        elif name == "spectrogram":
            fig = plot_spectrogram(echoes, best)
            fig.axes[0].set_title(f"pulse {best}: {int(echoes.n_leaves[best])} leaves", fontsize=10)
            save(fig, "spectrogram.png")
        elif name == "spectrum":
            fig = plot_spectrum(echoes, best)
            save(fig, "spectrum.png")
    return files
