"""The dataset spec: what to draw, how much, and how to store it (TOML or dataclasses).

A :class:`DatasetSpec` describes distributions, not values. Every scalar that may vary is a
:class:`Dist`, written in TOML as a plain number (fixed) or as a one-key inline table::

    density_per_m3 = 25.0                          # fixed
    density_per_m3 = { uniform = [5.0, 40.0] }     # U(5, 40)
    density_per_m3 = { loguniform = [1.0, 100.0] } # log-uniform on [1, 100]
    beamwidth_deg  = { choice = [10.0, 20.0, 50.0] }

Units are in the names: ``_m`` metres, ``_deg`` degrees, ``_hz`` hertz, ``_per_m3`` per m^3.
Validation is strict: unknown keys, wrong types and out-of-range values raise
:class:`SpecError` naming the dotted key (``sonar.band_hz``). :meth:`DatasetSpec.to_toml`
writes the canonical form (every field, fixed order); its SHA-256 identifies the spec.
"""

# ruff: noqa: RUF009  (the fields are made by _f, a wrapper of dataclasses.field)
from __future__ import annotations

import hashlib
import json
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from .._resources import human_bytes, memory_limit
from ..echoes.canonical import CANONICAL_BOX
from ..forest.ipp import PAPER_WINDOW
from ..sonar.shading import DEFAULT_LEAF_TRANSMISSION as _DEFAULT_LEAF_TRANSMISSION

__all__ = [
    "CallSpec",
    "DatasetSpec",
    "Dist",
    "ForestSpec",
    "LeafBoxSpec",
    "LeafSpec",
    "OutputSpec",
    "PoseSpec",
    "SceneSpec",
    "SonarSpec",
    "SpecError",
]

#: Largest chunk (bytes of echo data) a worker holds in memory before writing it.
MAX_CHUNK_BYTES = 1 << 30

#: What the store's indexes take per sample (bytes) and per chunk (its index and marker),
#: held whole by the process that creates, resumes or verifies it.
INDEX_BYTES_PER_SAMPLE = 8
INDEX_BYTES_PER_CHUNK = 16


class SpecError(ValueError):
    """A dataset spec is malformed: unknown key, wrong type or value out of range."""


# -------------------------------------------------------------------------------- Dist


_DIST_KINDS = ("fixed", "uniform", "loguniform", "choice")


def _real(x: Any, name: str) -> float:
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
        raise SpecError(f"{name} must be a number, got {x!r}")
    v = float(x)
    if not math.isfinite(v):
        raise SpecError(f"{name} must be finite, got {x!r}")
    return v


@dataclass(frozen=True)
class Dist:
    """A scalar drawn once per sample (or scene): ``fixed``, ``uniform`` on [lo, hi),
    ``loguniform`` on [lo, hi) (lo > 0), or ``choice`` among values (equal odds)."""

    kind: str
    values: tuple[float, ...]

    def __post_init__(self) -> None:
        if self.kind not in _DIST_KINDS:
            raise SpecError(f"distribution kind must be one of {_DIST_KINDS}, got {self.kind!r}")
        vals = tuple(_real(v, f"{self.kind} value") for v in self.values)
        object.__setattr__(self, "values", vals)
        if self.kind == "fixed" and len(vals) != 1:
            raise SpecError(f"a fixed value holds one number, got {vals}")
        if self.kind in ("uniform", "loguniform"):
            if len(vals) != 2 or not vals[0] < vals[1]:
                raise SpecError(f"{self.kind} needs [lo, hi] with lo < hi, got {list(vals)}")
            if self.kind == "loguniform" and vals[0] <= 0:
                raise SpecError(f"loguniform needs lo > 0, got {list(vals)}")
        if self.kind == "choice" and not vals:
            raise SpecError("choice needs at least one value")

    @classmethod
    def fixed(cls, value: float) -> Dist:
        return cls("fixed", (value,))

    @classmethod
    def uniform(cls, lo: float, hi: float) -> Dist:
        return cls("uniform", (lo, hi))

    @classmethod
    def loguniform(cls, lo: float, hi: float) -> Dist:
        return cls("loguniform", (lo, hi))

    @classmethod
    def choice(cls, *values: float) -> Dist:
        return cls("choice", tuple(values))

    @classmethod
    def parse(cls, raw: Any, name: str) -> Dist:
        """A Dist from a number, a Dist, or a one-key table ``{uniform = [lo, hi]}`` etc."""
        if isinstance(raw, Dist):
            return raw
        if isinstance(raw, Mapping):
            if len(raw) != 1:
                raise SpecError(
                    f"{name}: a distribution is one of {{uniform = [lo, hi]}}, "
                    f"{{loguniform = [lo, hi]}}, {{choice = [...]}}; got {dict(raw)!r}"
                )
            ((kind, vals),) = raw.items()
            if kind not in _DIST_KINDS:
                raise SpecError(
                    f"{name}: unknown distribution {kind!r} (known: {', '.join(_DIST_KINDS)})"
                )
            if kind == "fixed":
                vals = [vals]
            if not isinstance(vals, (list, tuple)):
                raise SpecError(f"{name}: {kind} takes a list of numbers, got {vals!r}")
            try:
                return cls(kind, tuple(vals))
            except SpecError as exc:
                raise SpecError(f"{name}: {exc}") from None
        try:
            return cls.fixed(raw)
        except SpecError as exc:
            raise SpecError(f"{name}: {exc} (or a table such as {{uniform = [lo, hi]}})") from None

    @property
    def low(self) -> float:
        """Smallest value it can take."""
        return min(self.values)

    @property
    def high(self) -> float:
        """Largest value it can take."""
        return max(self.values)

    @property
    def is_random(self) -> bool:
        return self.kind != "fixed" and not (self.kind == "choice" and len(self.values) == 1)

    def draw(self, rng: np.random.Generator) -> float:
        """One value. A fixed value consumes no random numbers."""
        if self.kind == "fixed":
            return self.values[0]
        if self.kind == "uniform":
            return float(rng.uniform(self.values[0], self.values[1]))
        if self.kind == "loguniform":
            lo, hi = math.log(self.values[0]), math.log(self.values[1])
            return float(math.exp(rng.uniform(lo, hi)))
        return self.values[int(rng.integers(len(self.values)))]

    def to_toml_value(self) -> float | dict[str, list[float]]:
        if self.kind == "fixed":
            return self.values[0]
        return {self.kind: list(self.values)}


