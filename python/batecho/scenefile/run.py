"""Running a scene file: build its scene, sonar and flight, simulate the echoes, and write
``echoes.npz``, the plots of ``[output]`` and, if asked, the scene as an OBJ file."""

from __future__ import annotations

import os
import re
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._resources import echoes_bytes_per_pulse
from .._validate import flag
from ..echoes.export import wood_and_shading
from ..echoes.simulate import DEFAULT_METHOD, DEFAULT_TOL
from ..forest.clearance import ClearanceWarning, SolidClearance, low_clearance, solid_clearance
from ..forest.scene import Scene
from ..outputs.files import check_output_folder, make_output_folder, writing
from ..outputs.npz import write_npz
from ..sonar.record import sonar_params
from ..sonar.sonar import Sonar
from .file import SceneFile
from .flightplan import FlightPlan
from .schema import RECEIVER_PLOTS, ScenefileError

__all__ = [
    "RunResult",
    "SimulationSetup",
    "check_clearance",
    "flight_min_clearance",
    "run_scenefile",
    "sample_indices",
    "setup_scenefile",
    "simulate_options",
    "sonar_params",
]


def simulate_options(method: str = DEFAULT_METHOD, tol: float = DEFAULT_TOL) -> dict[str, Any]:
    """Keyword arguments for :func:`batecho.simulate`: none for its defaults, else ``method``
    and ``tol``."""
    if method == DEFAULT_METHOD and tol == DEFAULT_TOL:
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
    # ([scene] branches = true: the trees' woody skeletons echo and may block, §9-§10)
    scene = obj.scene(branches=True) if sf.config["scene"].get("branches") else Scene(leaves)
    t2 = time.perf_counter()
    sonar = sf.build_sonar()
    n = sonar._provisional_n() if sonar.is_auto else int(sonar.n_samples)
    f_lo, f_hi = sonar.band_hz
    bins = (float(f_hi) - float(f_lo)) * n / sonar.fs + 1.0
    if pos is not None and len(pos):
        center = np.asarray(pos, dtype=np.float64).mean(axis=0)
    else:
        lo, hi = leaves.bounds()
        center = 0.5 * (lo[:2] + hi[:2])
    plan = sf.build_flight(
        center,
        obj if pos is not None else None,
        bytes_per_pulse=echoes_bytes_per_pulse(bins, n, sonar.n_receivers),
    )
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


def check_clearance(st: SimulationSetup) -> SolidClearance:
    """Every pulse's distance to the nearest leaf and bark. A pulse closer than ``[flight]
    min_clearance_m`` is refused (:class:`ScenefileError`), or with ``allow_low_clearance =
    true`` warned of (:class:`batecho.ClearanceWarning`)."""
    sf, fl = st.scenefile, st.scenefile.config["flight"]
    pos = st.plan.poses.positions
    cl = _clearance(st, pos, "a pulse")
    margin = fl["min_clearance_m"]
    msg = low_clearance(cl.distance, cl.part, pos, margin, noun="pulse") if margin > 0 else None
    if msg is not None:
        if not fl["allow_low_clearance"]:
            raise ScenefileError(
                f"{sf.path or '<string>'}: [flight] {msg}. Move the flight (radius, altitude, "
                "center, positions) or set [flight] allow_low_clearance = true to simulate it "
                "anyway"
            )
        warnings.warn(msg, ClearanceWarning, stacklevel=3)
    return cl


def _clearance(st: SimulationSetup, points: np.ndarray, what: str) -> SolidClearance:
    """:func:`solid_clearance` of ``points`` (``what``: the pulses or the flight's steps);
    points too far out to measure (a huge altitude or radius) name the scene file's
    ``[flight]`` table."""
    try:
        return solid_clearance(st.scene_object, points, scene=st.scene)
    except ValueError as exc:
        raise ScenefileError(
            f"{st.scenefile.path or '<string>'}: [flight] {what} is out of reach ({exc}); "
            "check altitude, center, radius, start, target and points"
        ) from None


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
    clearance: SolidClearance | None = None
    #: The flight's smallest clearance from leaves and bark (m) and when it occurs (s; None
    #: for pulses placed by count): see :func:`flight_min_clearance`.
    min_clearance_m: float | None = None
    min_clearance_time_s: float | None = None


