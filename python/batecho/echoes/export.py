"""Echoes as files other tools open: an xarray Dataset (named dimensions, units, the sonar as
attributes), a WAV file to listen to (time-expanded, one channel per receiver) and a MATLAB
MAT file.

Every export has a receiver dimension: the receivers of ``Sonar(receivers=...)``, or one
receiver at the emitter (``"emitter"``) for a sonar without them.
"""

from __future__ import annotations

import errno
import json
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .._core import __version__
from .._validate import real_array
from ..sonar.record import sonar_params

if TYPE_CHECKING:
    from ..sonar.call import Call

__all__ = ["to_mat", "to_wav", "to_xarray", "with_receiver_axis", "wood_and_shading", "write_wav"]


def with_receiver_axis(echoes: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(spectrum (p, R, M), impulse (p, R, n), n_leaves (p, R))``: a sonar without receivers
    of its own gets a receiver axis of length 1."""
    if echoes.n_receivers:
        return echoes.spectrum, echoes.impulse, echoes.n_leaves
    return echoes.spectrum[:, None], echoes.impulse[:, None], echoes.n_leaves[:, None]


def wood_and_shading(echoes: Any) -> dict[str, np.ndarray]:
    """The echoes' wood and shading arrays as they hold them, only where the scene has them:
    ``wood_spectrum`` and ``n_pieces`` with branches, ``n_shaded`` when the sonar shades."""
    out: dict[str, np.ndarray] = {}
    if echoes.wood_spectrum is not None:
        out["wood_spectrum"] = echoes.wood_spectrum
        out["n_pieces"] = echoes.n_pieces
    if echoes.sonar.shading is not None:
        out["n_shaded"] = echoes.n_shaded
    return out


def _wood_and_shading_per_receiver(echoes: Any) -> dict[str, np.ndarray]:
    """:func:`wood_and_shading` with a receiver axis after the pose axis."""
    out = wood_and_shading(echoes)
    return out if echoes.n_receivers else {name: x[:, None] for name, x in out.items()}


#: Dimensions and attributes of the wood and shading variables of the xarray Dataset.
_WOOD_AND_SHADING_VARS: dict[str, tuple[tuple[str, ...], dict[str, str]]] = {
    "wood_spectrum": (
        ("pose", "receiver", "frequency"),
        {"units": "1", "long_name": "the branches' share of the spectrum Y_k"},
    ),
    "n_pieces": (
        ("pose", "receiver"),
        {"units": "1", "long_name": "branch pieces that counted"},
    ),
    "n_shaded": (
        ("pose", "receiver"),
        {"units": "1", "long_name": "counting leaves that shading dimmed or silenced"},
    ),
}


def _receiver_table(echoes: Any) -> tuple[list[str], np.ndarray]:
    """Receiver names and offsets (R, 3) (m, in the sonar's frame)."""
    rxs = echoes.sonar.receivers
    if not rxs:
        return ["emitter"], np.zeros((1, 3))
    names = ["left", "right"] if len(rxs) == 2 and _is_binaural(echoes) else None
    names = names or [f"receiver {j}" for j in range(len(rxs))]
    offsets = np.array([r.offset_m for r in rxs], dtype=np.float64)
    if echoes.receiver is not None:  # one receiver's echoes
        return [names[echoes.receiver]], offsets[echoes.receiver : echoes.receiver + 1]
    return names, offsets


def _is_binaural(echoes: Any) -> bool:
    rxs = echoes.sonar.receivers
    assert rxs is not None
    return rxs[0].offset_m[1] > 0 > rxs[1].offset_m[1]


def _scalar_attrs(echoes: Any) -> dict[str, Any]:
    s = echoes.sonar
    return {
        "fs_hz": float(s.fs),
        "n_samples": int(s.n_samples),
        "band_hz": [float(x) for x in s.band_hz],
        "sound_speed_m_per_s": float(s.sound_speed),
        "leaf_model": s.leaf_model,
        "lobe": s.lobe,
        "window": s.window,
        "gain": float(s.gain),
        "spreading": int(bool(s.spreading)),
        "sonar_json": json.dumps(sonar_params(s), sort_keys=True),
        "batecho_version": __version__,
    }


def to_xarray(echoes: Any, call: Call | None = None, received: np.ndarray | None = None):
    """The echoes as an ``xarray.Dataset`` (needs the ``xarray`` extra: ``pip install
    batecho[xarray]``).

    Dimensions ``pose``, ``receiver``, ``time``, ``frequency`` and ``xyz``. Variables:
    ``impulse`` (pose, receiver, time), ``spectrum`` (pose, receiver, frequency, complex),
    ``n_leaves`` (pose, receiver), the poses' ``position``, ``forward``, ``up``, ``left``
    (pose, xyz); with branches in the scene ``wood_spectrum`` (pose, receiver, frequency,
    complex: the branches' share of ``spectrum``) and ``n_pieces`` (pose, receiver); when
    the sonar shades, ``n_shaded`` (pose, receiver). Coordinates: ``time`` (s), ``frequency``
    (Hz), ``range`` along time (m, ``v t / 2``), the receivers' names and ``receiver_offset``
    (receiver, xyz; m, in the sonar's frame). Attributes: the sonar's parameters
    (``sonar_json`` holds every one).

    With ``call``, also ``received`` (pose, receiver, time): what the receivers record (given
    as ``received``, or :meth:`Echoes.received` without noise), and the call's ``call``
    samples along ``call_time`` (s).
    """
    try:
        import xarray as xr
    except ImportError:  # pragma: no cover - the extra is installed in the tests
        raise ImportError("Echoes.to_xarray needs xarray: pip install 'batecho[xarray]'") from None
    spec, imp, counts = with_receiver_axis(echoes)
    names, offsets = _receiver_table(echoes)
    poses = echoes.poses
    xyz = ("pose", "xyz")
    ds = xr.Dataset(
        data_vars={
            "impulse": (
                ("pose", "receiver", "time"),
                imp,
                {"units": "1", "long_name": "impulse response 2 irfft(Y, n)"},
            ),
            "spectrum": (
                ("pose", "receiver", "frequency"),
                spec,
                {"units": "1", "long_name": "windowed band spectrum Y_k"},
            ),
            "n_leaves": (
                ("pose", "receiver"),
                counts,
                {"units": "1", "long_name": "leaves that counted"},
            ),
            "position": (xyz, poses.positions, {"units": "m"}),
            "forward": (xyz, poses.forward, {"units": "1"}),
            "up": (xyz, poses.up, {"units": "1"}),
            "left": (xyz, poses.left, {"units": "1"}),
        },
        coords={
            "pose": ("pose", np.arange(len(poses))),
            "receiver": ("receiver", np.array(names, dtype=object)),
            "time": ("time", echoes.times, {"units": "s"}),
            "range": ("time", echoes.ranges, {"units": "m", "long_name": "range v t / 2"}),
            "frequency": ("frequency", echoes.freqs, {"units": "Hz"}),
            "xyz": ("xyz", np.array(["x", "y", "z"], dtype=object)),
            "receiver_offset": (
                ("receiver", "xyz"),
                offsets,
                {"units": "m", "long_name": "offset (forward, left, up) in the sonar's frame"},
            ),
        },
        attrs=_scalar_attrs(echoes),
    )
    for name, x in _wood_and_shading_per_receiver(echoes).items():
        dims, attrs = _WOOD_AND_SHADING_VARS[name]
        ds[name] = (dims, x, attrs)
    if call is not None:
        rec = _received(echoes, call, received)
        ds["received"] = (
            ("pose", "receiver", "time"),
            rec,
            {"units": "1", "long_name": "the impulse response convolved with the call"},
        )
        ds["call"] = ("call_time", call.samples, {"units": "1", "long_name": call.name})
        ds = ds.assign_coords(call_time=("call_time", call.times, {"units": "s"}))
    elif received is not None:
        raise ValueError("received is exported with its call: pass call= too")
    # (the Dataset owns its arrays: editing it leaves the echoes and the caller's arrays alone)
    return ds.copy(deep=True)


def _received(echoes: Any, call: Call, received: Any) -> np.ndarray:
    """What the receivers record, with a receiver axis: ``received`` (a copy, checked to be
    finite and shaped as the impulse responses) or :meth:`Echoes.received` without noise.
    ``call`` must be a :class:`~batecho.Call` at the echoes' rate either way."""
    from .received import _check_call

    _check_call(call, echoes.sonar.fs)
    if received is None:
        rec = echoes.received(call)
    else:
        rec = real_array(received, "received")
        if rec.shape != echoes.impulse.shape:
            raise ValueError(
                f"received must have the impulse responses' shape {echoes.impulse.shape}, "
                f"got {rec.shape}"
            )
        if not np.all(np.isfinite(rec)):
            raise ValueError("received must be finite")
    return rec if echoes.n_receivers else rec[:, None]


def _file_to_write(path: str | os.PathLike) -> Path:
    """``path`` as a Path whose folder exists (FileNotFoundError naming it otherwise) and that
    is not a folder itself (IsADirectoryError naming it)."""
    p = Path(path)
    if p.is_dir():
        raise IsADirectoryError(errno.EISDIR, "cannot write the echoes onto a folder", str(p))
    if not p.parent.is_dir():
        raise FileNotFoundError(f"cannot write {p}: the folder {p.parent} does not exist")
    return p


def _pcm16(x: np.ndarray) -> np.ndarray:
    peak = float(np.max(np.abs(x))) if x.size else 0.0
    if peak == 0.0:
        return np.zeros(x.shape, dtype=np.int16)
    return np.round(x / peak * 32767.0 * 0.99).astype(np.int16)


def to_wav(
    echoes: Any,
    path: str | os.PathLike,
    time_expansion: float = 10.0,
    receiver: int | None = None,
    call: Call | None = None,
    noise_rms: float = 0.0,
    rng: Any = None,
) -> Path:
    """Write the echoes as a 16-bit WAV file to listen to, as bat researchers do: the poses'
    records one after another, slowed down ``time_expansion`` times (the file's rate is
    ``fs / time_expansion``, rounded to the hertz), normalised to 99 % of full scale. One
    channel per receiver (stereo for two ears, the left first), or the one ``receiver``.

    Without ``call`` the impulse responses are written; with it, what the receivers record
    (:meth:`Echoes.received`, with ``noise_rms`` and ``rng``).
    """
    if call is None and (noise_rms != 0.0 or rng is not None):
        raise ValueError("noise_rms and rng are the noise of the received call: pass call= too")
    x = echoes.received(call, noise_rms, rng) if call is not None else echoes.impulse
    x = x if echoes.n_receivers else x[:, None]
    if receiver is not None:
        r = _receiver_index(receiver, x.shape[1])
        x = x[:, r : r + 1]
    return write_wav(path, x, echoes.sonar.fs, time_expansion)


def write_wav(path: str | os.PathLike, x: np.ndarray, fs: float, time_expansion: float) -> Path:
    """Write ``x`` (pose, receiver, time) as a 16-bit WAV file: the poses one after another,
    one channel per receiver, at the rate ``fs / time_expansion`` (rounded to the hertz),
    normalised to 99 % of full scale."""
    from scipy.io import wavfile

    from .._validate import positive_scalar

    te = positive_scalar(time_expansion, "time_expansion", strict=True)
    rate = round(fs / te)
    if not 1 <= rate <= 2**31 - 1:
        raise ValueError(f"fs / time_expansion = {fs / te:g} Hz is not a WAV rate")
    p = _file_to_write(path)
    # (pose, receiver, time) -> (pose time, receiver)
    frames = np.ascontiguousarray(np.transpose(x, (0, 2, 1)).reshape(-1, x.shape[1]))
    data = _pcm16(frames)
    wavfile.write(p, rate, data[:, 0] if data.shape[1] == 1 else data)
    return p


def _receiver_index(receiver: Any, n: int) -> int:
    if isinstance(receiver, bool) or not isinstance(receiver, (int, np.integer)):
        raise TypeError(f"receiver must be an int index or None, got {receiver!r}")
    if not 0 <= receiver < n:
        raise ValueError(f"receiver {receiver} out of range: the echoes have {n} receivers")
    return int(receiver)


def to_mat(
    echoes: Any,
    path: str | os.PathLike,
    call: Call | None = None,
    received: np.ndarray | None = None,
) -> Path:
    """Write the echoes as a MATLAB MAT file (``scipy.io.savemat``, format 5): ``impulse``
    (pose, receiver, time), ``spectrum`` (pose, receiver, frequency), ``n_leaves``, ``times``
    (s), ``freqs`` (Hz), ``positions``, ``forward``, ``up``, ``left`` (pose, 3),
    ``receiver_offsets`` (receiver, 3; m), ``receiver_names``, ``fs``, ``sound_speed``,
    ``sonar_json`` and ``batecho_version``; with branches in the scene ``wood_spectrum``
    (pose, receiver, frequency) and ``n_pieces`` (pose, receiver), when the sonar shades
    ``n_shaded`` (pose, receiver); with ``call``, ``received`` (pose, receiver,
    time: given, or :meth:`Echoes.received` without noise) and the ``call`` samples."""
    from scipy.io import savemat

    spec, imp, counts = with_receiver_axis(echoes)
    names, offsets = _receiver_table(echoes)
    poses = echoes.poses
    p = _file_to_write(path)
    # (counts as doubles, as n_leaves: MATLAB's default class)
    extra: dict[str, Any] = {
        name: x if name == "wood_spectrum" else x.astype(np.float64)
        for name, x in _wood_and_shading_per_receiver(echoes).items()
    }
    if call is not None:
        extra |= {"received": _received(echoes, call, received), "call": call.samples}
    elif received is not None:
        raise ValueError("received is exported with its call: pass call= too")
    savemat(
        p,
        extra
        | {
            "impulse": imp,
            "spectrum": spec,
            "n_leaves": counts.astype(np.float64),
            "times": echoes.times,
            "freqs": echoes.freqs,
            "positions": poses.positions,
            "forward": poses.forward,
            "up": poses.up,
            "left": poses.left,
            "receiver_offsets": offsets,
            "receiver_names": np.array(names, dtype=object),
            "fs": float(echoes.sonar.fs),
            "sound_speed": float(echoes.sonar.sound_speed),
            "sonar_json": json.dumps(sonar_params(echoes.sonar), sort_keys=True),
            "batecho_version": __version__,
        },
        do_compression=True,
    )
    return p
