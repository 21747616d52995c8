"""The scene-file schema: every table and key a scene file may hold, with its type, choices
and default, and the checks that fill in the defaults of a parsed file.

``batecho simulate SCENE.toml`` reads one (see ``examples/flight.toml``)::

    seed = 7                      # every random draw (leaves, trees, tree positions)

    [scene]                       # kind = "leaf_box" | "obj" | "tree" | "forest"
    kind = "forest"
    n_trees = 3                   # forest: the paper's IPP conditioned on 3 trees
    branches = true               # tree, forest: trunks and branches echo (docs/model.md §9)
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
    min_clearance_m = 0.5         # every pulse this far from leaves and bark, or refused
    [flight.mount]                # batecho.SonarMount
    pitch_deg = -5

    [sonar.binaural]              # two ears (batecho.Sonar.binaural), or [[sonar.receivers]]
    separation_m = 0.02
    ear_yaw_deg = 30

    [call]                        # the emitted call: what the receivers record (optional)
    kind = "linear_fm"            # "linear_fm" | "hyperbolic_fm" | "cf_fm"
    f_start_hz = 80e3
    f_end_hz = 60e3
    duration_s = 2e-3
    noise_rms = 0.0

    [output]
    plots = ["scene", "impulses", "echo_image", "spectrogram"]
    wav = true                    # echoes.wav, time-expanded (wav_time_expansion = 10)
    mat = true                    # echoes.mat (MATLAB)
    xarray = true                 # echoes.zarr (xarray.open_zarr)

A flight that brings a pulse closer than ``[flight] min_clearance_m`` (default 0.5 m) to a leaf
or to bark is refused unless ``[flight] allow_low_clearance = true``.

Every key is checked: an unknown key, a value of the wrong type or out of its choices raises
:class:`ScenefileError` naming the file, the table and the key. Lengths in metres, times in
seconds, angles in degrees (keys ending ``_deg``), frequencies in Hz.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ..echoes.simulate import DEFAULT_METHOD, DEFAULT_TOL, METHODS
from ..forest.clearance import DEFAULT_MIN_CLEARANCE_M
from ..forest.models import TREE_MODELS
from ..sonar.beam import horseshoe_bat_beamwidth_deg

__all__ = [
    "CALL_KINDS",
    "PLOTS",
    "RECEIVER_PLOTS",
    "SCENE_KEYS_BY_KIND",
    "ScenefileError",
    "check_document",
]

#: The highest resolution of the plots (dots per inch).
MAX_DPI = 2400

#: The plots a scene file may ask for in ``[output] plots``.
PLOTS = (
    "scene",
    "impulses",
    "echo_image",
    "spectrogram",
    "spectrum",
    "binaural_impulses",
    "binaural_echo_images",
    "interaural",
)
#: The plots that need two receivers or more.
RECEIVER_PLOTS = ("binaural_impulses", "binaural_echo_images", "interaural")


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
_SHADING = {
    "leaf_transmission": _Opt("float", doc="one-way amplitude past one leaf (default 0.6)"),
    "branches_block": _Opt("bool", doc="a branch on the ray silences (default true)"),
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
    "branch_piece_scale": _Opt("float", doc="in (0, 1]: branch pieces this much shorter"),
    "beam": _table(_BEAM),
    "receiver": _table(_BEAM),
    "absorption": _table(_ATMOSPHERE),
    "shading": _table(_SHADING),
    "receivers": _Opt("receivers", doc="[[sonar.receivers]] offset_m = [f, l, u], [.beam]"),
    "binaural": _Opt("binaural", doc="separation_m, ear_yaw_deg, ear_pitch_deg, [.ear_beam]"),
}
_RECEIVER = {
    "offset_m": _Opt("vec3", [0.0, 0.0, 0.0], doc="(forward, left, up) from the emitter, m"),
    "beam": _table(_BEAM),
}
_BINAURAL = {
    "separation_m": _Opt("float", _REQUIRED),
    "ear_yaw_deg": _Opt("float", _REQUIRED),
    "ear_pitch_deg": _Opt("float", 0.0),
    "ear_beam": _table(_BEAM),
}
#: The calls of ``[call] kind``: batecho.Call's constructors.
CALL_KINDS = ("linear_fm", "hyperbolic_fm", "cf_fm")
_CALL = {
    "kind": _Opt("str", _REQUIRED, choices=CALL_KINDS),
    "f_start_hz": _Opt("float", doc="linear_fm, hyperbolic_fm"),
    "f_end_hz": _Opt("float", doc="linear_fm, hyperbolic_fm"),
    "f_cf_hz": _Opt("float", doc="cf_fm: the constant frequency"),
    "fm_end_hz": _Opt("float", doc="cf_fm: where the FM tail ends"),
    "fm_duration_s": _Opt("float", doc="cf_fm: the FM tail's duration"),
    "duration_s": _Opt("float", _REQUIRED),
    "window": _Opt("str", choices=("hann", "hamming", "blackman", "tukey", "rect")),
    "noise_rms": _Opt("float", 0.0, doc="white Gaussian noise added to what is received"),
}
_CALL_KEYS = {
    "linear_fm": {"f_start_hz", "f_end_hz"},
    "hyperbolic_fm": {"f_start_hz", "f_end_hz"},
    "cf_fm": {"f_cf_hz", "fm_end_hz", "fm_duration_s"},
}
_SCENE_KINDS = ("leaf_box", "obj", "tree", "forest")
_TREE_MODELS = tuple(TREE_MODELS)
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
    "branches": _Opt(
        "bool", False, doc="the trees' trunks and branches echo and may block (tree, forest)"
    ),
}
SCENE_KEYS_BY_KIND = {
    "leaf_box": {
        "density_per_m3",
        "box",
        "radius_mean_m",
        "radius_sd_m",
        "normal_angle_mean_deg",
        "normal_angle_sd_deg",
    },
    "obj": {"path", "leaf_patterns", "up", "per", "scale", "offset"},
    "tree": {"model", "position", "tree", "branches"},
    "forest": {
        "branches",
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
    "radius": _Opt(
        "float_or_clear",
        doc='m; default 6.2 (circle), 3.1 (figure eight); "clear" (circle): the smallest '
        "radius >= 6.2 m that passes min_clearance_m outside every crown at the flight's "
        "altitude (forest, tree)",
    ),
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
    "min_clearance_m": _Opt(
        "float",
        DEFAULT_MIN_CLEARANCE_M,
        doc="every pulse keeps this distance from leaves and bark, m (0: no check)",
    ),
    "allow_low_clearance": _Opt(
        "bool", False, doc="simulate (with a warning) a flight closer than min_clearance_m"
    ),
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
    "wav": _Opt("bool", False, doc="echoes.wav: one channel per receiver, time-expanded"),
    "wav_time_expansion": _Opt("float", 10.0, doc="the WAV's rate is fs / this"),
    "mat": _Opt("bool", False, doc="echoes.mat (MATLAB, scipy.io.savemat)"),
    "xarray": _Opt("bool", False, doc="echoes.zarr: the xarray Dataset (xarray extra)"),
}
_TOP = {
    "seed": _Opt("int", 0),
    "description": _Opt("str", ""),
    "method": _Opt("str", DEFAULT_METHOD, choices=METHODS),
    "tol": _Opt("float", DEFAULT_TOL, doc="relative L2 error of the spectrum for method fast/auto"),
    "scene": _table(_SCENE),
    "sonar": _table(_SONAR),
    "flight": _table(_FLIGHT),
    "output": _table(_OUTPUT),
    "call": _Opt("table", choices=(_CALL,)),
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
    return ScenefileError(f"[{where}] {key}: {msg}" if where else f"{key}: {msg}")


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
        if not _is_num(v):
            raise _fail(where, key, f"expected a number, got {v!r} ({_tname(v)})")
        if not math.isfinite(float(v)):
            raise _fail(where, key, f"must be finite, got {v!r}")
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
    if k == "float_or_clear":
        if v == "clear":
            return v
        if not _is_num(v):
            raise _fail(where, key, f'expected a number or "clear", got {v!r} ({_tname(v)})')
        if not math.isfinite(float(v)):
            raise _fail(where, key, f'must be finite (or "clear"), got {v!r}')
        return float(v)
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
            out: dict[str, Any] = {"centers": _points(v["centers"], 2, f"{where}.{key}", "centers")}
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
    if k == "receivers":
        if not isinstance(v, list) or not v or not all(isinstance(x, dict) for x in v):
            raise _fail(where, key, f"expected [[{where}.{key}]] tables, got {v!r}")
        return [_check_table(x, _RECEIVER, f"{where}.{key}[{i}]") for i, x in enumerate(v)]
    if k == "binaural":
        if not isinstance(v, dict):
            raise _fail(where, key, f"expected a table, got {v!r} ({_tname(v)})")
        return _check_table(v, _BINAURAL, f"{where}.{key}")
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


def check_document(doc: dict) -> dict[str, Any]:
    if "scene" not in doc:
        _unknown(doc, _TOP, "")
        raise ScenefileError(
            'missing table [scene] (with kind = "leaf_box", "obj", "tree" or "forest")'
        )
    cfg = _check_table(doc, _TOP, "")
    sc = cfg["scene"]
    kind = sc["kind"]
    for key in doc["scene"]:
        if key != "kind" and key not in SCENE_KEYS_BY_KIND[kind]:
            raise ScenefileError(
                f'[scene] {key}: not used with kind = "{kind}"; keys for this kind: '
                f"{', '.join(sorted(SCENE_KEYS_BY_KIND[kind]))}"
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
    if fl.get("radius") == "clear" and fl["path"] != "circle":
        raise ScenefileError('[flight] radius: "clear" is for path = "circle"')
    if fl.get("radius") == "clear" and sc["kind"] not in ("forest", "tree"):
        raise ScenefileError(
            f'[flight] radius: "clear" keeps the circle outside the trees\' reach; it needs '
            f'[scene] kind = "forest" or "tree", not "{kind}"'
        )
    if fl["min_clearance_m"] < 0:
        raise ScenefileError(
            f"[flight] min_clearance_m: must be >= 0 (0: no check), got {fl['min_clearance_m']}"
        )
    if fl["mode"] == "kinematic" and ({"quadrotor", "dt"} & given):
        raise ScenefileError('[flight] quadrotor, dt: only used with mode = "flown"')
    if "n_pulses" in fl and "pulse_rate_hz" in fl:
        raise ScenefileError("[flight]: give n_pulses or pulse_rate_hz, not both")
    if "n_pulses" in fl and fl["n_pulses"] < 1:
        raise ScenefileError(f"[flight] n_pulses: must be >= 1, got {fl['n_pulses']}")
    for key in ("pulse_rate_hz", "dt", "duration", "speed"):
        if key in fl and not fl[key] > 0:
            raise ScenefileError(f"[flight] {key}: must be > 0, got {fl[key]}")
    if "n_pulses" not in fl and "pulse_rate_hz" not in fl:
        fl["n_pulses"] = 15
    if (
        "duration" in fl
        and "n_pulses" in fl
        and fl["mode"] == "kinematic"
        and fl["path"] in ("circle", "line", "figure_eight")
    ):
        raise ScenefileError(
            f"[flight] duration: not used by kinematic pulses placed by n_pulses on a path = "
            f'"{fl["path"]}" (they span the whole path); give pulse_rate_hz, or leave '
            "duration out"
        )
    if fl["path"] == "line" and "start" not in fl:
        raise ScenefileError('[flight]: path = "line" needs start = [x, y, z]')
    if fl["path"] == "waypoints" and "points" not in fl:
        raise ScenefileError('[flight]: path = "waypoints" needs points = [[x, y, z], ...]')
    if fl["heading"] == "fixed" and "yaw_deg" not in fl:
        raise ScenefileError('[flight]: heading = "fixed" needs yaw_deg')
    if "yaw_deg" in fl and fl["heading"] != "fixed":
        raise ScenefileError('[flight] yaw_deg: only used with heading = "fixed"')
    if "target" in fl and fl["path"] != "line" and fl["heading"] not in ("center", "look_at"):
        raise ScenefileError(
            '[flight] target: only used with heading = "center" or "look_at" (where the sonar '
            f'looks), or path = "line" (where it ends); not with heading = "{fl["heading"]}"'
        )
    so = cfg["sonar"]
    if "horseshoe_bat_khz" in so:
        f_khz = so["horseshoe_bat_khz"]
        bw = horseshoe_bat_beamwidth_deg(f_khz)
        if not 0.0 < bw < 180.0:
            raise ScenefileError(
                f"[sonar] horseshoe_bat_khz: the horseshoe-bat fit at {f_khz:g} kHz gives a "
                f"beamwidth of {bw:.6g} deg, not in (0, 180); the fit gives one from about "
                "48.4 to 94.3 kHz"
            )
    if "binaural" in so and ("receivers" in so or so.get("receiver")):
        raise ScenefileError(
            "[sonar] binaural: give [sonar.binaural] or [[sonar.receivers]] / [sonar.receiver], "
            "not both"
        )
    if "call" in cfg:
        call = cfg["call"]
        for key in ("f_start_hz", "f_end_hz", "f_cf_hz", "fm_end_hz", "fm_duration_s"):
            if key in call and key not in _CALL_KEYS[call["kind"]]:
                raise ScenefileError(
                    f'[call] {key}: not used with kind = "{call["kind"]}"; keys for this kind: '
                    f"{', '.join(sorted(_CALL_KEYS[call['kind']]))}, duration_s, window, "
                    "noise_rms"
                )
        missing = sorted(_CALL_KEYS[call["kind"]] - set(call))
        if missing:
            raise ScenefileError(f'[call]: kind = "{call["kind"]}" needs {", ".join(missing)}')
        if call["noise_rms"] < 0:
            raise ScenefileError(f"[call] noise_rms: must be >= 0, got {call['noise_rms']}")
    two = "binaural" in so or len(so.get("receivers", [])) >= 2
    for name in cfg["output"]["plots"]:
        if name in RECEIVER_PLOTS and not two:
            raise ScenefileError(
                f'[output] plots: "{name}" needs two receivers ([sonar.binaural] or two '
                "[[sonar.receivers]])"
            )
    for key in ("sample_points", "dpi", "max_scene_points"):
        if cfg["output"][key] < 1:
            raise ScenefileError(f"[output] {key}: must be >= 1, got {cfg['output'][key]}")
    if not cfg["output"]["wav_time_expansion"] > 0:
        raise ScenefileError(
            f"[output] wav_time_expansion: must be > 0, got {cfg['output']['wav_time_expansion']}"
        )
    if cfg["output"]["dpi"] > MAX_DPI:
        raise ScenefileError(
            f"[output] dpi: at most {MAX_DPI} (print quality is 300-600), "
            f"got {cfg['output']['dpi']}"
        )
    if not 0.0 < cfg["tol"] < 1.0:
        raise ScenefileError(f"tol: must be in (0, 1), got {cfg['tol']}")
    if not 0 <= cfg["seed"] < 2**128:
        raise ScenefileError(f"seed: must be an integer in [0, 2^128), got {cfg['seed']}")
    return cfg