def flight_min_clearance(
    st: SimulationSetup, clearance: SolidClearance
) -> tuple[float, float | None]:
    """The flight's smallest distance (m) from the scene's leaves and bark, and its time (s):
    over every recorded step of a flown flight, else over the pulses (``clearance``, theirs;
    the time is the pulse's, or None when the pulses are placed by count)."""
    fl = st.plan.flight
    if fl is not None:
        d = _clearance(st, fl.positions, "a step of the flight").distance
        i = int(np.argmin(d))
        return float(d[i]), float(fl.times[i])
    d = clearance.distance
    i = int(np.argmin(d))
    times = st.plan.pulse_times
    return float(d[i]), None if times is None else float(times[i])


def run_scenefile(
    sf: SceneFile | str | os.PathLike,
    out_dir: str | os.PathLike,
    *,
    plots: bool = True,
    progress: Callable[[str], None] | None = None,
) -> RunResult:
    """Build, simulate and write the outputs of a scene file into ``out_dir``: ``sf`` is a
    :class:`SceneFile` or the path of one (read with :meth:`SceneFile.from_path`).

    Writes ``echoes.npz`` (``[output] npz``) with keys ``spectrum``, ``freqs``, ``band_bins``
    (first and last band bin: ``impulse = 2 irfft(Y, n_samples)`` with ``Y`` zero outside
    them), ``impulse`` (unless ``impulse = false``), ``times``, ``n_leaves``, ``positions``,
    ``forward``, ``up``, ``left``, ``pulse_times`` (empty for pulses placed by count),
    ``sample_indices``, ``clearance_m`` (each pulse's distance to the nearest leaf or bark),
    ``min_clearance_m`` and ``min_clearance_time_s`` (the flight's smallest such distance over
    every recorded step when flown, else over the pulses, and its time: NaN by count),
    ``tree_positions``, ``path_points``, ``seed``, ``config_toml`` (the file's text, with
    the seed used: see :meth:`SceneFile.with_seed`), ``config_json`` (every table with its
    defaults), ``sonar_json``, ``scene_json``, ``batecho_version`` and, when flown,
    ``flight_times``, ``flight_positions``, ``flight_reference_positions``; the PNG plots
    of ``[output] plots`` (``scene_3d.png``, ``impulses.png``, ``echo_image.png``,
    ``spectrogram.png``, ``spectrum.png``) and, with ``[output] obj = true``, ``scene.obj``.
    ``progress(message)`` is told of each step. A pulse closer than ``[flight]
    min_clearance_m`` to a leaf or bark is refused (see :func:`check_clearance`).
    """
    from ..echoes.simulate import simulate

    plots = flag(plots, "plots")
    if isinstance(sf, (str, os.PathLike)):
        sf = SceneFile.from_path(sf)
    elif not isinstance(sf, SceneFile):
        raise TypeError(
            f"run_scenefile takes a SceneFile or the path of a scene file, got {type(sf).__name__}"
        )
    say = progress or (lambda msg: None)
    out = check_output_folder(out_dir)
    _check_obj_inputs_kept(sf, out)
    say("building the scene and the flight")
    st = setup_scenefile(sf)
    cfg = sf.config
    oc = cfg["output"]
    call = sf.build_call(st.sonar.fs)
    if oc["wav"]:
        _check_wav_rate(sf, st.sonar.fs)
    say("checking the clearance of every pulse from leaves and bark")
    t0 = time.perf_counter()
    clearance = check_clearance(st)
    least, least_t = flight_min_clearance(st, clearance)
    st.timings_s["clearance_s"] = time.perf_counter() - t0
    say(f"simulating {len(st.plan.poses)} pulses on {st.scene.n_leaves} leaves")
    t0 = time.perf_counter()
    try:
        echoes = simulate(
            st.scene,
            st.sonar,
            st.plan.poses,
            **simulate_options(cfg["method"], cfg["tol"]),
            min_clearance_m=0.0,  # checked above, bark included
        )
    except ValueError as exc:
        raise ScenefileError(f"{sf.path or '<string>'}: simulating: {exc}") from None
    timings = dict(st.timings_s, simulate_s=time.perf_counter() - t0)
    make_output_folder(out)
    files: list[Path] = []
    p = len(echoes)
    idx = sample_indices(p, oc["sample_points"], st.plan.closed)
    received = None
    if call is not None:
        say(f"receiving the call ({call!r})")
        # (the noise's own stream of the file's seed)
        noise_rng = np.random.default_rng([abs(int(sf.seed)), 34])
        received = echoes.received(call, cfg["call"]["noise_rms"], noise_rng)
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
            "band_bins": np.asarray(echoes.sonar.bins),
            "times": echoes.times,
            "n_leaves": echoes.n_leaves,
            "positions": echoes.poses.positions,
            "forward": echoes.poses.forward,
            "up": echoes.poses.up,
            "left": echoes.poses.left,
            "pulse_times": np.zeros(0) if st.plan.pulse_times is None else st.plan.pulse_times,
            "sample_indices": idx,
            "clearance_m": clearance.distance,
            "min_clearance_m": least,
            "min_clearance_time_s": np.nan if least_t is None else least_t,
            "tree_positions": np.zeros((0, 2)) if st.tree_positions is None else st.tree_positions,
            "path_points": st.plan.path_points,
            "seed": sf.seed,
            "config_toml": sf.text,
        }
        if oc["impulse"]:
            arrays["impulse"] = echoes.impulse
        arrays |= wood_and_shading(echoes)
        if echoes.n_receivers:
            arrays["receiver_offsets"] = np.array([r.offset_m for r in st.sonar.receivers or ()])
        if received is not None and call is not None:
            arrays["received"] = received
            arrays["call"] = call.samples
        if st.plan.flight is not None:
            fl = st.plan.flight
            arrays["flight_times"] = fl.times
            arrays["flight_positions"] = fl.positions
            arrays["flight_reference_positions"] = fl.reference_positions
        records = {
            "config_json": cfg,
            "sonar_json": sonar_params(st.sonar),
            "scene_json": scene_desc,
        }
        with writing(out / "echoes.npz"):
            files.append(write_npz(out / "echoes.npz", arrays, records))
    files += _exports(echoes, out, oc, call, received, say)
    if oc["obj"]:
        say("writing scene.obj")
        with writing(out / "scene.obj"):
            files.append(_write_scene_obj(st, out / "scene.obj"))
    if plots and oc["plots"]:
        files += _plots(st, echoes, idx, out, oc, say)
    return RunResult(st, echoes, files, timings, clearance, least, least_t)