# ---------------------------------------------------------------------- field helpers


def _f(default: Any, kind: str, **check: Any) -> Any:
    """A spec field: its default, its kind (see ``_coerce``) and its checks (lo, hi, ...)."""
    meta = {"kind": kind, **check}
    if isinstance(default, dict):
        return field(default_factory=lambda: dict(default), metadata=meta)
    return field(default=default, metadata=meta)


def _in_range(v: float, name: str, meta: Mapping[str, Any]) -> None:
    lo, hi = meta.get("lo"), meta.get("hi")
    lo_open, hi_open = meta.get("lo_open", False), meta.get("hi_open", False)
    bad = (lo is not None and (v < lo or (lo_open and v == lo))) or (
        hi is not None and (v > hi or (hi_open and v == hi))
    )
    if bad:
        left = "(" if lo_open else "["
        right = ")" if hi_open else "]"
        lo_s = "-inf" if lo is None else f"{lo:g}"
        hi_s = "inf" if hi is None else f"{hi:g}"
        raise SpecError(f"{name} must be in {left}{lo_s}, {hi_s}{right}, got {v:g}")


def _coerce(value: Any, name: str, meta: Mapping[str, Any]) -> Any:
    kind = meta["kind"]
    if kind == "dist":
        d = Dist.parse(value, name)
        for v in (d.low, d.high):
            try:
                _in_range(v, name, meta)
            except SpecError as exc:
                raise SpecError(f"{exc} (every value the distribution can take)") from None
        return d
    if kind == "float":
        v = _real(value, name)
        _in_range(v, name, meta)
        return v
    if kind == "opt_float":
        return None if value is None else _coerce(value, name, {**meta, "kind": "float"})
    if kind == "int":
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise SpecError(f"{name} must be an integer, got {value!r}")
        v = int(value)
        _in_range(v, name, meta)
        return v
    if kind == "bool":
        if not isinstance(value, (bool, np.bool_)):
            raise SpecError(f"{name} must be true or false, got {value!r}")
        return bool(value)
    if kind == "str":
        if not isinstance(value, str):
            raise SpecError(f"{name} must be a string, got {value!r}")
        choices = meta.get("choices")
        if choices is not None and value not in choices:
            raise SpecError(f"{name} must be one of {list(choices)}, got {value!r}")
        return value
    if kind in ("floats", "opt_floats"):
        if value is None and kind == "opt_floats":
            return None
        n = meta["n"]
        if not isinstance(value, (list, tuple, np.ndarray)) or len(value) != n:
            raise SpecError(f"{name} must be a list of {n} numbers, got {value!r}")
        out = tuple(_real(v, name) for v in value)
        for v in out:
            _in_range(v, name, meta)
        return out
    if kind == "box":
        ok = isinstance(value, (list, tuple)) and len(value) == 3
        ok = ok and all(isinstance(p, (list, tuple)) and len(p) == 2 for p in value)
        if not ok:
            raise SpecError(f"{name} must be [[x0, x1], [y0, y1], [z0, z1]] (m), got {value!r}")
        box = tuple((_real(p[0], name), _real(p[1], name)) for p in value)
        for axis, (a, b) in zip("xyz", box, strict=True):
            if not a < b:
                raise SpecError(f"{name}: {axis} range needs {axis}0 < {axis}1, got [{a}, {b}]")
        return box
    if kind == "params":
        if not isinstance(value, Mapping):
            raise SpecError(f"{name} must be a table, got {value!r}")
        out_params: dict[str, Any] = {}
        for k in sorted(value):
            item = value[k]
            dist_table = (
                isinstance(item, Mapping) and len(item) == 1 and next(iter(item)) in _DIST_KINDS
            )
            if isinstance(item, Dist) or dist_table:
                item = Dist.parse(item, f"{name}.{k}")
            out_params[str(k)] = item
        return out_params
    if kind == "opt_section":
        return None if value is None else _coerce(value, name, {**meta, "kind": "section"})
    if kind == "section":
        cls = meta["cls"]
        if isinstance(value, cls):
            return value
        return cls._from_mapping(value, name)
    raise AssertionError(kind)  # pragma: no cover


