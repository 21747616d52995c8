"""A scene file read and checked, and the sonar, scene and flight it describes built from it."""

from __future__ import annotations

import copy
import os
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..sonar.beam import Beam
from ..sonar.call import Call
from ..sonar.receivers import Receiver, binaural_receivers
from ..sonar.sonar import Sonar
from ..trees.leaves import Leaves
from .flightplan import FlightPlan, flight_plan
from .schema import SCENE_KEYS_BY_KIND, ScenefileError, check_document

__all__ = ["SceneFile"]


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
            cfg = check_document(doc)
        except ScenefileError as exc:
            raise ScenefileError(f"{name}: {exc}") from None
        return cls(cfg, text, None if path is None else Path(path))

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any], base_dir: str | os.PathLike | None = None):
        """Check a scene description given as a dict (the parsed TOML); relative paths are
        taken from ``base_dir`` (default: the working folder)."""
        try:
            cfg = check_document(dict(doc))
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

    def with_seed(self, seed: int) -> SceneFile:
        """A copy whose ``seed`` is ``seed``, in ``config`` and in ``text`` (its top-level
        ``seed = ...`` line rewritten, or one added at the top), so that the text reruns it."""
        config = dict(copy.deepcopy(self.config), seed=int(seed))
        text = self.text
        if text:
            table = re.search(r"^[ \t]*\[", text, re.M)
            top = table.start() if table else len(text)
            line = re.compile(
                r"^([ \t]*([\"']?)seed\2[ \t]*=[ \t]*)[^#\n]*?([ \t]*(?:#.*)?)$", re.M
            )
            if line.search(text, 0, top):
                head = line.sub(lambda m: f"{m.group(1)}{int(seed)}{m.group(3)}", text[:top], 1)
                text = head + text[top:]
            else:
                text = f"seed = {int(seed)}\n" + text
            try:
                rewritten = tomllib.loads(text).get("seed") == int(seed)
            except tomllib.TOMLDecodeError:
                rewritten = False
            if not rewritten:  # pragma: no cover - a safeguard
                raise AssertionError("rewriting the seed of the scene file's text failed")
        return SceneFile(config, text, self.path)

    @property
    def _name(self) -> str:
        return str(self.path) if self.path is not None else "<string>"

    def _err(self, msg: str) -> ScenefileError:
        return ScenefileError(f"{self._name}: {msg}")

    # -- building ----------------------------------------------------------------------
    def build_sonar(self) -> Sonar:
        """The :class:`batecho.Sonar` of ``[sonar]``."""
        cfg = dict(self.config["sonar"])
        kw: dict[str, Any] = {}
        binaural = cfg.pop("binaural", None)
        for key, val in cfg.items():
            if key in ("beam", "receiver"):
                if val:
                    kw[key] = self._beam(val, f"sonar.{key}")
            elif key == "receivers":
                rxs = []
                for i, rx in enumerate(val):
                    beam = (
                        self._beam(rx["beam"], f"sonar.receivers[{i}].beam")
                        if rx.get("beam")
                        else None
                    )
                    try:
                        rxs.append(Receiver(tuple(rx["offset_m"]), beam))
                    except (TypeError, ValueError) as exc:
                        raise self._err(f"[sonar.receivers[{i}]] {exc}") from None
                kw[key] = tuple(rxs)
            elif key == "absorption":
                if val:
                    from ..sonar.absorption import Atmosphere

                    try:
                        kw[key] = Atmosphere(**val)
                    except (TypeError, ValueError) as exc:
                        raise self._err(f"[sonar.absorption] {exc}") from None
            elif key == "shading":
                if val:
                    from ..sonar.shading import Shading

                    try:
                        kw[key] = Shading(**val)
                    except (TypeError, ValueError) as exc:
                        raise self._err(f"[sonar.shading] {exc}") from None
            elif key == "band_hz":
                kw[key] = tuple(val)
            else:
                kw[key] = val
        hb = kw.pop("horseshoe_bat_khz", None)
        try:
            if hb is not None:
                if "beamwidth_deg" in kw or "beam" in kw:
                    raise ValueError("give horseshoe_bat_khz or beamwidth_deg / [sonar.beam]")
                sonar = Sonar.horseshoe_bat(hb, **kw)
            else:
                sonar = Sonar(**kw)
            if binaural:
                ear = binaural.get("ear_beam")
                ear_beam = self._beam(ear, "sonar.binaural.ear_beam") if ear else sonar.beam
                assert ear_beam is not None
                sonar = sonar.replace(
                    receivers=binaural_receivers(
                        binaural["separation_m"],
                        binaural["ear_yaw_deg"],
                        binaural["ear_pitch_deg"],
                        ear_beam,
                    )
                )
            return sonar
        except (TypeError, ValueError) as exc:
            raise self._err(f"[sonar] {exc}") from None
        except MemoryError as exc:
            raise MemoryError(f"{self._name}: [sonar] {exc}") from None

    def _beam(self, table: dict[str, Any], where: str) -> Beam:
        try:
            kw: dict[str, Any] = {
                k: tuple(v) if isinstance(v, list) else v for k, v in table.items()
            }
            return Beam(**kw)
        except (TypeError, ValueError) as exc:
            raise self._err(f"[{where}] {exc}") from None

    def build_call(self, fs: float) -> Call | None:
        """The :class:`batecho.Call` of ``[call]`` at the sonar's rate ``fs``, or None."""
        c = self.config.get("call")
        if not c:
            return None
        kw = {k: v for k, v in c.items() if k not in ("kind", "noise_rms")}
        try:
            return getattr(Call, c["kind"])(fs=fs, **kw)
        except (TypeError, ValueError) as exc:
            raise self._err(f"[call] {exc}") from None

    def build_scene(self, rng: np.random.Generator) -> tuple[Any, Leaves, np.ndarray | None]:
        """``(scene object, leaves, tree positions (t, 2) or None)`` of ``[scene]``; the scene
        object is what gets drawn (a forest with its bark, an OBJ mesh, or the leaves)."""
        sc = self.config["scene"]
        kind = sc["kind"]
        try:
            if kind == "leaf_box":
                from ..echoes.canonical import canonical_leaf_box

                kw = {k: v for k, v in sc.items() if k in SCENE_KEYS_BY_KIND["leaf_box"]}
                if "box" in kw:
                    kw["box"] = tuple(tuple(b) for b in kw["box"])
                leaves = canonical_leaf_box(rng, **kw)
                return leaves, leaves, None
            if kind == "obj":
                from ..trees.objfile import load_obj, no_leaves_reason

                p = Path(sc["path"])
                p = p if p.is_absolute() else self.base_dir / p
                if not p.exists():
                    raise self._err(f"[scene] path: OBJ file not found: {p}")
                if p.is_dir():
                    raise self._err(f"[scene] path: {p} is a folder, not an OBJ file")
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
                    reason = no_leaves_reason(mesh, sc.get("leaf_patterns"))
                    raise self._err(f"[scene] path: {p}: {reason}")
                return mesh, mesh.leaves, None
            from ..forest.ipp import PAPER_WINDOW, draw_tree_positions, sample_ipp
            from ..forest.models import make_forest

            model, params = sc.get("model", "grow_tree"), dict(sc.get("tree", {}))
            if kind == "tree":
                pos = np.asarray([sc.get("position", [0.0, 0.0])])
            elif "positions" in sc:
                pos = np.asarray(sc["positions"])
            else:
                lam = _intensity(sc.get("intensity", "paper"))
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
        except MemoryError as exc:
            raise MemoryError(f"{self._name}: [scene] {exc}") from None

    def build_flight(
        self, center_xy: np.ndarray, forest: Any = None, bytes_per_pulse: float = 0.0
    ) -> FlightPlan:
        """The pulse poses of ``[flight]``; ``center_xy`` is the scene's centre (m), the
        default centre of circles and figure eights and the default look-at target;
        ``forest``, the scene's :class:`batecho.Forest` (for ``radius = "clear"``). The
        pulses times ``bytes_per_pulse`` (their echoes) must fit the memory limit."""
        try:
            return flight_plan(
                self.config["flight"],
                np.asarray(center_xy, dtype=np.float64),
                forest,
                bytes_per_pulse,
            )
        except ScenefileError as exc:
            raise self._err(str(exc)) from None
        except (TypeError, ValueError) as exc:
            raise self._err(f"[flight] {exc}") from None
        except MemoryError as exc:
            raise MemoryError(f"{self._name}: {exc}") from None


def _intensity(spec: Any):
    from ..forest.ipp import SquaredExponentialMixture, paper_intensity

    if spec == "paper":
        return paper_intensity()
    return SquaredExponentialMixture(
        centers=np.asarray(spec["centers"]),
        length_scales=np.asarray(spec["length_scales"]),
        weights=np.asarray(spec["weights"]),
    )