def _check_obj_inputs_kept(sf: SceneFile, out: Path) -> None:
    """Refuse, before any work, ``[output] obj = true`` whose ``scene.obj`` or ``scene.mtl``
    would overwrite an input of the scene: its OBJ file, or a material library that the OBJ
    names (``mtllib``) in its folder."""
    sc = sf.config["scene"]
    if not sf.config["output"]["obj"] or sc["kind"] != "obj":
        return
    src = Path(sc["path"])
    src = src if src.is_absolute() else sf.base_dir / src
    hit = None
    if _same_file(out / "scene.obj", src):
        hit = out / "scene.obj", "OBJ file"
    elif (out / "scene.mtl").exists() and _same_file(out, src.parent):
        text = src.read_bytes() if src.is_file() else b""
        names = re.findall(rb"^[ \t]*mtllib[ \t]+(.*)$", text, flags=re.MULTILINE)
        if any(b"scene.mtl" in line.split() for line in names):
            hit = out / "scene.mtl", f"material library (mtllib of {src})"
    if hit is not None:
        raise ScenefileError(
            f"{sf.path or '<string>'}: [output] obj = true would overwrite {hit[0]}, the "
            f"scene's own {hit[1]}; write to another folder (--out)"
        )


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:  # (either is missing)
        return False