class _Section:
    """Base of the spec dataclasses: coerces and checks every field in ``__post_init__``."""

    _path: ClassVar[str] = ""

    def __post_init__(self) -> None:
        for f in fields(self):  # type: ignore[arg-type]
            name = f"{self._path}.{f.name}" if self._path else f.name
            value = _coerce(getattr(self, f.name), name, f.metadata)
            object.__setattr__(self, f.name, value)
        self._check()

    def _check(self) -> None:
        """Checks between fields; raise SpecError naming the keys."""

    @classmethod
    def _from_mapping(cls, raw: Any, path: str) -> Any:
        if isinstance(raw, cls):
            return raw
        if not isinstance(raw, Mapping):
            raise SpecError(f"[{path}] must be a table, got {raw!r}")
        known = [f.name for f in fields(cls)]  # type: ignore[arg-type]
        unknown = [k for k in raw if k not in known]
        if unknown:
            where = f"[{path}]" if path else "the top level"
            raise SpecError(
                f"unknown key{'s' if len(unknown) > 1 else ''} "
                f"{', '.join(repr(k) for k in unknown)} in {where} (known: {', '.join(known)})"
            )
        return cls(**raw)

    def _to_dict(self, full: bool = False) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for f in fields(self):  # type: ignore[arg-type]
            v = getattr(self, f.name)
            if v is None:
                continue
            # (keys added after the format's first version stay out at their defaults unless
            # `full`, so that an earlier spec keeps its canonical form and hash)
            if not full and f.metadata.get("omit_default") and v == f.default:
                continue
            if isinstance(v, Dist):
                v = v.to_toml_value()
            elif isinstance(v, _Section):
                v = v._to_dict(full)
            elif isinstance(v, tuple):
                v = [list(x) if isinstance(x, tuple) else x for x in v]
            elif isinstance(v, dict):
                v = {
                    k: x.to_toml_value() if isinstance(x, Dist) else json.loads(json.dumps(x))
                    for k, x in v.items()
                }
            out[f.name] = v
        return out


# ----------------------------------------------------------------------------- sections


@dataclass(frozen=True)
class LeafBoxSpec(_Section):
    """``scene.kind = "leaf_box"``: leaves uniform in ``box_m`` (Ming's canonical box by
    default), ``round(density_per_m3 x volume)`` of them."""

    _path: ClassVar[str] = "scene.leaf_box"
    box_m: tuple[tuple[float, float], ...] = _f(CANONICAL_BOX, "box")
    density_per_m3: Dist = _f(Dist.fixed(25.0), "dist", lo=0.0, lo_open=True)

    def _check(self) -> None:
        vol = math.prod(b - a for a, b in self.box_m)
        if self.density_per_m3.low * vol < 0.5:
            raise SpecError(
                f"scene.leaf_box: density_per_m3 = {self.density_per_m3.low:g} in a "
                f"{vol:g} m^3 box gives no leaf; raise the density or enlarge box_m"
            )
        if self.density_per_m3.high * vol > 50_000_000:
            raise SpecError(
                f"scene.leaf_box: density_per_m3 = {self.density_per_m3.high:g} in a "
                f"{vol:g} m^3 box gives over 5e7 leaves; that is too many for one scene"
            )


@dataclass(frozen=True)
class ForestSpec(_Section):
    """``scene.kind = "forest"``: trees at an inhomogeneous Poisson process, by
    ``batecho.forest.Forest.from_ipp``.

    ``intensity = "paper"``: the paper's two-bump intensity times ``intensity_scale``;
    ``"homogeneous"``: ``intensity_scale`` trees per m^2. ``window_m`` is
    (xmin, xmax, ymin, ymax) m. ``variants`` distinct trees are grown and reused; each tree is
    scaled by ``exp(scale_sd z)``. ``tree_params`` go to ``batecho.grow_tree``; a numeric one
    may be a distribution (``trunk_height = {uniform = [3.0, 6.0]}``), drawn once per scene.
    ``redraw_leaves = true`` keeps the forest's leaf positions but draws radii and normals
    from ``[leaves]``. ``branches = true`` places the trees' woody skeletons in the scene: they
    echo (docs/model.md §9), may block (``sonar.shading``), and every pulse gets the label
    ``nearest_wood_m``. A forest drawn with no tree is drawn again (the scenes are conditioned
    on at least one tree).
    """

    _path: ClassVar[str] = "scene.forest"
    intensity: str = _f("paper", "str", choices=("paper", "homogeneous"))
    intensity_scale: Dist = _f(Dist.fixed(1.0), "dist", lo=0.0, lo_open=True)
    window_m: tuple[float, float, float, float] = _f(PAPER_WINDOW, "floats", n=4)
    variants: int = _f(4, "int", lo=1)
    scale_sd: Dist = _f(Dist.fixed(0.0), "dist", lo=0.0)
    redraw_leaves: bool = _f(False, "bool")
    tree_params: dict[str, Any] = _f({}, "params")
    branches: bool = _f(False, "bool", omit_default=True)

    def random_tree_params(self) -> tuple[str, ...]:
        """The tree parameters that are drawn (not fixed), sorted."""
        return tuple(k for k, v in self.tree_params.items() if isinstance(v, Dist) and v.is_random)

    def _check(self) -> None:
        x0, x1, y0, y1 = self.window_m
        if not (x0 < x1 and y0 < y1):
            raise SpecError(
                f"scene.forest.window_m must be [xmin, xmax, ymin, ymax] with xmin < xmax and "
                f"ymin < ymax, got {list(self.window_m)}"
            )


SCENE_KINDS = ("leaf_box", "forest")


@dataclass(frozen=True)
class SceneSpec(_Section):
    """Which scenes, and how often a new one is drawn.

    ``reuse = "per_sample"``: every sample its own scene. ``"pool"``: ``pool_size`` scenes,
    sample ``i`` uses scene ``i * pool_size // n_samples`` (consecutive samples share one, so a
    worker builds each scene once and keeps it). Scene ``j`` is drawn from the seed of sample
    ``j``, so a pool of ``n_samples`` scenes equals ``per_sample``.
    """

    _path: ClassVar[str] = "scene"
    kind: str = _f("leaf_box", "str", choices=SCENE_KINDS)
    reuse: str = _f("per_sample", "str", choices=("per_sample", "pool"))
    pool_size: int = _f(1, "int", lo=1)
    leaf_box: LeafBoxSpec = _f(None, "section", cls=LeafBoxSpec)
    forest: ForestSpec = _f(None, "section", cls=ForestSpec)

    def __post_init__(self) -> None:
        if self.leaf_box is None:
            object.__setattr__(self, "leaf_box", LeafBoxSpec())
        if self.forest is None:
            object.__setattr__(self, "forest", ForestSpec())
        super().__post_init__()


@dataclass(frozen=True)
class LeafSpec(_Section):
    """Leaf disks: radius ~ Normal(``radius_mean_m``, ``radius_sd_m``) truncated below at
    ``radius_min_m``; normal at elevation ~ Normal(``normal_elevation_mean_deg``,
    ``normal_elevation_sd_deg``) above the horizontal plane, azimuth uniform (90 deg: a flat,
    horizontal leaf). The four distribution parameters are drawn once per scene."""

    _path: ClassVar[str] = "leaves"
    radius_mean_m: Dist = _f(Dist.fixed(0.02), "dist", lo=0.0, lo_open=True)
    radius_sd_m: Dist = _f(Dist.fixed(0.002), "dist", lo=0.0)
    radius_min_m: float = _f(0.001, "float", lo=0.0, lo_open=True)
    normal_elevation_mean_deg: Dist = _f(Dist.fixed(45.0), "dist", lo=-90.0, hi=90.0)
    normal_elevation_sd_deg: Dist = _f(Dist.fixed(15.0), "dist", lo=0.0, hi=180.0)

    def _check(self) -> None:
        if self.radius_mean_m.low < self.radius_min_m:
            raise SpecError(
                f"leaves.radius_mean_m can be {self.radius_mean_m.low:g} m, below "
                f"leaves.radius_min_m = {self.radius_min_m:g} m"
            )