def _exports(echoes, out: Path, oc: dict, call, received, say) -> list[Path]:
    """``[output] wav``, ``mat`` and ``xarray``: the received call where ``[call]`` is given,
    else the impulse responses."""
    files = []
    if oc["wav"]:
        say("writing echoes.wav")
        with writing(out / "echoes.wav"):
            files.append(_wav(echoes, out / "echoes.wav", oc["wav_time_expansion"], received))
    if oc["mat"]:
        say("writing echoes.mat")
        with writing(out / "echoes.mat"):
            files.append(echoes.to_mat(out / "echoes.mat", call=call, received=received))
    if oc["xarray"]:
        say("writing echoes.zarr")
        import shutil

        path = out / "echoes.zarr"
        if path.exists():
            shutil.rmtree(path)
        ds = echoes.to_xarray(call=call, received=received)
        with writing(path), warnings.catch_warnings():
            # (consolidated, so that xarray.open_zarr opens it in one read and without a
            # warning; zarr notes that consolidated metadata is not in the v3 spec)
            warnings.simplefilter("ignore", UserWarning)
            ds.to_zarr(path, consolidated=True)
        files.append(path)
    return files


def _check_wav_rate(sf: SceneFile, fs: float) -> None:
    te = sf.config["output"]["wav_time_expansion"]
    if not 1 <= round(fs / te) <= 2**31 - 1:
        raise ScenefileError(
            f"{sf.path or '<string>'}: [output] wav_time_expansion: fs / {te:g} = "
            f"{fs / te:g} Hz is not a WAV rate (1 Hz to 2^31 - 1 Hz)"
        )


def _wav(echoes, path: Path, time_expansion: float, received) -> Path:
    from ..echoes.export import write_wav

    x = echoes.impulse if received is None else received
    return write_wav(path, x if echoes.n_receivers else x[:, None], echoes.sonar.fs, time_expansion)


def _write_scene_obj(st: SimulationSetup, path: Path) -> Path:
    obj = st.scene_object
    if callable(getattr(obj, "to_obj", None)):
        return Path(obj.to_obj(path) or path)
    from ..trees.objfile import write_obj

    return write_obj(path, leaves=st.scene.leaves)


def _receiver_plot(name: str, echoes, best: int, st: SimulationSetup):
    from ..outputs.binaural import (
        plot_binaural_echo_images,
        plot_binaural_impulses,
        plot_interaural_differences,
    )

    x = st.plan.x
    order_ok = len(np.unique(x)) == len(x)
    kw: dict[str, Any] = dict(
        x=x if order_ok else None, xlabel=st.plan.x_label if order_ok else "pulse"
    )
    if name == "binaural_impulses":
        return plot_binaural_impulses(echoes, best)
    if name == "binaural_echo_images":
        return plot_binaural_echo_images(echoes, **kw)
    return plot_interaural_differences(echoes, **kw)


def _plots(st: SimulationSetup, echoes, idx, out: Path, oc: dict, say) -> list[Path]:
    import matplotlib.pyplot as plt

    from ..echoes.simulate import lobe_members
    from ..outputs.plots import (
        plot_echo_image,
        plot_impulses,
        plot_scene_3d,
        plot_spectrogram,
        plot_spectrum,
    )

    files = []
    dpi = oc["dpi"]
    heard = echoes
    if echoes.n_receivers:
        # (the one-receiver plots draw the first receiver: the left ear of two)
        echoes = echoes.for_receiver(0)
    best = int(idx[np.argmax(echoes.n_leaves[idx])])

    def save(fig, name):
        try:
            with writing(out / name):
                fig.savefig(out / name, dpi=dpi)
        finally:
            plt.close(fig)
        files.append(out / name)

    bw = None if st.sonar.beam is None else st.sonar.beam.beamwidth_deg
    beam = f"{bw:g} deg beam" if bw is not None else "custom beam"
    for name in oc["plots"]:
        say(f"plotting {name}")
        if name == "scene":
            first = 0 if heard.n_receivers else None
            members = [
                lobe_members(st.scene, st.sonar, st.plan.poses[int(i)], receiver=first) for i in idx
            ]
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
        elif name in RECEIVER_PLOTS:
            save(_receiver_plot(name, heard, best, st), f"{name}.png")
    return files