@dataclass(frozen=True)
class SonarSpec(_Section):
    """The sonar (see ``batecho.Sonar``): ``beamwidth_deg`` is drawn per sample; the grid
    (``fs`` Hz, ``n_samples``, ``band_hz``) is fixed. ``crop_range_m = [r0, r1]`` stores only
    the record's samples at ranges r0 <= v t / 2 <= r1 (m). Poses inside foliage can come
    within ``min_range_m`` of a leaf: ``too_close = "skip"`` (the default here) leaves such
    leaves out, ``"raise"`` fails the sample. ``shading = true`` shades the echoes
    (``batecho.Shading(leaf_transmission, branches_block)``, docs/model.md §10) and labels
    every pulse with ``n_shaded``."""

    _path: ClassVar[str] = "sonar"
    beamwidth_deg: Dist = _f(Dist.fixed(30.0), "dist", lo=0.0, hi=180.0, lo_open=True, hi_open=True)
    fs: float = _f(400e3, "float", lo=0.0, lo_open=True)
    n_samples: int = _f(24_000, "int", lo=16, hi=10_000_000)
    band_hz: tuple[float, float] = _f((60e3, 80e3), "floats", n=2, lo=0.0, lo_open=True)
    sound_speed: float = _f(340.0, "float", lo=0.0, lo_open=True)
    lobe: str = _f("detectable", "str", choices=("detectable", "cone"))
    threshold_db: float = _f(20.0, "float")
    cone_half_angle_deg: float | None = _f(None, "opt_float", lo=0.0, hi=180.0, lo_open=True)
    max_range_m: float | None = _f(None, "opt_float", lo=0.0, lo_open=True)
    leaf_model: str = _f("paper", "str", choices=("paper", "physical_optics"))
    spreading: bool = _f(True, "bool")
    gain: float = _f(0.2, "float", lo=0.0, lo_open=True)
    window: str = _f("hann", "str", choices=("hann", "rect"))
    min_range_m: float = _f(0.01, "float", lo=0.0, lo_open=True)
    too_close: str = _f("skip", "str", choices=("skip", "raise"))
    crop_range_m: tuple[float, float] | None = _f(None, "opt_floats", n=2, lo=0.0)
    #: Two ears (``batecho.Sonar.binaural``): their separation, their outward yaw and their
    #: pitch; without ``ear_separation_m`` the echo is heard at the emitter.
    ear_separation_m: float | None = _f(None, "opt_float", lo=0.0)
    ear_yaw_deg: float | None = _f(None, "opt_float", lo=-180.0, hi=180.0)
    ear_pitch_deg: float | None = _f(None, "opt_float", lo=-90.0, hi=90.0)
    shading: bool = _f(False, "bool", omit_default=True)
    leaf_transmission: float = _f(
        _DEFAULT_LEAF_TRANSMISSION, "float", lo=0.0, hi=1.0, omit_default=True
    )
    branches_block: bool = _f(True, "bool", omit_default=True)

    def _check(self) -> None:
        if self.ear_separation_m is None and (
            self.ear_yaw_deg is not None or self.ear_pitch_deg is not None
        ):
            raise SpecError("sonar.ear_yaw_deg, ear_pitch_deg: only with sonar.ear_separation_m")
        if self.ear_separation_m is not None and self.ear_yaw_deg is None:
            raise SpecError("sonar.ear_separation_m needs sonar.ear_yaw_deg (the ears' turn)")
        f_lo, f_hi = self.band_hz
        if not f_lo < f_hi:
            raise SpecError(f"sonar.band_hz must be [f_lo, f_hi] with f_lo < f_hi, got {f_lo}")
        for bw in (self.beamwidth_deg.low, self.beamwidth_deg.high):
            try:
                self.make(bw)
            except (ValueError, TypeError) as exc:
                raise SpecError(f"sonar: {exc}") from None
        if self.crop_range_m is not None:
            r0, r1 = self.crop_range_m
            if not r0 < r1:
                raise SpecError(f"sonar.crop_range_m must be [r0, r1] with r0 < r1, got {r0}")
            if self.time_slice()[1] - self.time_slice()[0] < 1:
                raise SpecError(
                    f"sonar.crop_range_m = [{r0}, {r1}] m holds no sample of the record "
                    f"(0 to {self.sound_speed * self.n_samples / (2 * self.fs):g} m)"
                )

    def make(self, beamwidth_deg: float):
        """A ``batecho.Sonar`` with this grid and ``beamwidth_deg``."""
        from ..sonar.shading import Shading
        from ..sonar.sonar import Sonar

        make: Any = Sonar
        if self.ear_separation_m is not None:
            sep, yaw = self.ear_separation_m, float(self.ear_yaw_deg or 0.0)
            pitch = float(self.ear_pitch_deg or 0.0)

            def make(**kw: Any) -> Sonar:
                return Sonar.binaural(sep, yaw, pitch, **kw)

        return make(
            beamwidth_deg=beamwidth_deg,
            fs=self.fs,
            n_samples=self.n_samples,
            band_hz=self.band_hz,
            sound_speed=self.sound_speed,
            lobe=self.lobe,
            threshold_db=self.threshold_db,
            cone_half_angle_deg=self.cone_half_angle_deg,
            max_range_m=self.max_range_m,
            leaf_model=self.leaf_model,
            spreading=self.spreading,
            gain=self.gain,
            window=self.window,
            min_range_m=self.min_range_m,
            too_close=self.too_close,
            shading=Shading(self.leaf_transmission, self.branches_block) if self.shading else None,
        )

    def time_slice(self) -> tuple[int, int]:
        """(t0, t1): the stored record samples ``t0 <= t < t1``."""
        if self.crop_range_m is None:
            return 0, self.n_samples
        r0, r1 = self.crop_range_m
        k = 2.0 * self.fs / self.sound_speed  # samples per metre of range
        t0 = min(self.n_samples, math.ceil(r0 * k - 1e-9))
        t1 = min(self.n_samples, math.floor(r1 * k + 1e-9) + 1)
        return t0, max(t0, t1)

    @property
    def n_bins(self) -> int:
        """Number of band bins (the ``freq`` dimension)."""
        return self.make(self.beamwidth_deg.low).n_bins

    @property
    def n_receivers(self) -> int:
        """The length of the ``receiver`` dimension: 2 with ears, else 0 (no such dim)."""
        return 0 if self.ear_separation_m is None else 2

    @property
    def min_leaf_radius_m(self) -> float:
        """The smallest leaf radius the leaf models accept (``k a >= 0.5`` at the band's
        lowest frequency), m."""
        return 0.5 * self.sound_speed / (2.0 * math.pi * self.band_hz[0])


_CALL_KEYS = {
    "linear_fm": ("f_start_hz", "f_end_hz"),
    "hyperbolic_fm": ("f_start_hz", "f_end_hz"),
    "cf_fm": ("f_cf_hz", "fm_end_hz", "fm_duration_s"),
}


@dataclass(frozen=True)
class CallSpec(_Section):
    """The emitted call (``batecho.Call``): ``kind`` and its parameters, and white noise of
    rms ``noise_rms``. With a call, the store holds ``received``: the impulse responses
    convolved with the call plus the noise (drawn from the sample's generator)."""

    _path: ClassVar[str] = "call"
    kind: str = _f("linear_fm", "str", choices=tuple(_CALL_KEYS))
    duration_s: float = _f(2e-3, "float", lo=0.0, lo_open=True)
    f_start_hz: float | None = _f(None, "opt_float", lo=0.0, lo_open=True)
    f_end_hz: float | None = _f(None, "opt_float", lo=0.0, lo_open=True)
    f_cf_hz: float | None = _f(None, "opt_float", lo=0.0, lo_open=True)
    fm_end_hz: float | None = _f(None, "opt_float", lo=0.0, lo_open=True)
    fm_duration_s: float | None = _f(None, "opt_float", lo=0.0)
    window: str = _f("hann", "str", choices=("hann", "hamming", "blackman", "tukey", "rect"))
    noise_rms: float = _f(0.0, "float", lo=0.0)

    def _check(self) -> None:
        need = _CALL_KEYS[self.kind]
        for key in ("f_start_hz", "f_end_hz", "f_cf_hz", "fm_end_hz", "fm_duration_s"):
            given = getattr(self, key) is not None
            if given != (key in need):
                raise SpecError(
                    f"call.{key}: {'needed' if not given else 'not used'} with "
                    f"kind = {self.kind!r} (it takes {', '.join(need)})"
                )

    def make(self, fs: float):
        """The ``batecho.Call`` at the sample rate ``fs``."""
        from ..sonar.call import Call

        kw = {k: getattr(self, k) for k in _CALL_KEYS[self.kind]}
        return getattr(Call, self.kind)(duration_s=self.duration_s, fs=fs, window=self.window, **kw)


@dataclass(frozen=True)
class PoseSpec(_Section):
    """Where the pulses come from.

    ``mode = "flight"``, ``path = "circle"``: ``pulses_per_sample`` poses at equal angles on a
    horizontal circle of ``circle_radius_m`` around the scene centre at z = ``altitude_m``,
    starting at ``start_angle_deg`` (the paper: 6.2 m at 5 m). ``path = "line"``: a straight
    level run toward the scene centre, starting ``start_distance_m`` from it (horizontally) on
    bearing ``bearing_deg`` and ``run_length_m`` long. ``heading``: ``"center"`` points the
    beam at the scene centre (at flight altitude), ``"velocity"`` along the path.

    ``mode = "random"``: each pulse uniform in the scene's bounding box grown by ``margin_m``
    (each side), with a uniform heading and a beam elevation ``pitch_deg`` (drawn per pulse).
    """

    _path: ClassVar[str] = "poses"
    mode: str = _f("flight", "str", choices=("flight", "random"))
    path: str = _f("circle", "str", choices=("circle", "line"))
    heading: str = _f("center", "str", choices=("center", "velocity"))
    altitude_m: Dist = _f(Dist.fixed(0.0), "dist")
    circle_radius_m: Dist = _f(Dist.fixed(6.2), "dist", lo=0.0, lo_open=True)
    start_angle_deg: Dist = _f(Dist.uniform(0.0, 360.0), "dist")
    bearing_deg: Dist = _f(Dist.uniform(0.0, 360.0), "dist")
    start_distance_m: Dist = _f(Dist.fixed(12.0), "dist", lo=0.0, lo_open=True)
    run_length_m: Dist = _f(Dist.fixed(6.0), "dist", lo=0.0)
    margin_m: float = _f(0.0, "float")
    pitch_deg: Dist = _f(Dist.fixed(0.0), "dist", lo=-89.0, hi=89.0)

    def _check(self) -> None:
        if self.mode == "flight" and self.path == "line":
            if self.run_length_m.high >= self.start_distance_m.low:
                raise SpecError(
                    f"poses.run_length_m (up to {self.run_length_m.high:g} m) must stay below "
                    f"poses.start_distance_m (from {self.start_distance_m.low:g} m): the run "
                    "would reach the scene centre"
                )

    def label_names(self) -> tuple[str, ...]:
        """The pose parameters drawn per sample (stored as labels)."""
        if self.mode == "random":
            return ()
        if self.path == "circle":
            return ("altitude_m", "circle_radius_m", "start_angle_deg")
        return ("altitude_m", "bearing_deg", "start_distance_m", "run_length_m")


@dataclass(frozen=True)
class OutputSpec(_Section):
    """What is stored: the impulse response (``time``) and/or the band spectrum (``freq``),
    as ``dtype`` ("float32": float32 / complex64; "float64": float64 / complex128), in chunks
    of ``chunk_size`` samples (a chunk is the unit of work and of restart)."""

    _path: ClassVar[str] = "output"
    impulse: bool = _f(True, "bool")
    spectrum: bool = _f(False, "bool")
    dtype: str = _f("float32", "str", choices=("float32", "float64"))
    chunk_size: int = _f(16, "int", lo=1)

    def _check(self) -> None:
        if not (self.impulse or self.spectrum):
            raise SpecError("output: store at least one of impulse and spectrum")


# ------------------------------------------------------------------------- DatasetSpec


@dataclass(frozen=True)
class DatasetSpec(_Section):
    """A whole dataset: ``n_samples`` samples of ``pulses_per_sample`` pulses each, seeded by
    ``seed`` (sample ``i`` uses ``numpy.random.SeedSequence(seed).spawn(n)[i]``)."""

    _path: ClassVar[str] = ""
    name: str = _f("batecho-dataset", "str")
    seed: int = _f(0, "int", lo=0)
    n_samples: int = _f(64, "int", lo=1)
    pulses_per_sample: int = _f(1, "int", lo=1, hi=100_000)
    scene: SceneSpec = _f(None, "section", cls=SceneSpec)
    leaves: LeafSpec = _f(None, "section", cls=LeafSpec)
    sonar: SonarSpec = _f(None, "section", cls=SonarSpec)
    poses: PoseSpec = _f(None, "section", cls=PoseSpec)
    output: OutputSpec = _f(None, "section", cls=OutputSpec)
    call: CallSpec | None = _f(None, "opt_section", cls=CallSpec)

    def __post_init__(self) -> None:
        for name, cls in (
            ("scene", SceneSpec),
            ("leaves", LeafSpec),
            ("sonar", SonarSpec),
            ("poses", PoseSpec),
            ("output", OutputSpec),
        ):
            if getattr(self, name) is None:
                object.__setattr__(self, name, cls())
        super().__post_init__()

    def _check(self) -> None:
        if self.call is not None:
            try:
                self.call.make(self.sonar.fs)
            except (TypeError, ValueError) as exc:
                raise SpecError(f"call: {exc}") from None
        if self.scene.kind != "forest" and self.scene.forest.branches:
            raise SpecError(
                f'scene.forest.branches = true needs scene.kind = "forest" (the '
                f"{self.scene.kind!r} scenes have no trees)"
            )
        if self.scene.reuse == "pool" and self.scene.pool_size > self.n_samples:
            raise SpecError(
                f"scene.pool_size = {self.scene.pool_size} exceeds n_samples = {self.n_samples}"
            )
        index = INDEX_BYTES_PER_SAMPLE * self.n_samples + INDEX_BYTES_PER_CHUNK * self.n_chunks
        if index > memory_limit():
            raise SpecError(
                f"n_samples = {self.n_samples}: the store's sample and chunk indexes need about "
                f"{human_bytes(index)}, over batecho's memory limit of "
                f"{human_bytes(memory_limit())}; split the dataset into several stores (or "
                "raise the limit with batecho.set_memory_limit)"
            )
        r_min = self.sonar.min_leaf_radius_m
        if self.leaves.radius_min_m < r_min:
            raise SpecError(
                f"leaves.radius_min_m = {self.leaves.radius_min_m:g} m is below "
                f"{r_min:.3g} m, the smallest leaf the leaf models accept at "
                f"{self.sonar.band_hz[0]:g} Hz (k a >= 0.5)"
            )
        p = self.pulses_per_sample
        t0, t1 = self.sonar.time_slice()
        width = 4 if self.output.dtype == "float32" else 8
        # (with branches, the wood's share of the spectrum is stored too)
        spectra = (2 if self.has_wood else 1) * int(self.output.spectrum)
        values = (t1 - t0) * self.output.impulse + 2 * self.sonar.n_bins * spectra
        per_sample = p * width * values
        if per_sample * min(self.output.chunk_size, self.n_samples) > MAX_CHUNK_BYTES:
            raise SpecError(
                f"output.chunk_size = {self.output.chunk_size} samples makes chunks of about "
                f"{per_sample * self.output.chunk_size / 2**20:.0f} MiB; keep them under "
                f"{MAX_CHUNK_BYTES // 2**20} MiB"
            )

    # -- construction --------------------------------------------------------------
    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> DatasetSpec:
        """A validated spec from nested plain data (as parsed from TOML)."""
        return cls._from_mapping(data, "")

    @classmethod
    def from_toml_string(cls, text: str) -> DatasetSpec:
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise SpecError(f"not valid TOML: {exc}") from None
        return cls.from_dict(data)

    @classmethod
    def from_toml(cls, path: str | Path) -> DatasetSpec:
        """Read and validate a spec file."""
        p = Path(path)
        try:
            text = p.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise FileNotFoundError(f"spec file {p} does not exist") from None
        try:
            return cls.from_toml_string(text)
        except SpecError as exc:
            raise SpecError(f"{p}: {exc}") from None

    def with_values(self, changes: Mapping[str, Any]) -> DatasetSpec:
        """A copy with dotted keys changed, revalidated: ``{"sonar.n_samples": 2000}``."""
        data = self.to_dict()
        for key, value in changes.items():
            parts = key.split(".")
            node = data
            for part in parts[:-1]:
                node = node.setdefault(part, {})
                if not isinstance(node, dict):
                    raise SpecError(f"{key}: {part} is not a table")
            node[parts[-1]] = value.to_toml_value() if isinstance(value, Dist) else value
        return DatasetSpec.from_dict(data)

    # -- output ----------------------------------------------------------------------
    def to_dict(self, full: bool = False) -> dict[str, Any]:
        """Nested plain data (distributions as numbers or one-key tables): every field, but
        the later optional ones (shading, branches) at their defaults unless ``full``."""
        return self._to_dict(full)

    def to_toml(self, full: bool = False) -> str:
        """The canonical TOML text: every field in a fixed order (the later optional ones at
        their defaults only with ``full``). ``from_toml_string`` of it gives an equal spec, and
        the SHA-256 of the canonical text (:attr:`sha256`) identifies the spec."""
        return _dump_toml(self.to_dict(full))

    @property
    def sha256(self) -> str:
        """Hex SHA-256 of :meth:`to_toml` (UTF-8)."""
        return hashlib.sha256(self.to_toml().encode("utf-8")).hexdigest()

    # -- derived -----------------------------------------------------------------------
    @property
    def has_wood(self) -> bool:
        """Whether the scenes hold branches (forests with ``scene.forest.branches``)."""
        return self.scene.kind == "forest" and self.scene.forest.branches

    @property
    def chunk_size(self) -> int:
        return min(self.output.chunk_size, self.n_samples)

    @property
    def n_chunks(self) -> int:
        return -(-self.n_samples // self.chunk_size)

    def chunk_range(self, k: int) -> tuple[int, int]:
        """Samples ``[i0, i1)`` of chunk ``k``."""
        if not 0 <= k < self.n_chunks:
            raise IndexError(f"chunk {k} out of range (0..{self.n_chunks - 1})")
        i0 = k * self.chunk_size
        return i0, min(self.n_samples, i0 + self.chunk_size)

    def scene_index(self, i: int) -> int:
        """Which scene sample ``i`` uses."""
        if self.scene.reuse == "per_sample":
            return i
        return i * self.scene.pool_size // self.n_samples


# --------------------------------------------------------------------------- TOML out


def _toml_key(k: str) -> str:
    if k and all(c.isalnum() or c in "_-" for c in k):
        return k
    return json.dumps(k)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise SpecError(f"cannot write {v} to TOML")
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, Mapping):
        inner = ", ".join(f"{_toml_key(str(k))} = {_toml_value(x)}" for k, x in v.items())
        return "{ " + inner + " }" if inner else "{}"
    raise SpecError(f"cannot write {type(v).__name__} {v!r} to TOML")


def _dump_toml(data: Mapping[str, Any]) -> str:
    lines = ["# batecho dataset spec (canonical form: every key, fixed order)"]

    def emit(table: Mapping[str, Any], prefix: str) -> None:
        subs = []
        for k, v in table.items():
            if isinstance(v, dict) and k in _TABLE_KEYS.get(prefix, ()):
                subs.append((k, v))
            else:
                lines.append(f"{_toml_key(k)} = {_toml_value(v)}")
        for k, v in subs:
            name = f"{prefix}.{k}" if prefix else k
            lines.append("")
            lines.append(f"[{name}]")
            emit(v, name)

    emit(data, "")
    return "\n".join(lines) + "\n"


#: Which keys of each table are sub-tables (written as [a.b]); others are inline values.
_TABLE_KEYS: dict[str, tuple[str, ...]] = {
    "": ("scene", "leaves", "sonar", "poses", "output", "call"),
    "scene": ("leaf_box", "forest"),
}
