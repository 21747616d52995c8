"""The reference's entry points (docs/model.md §5, §5a): ``simulate``, the echoes of every
pose by the exact sum over counting leaves and branch pieces with their shading, for one ear
at the emitter or receivers of their own; and ``lobe_members``, the counting leaves of a pose.
"""

from __future__ import annotations

from typing import Any, cast

import numpy as np

from ..echoes.simulate import Echoes
from ..flight.poses import Poses
from ..sonar.sonar import Sonar
from ..trees.branches import Branches
from ..trees.leaves import Leaves, as_leaves
from .branches import _pieces, _pieces_heard, _wood_spectrum
from .leaves import _grid, _incidence, _spectrum
from .lobe import _counting
from .parts import _parts
from .receivers import _bisector_incidence, _heard, _receiver_position
from .shading import _shading


def lobe_members(
    scene: Any,
    sonar: Sonar,
    pose: Poses,
    *,
    search: str = "brute_force",
    receiver: int | None = None,
) -> np.ndarray:
    """Indices (ascending) of the leaves that count for one pose (for receiver ``receiver`` of
    a sonar with receivers of its own), by testing every leaf."""
    leaves = as_leaves(scene)
    if len(pose) != 1:
        raise ValueError(f"lobe_members takes one pose; got {len(pose)}")
    if sonar.receivers is not None:
        mask = _heard(leaves, sonar, pose, 0)[cast(int, receiver)][0]
    else:
        mask = _counting(leaves, sonar, pose, 0)[0]
    return np.flatnonzero(mask).astype(np.int64)


def simulate(scene: Any, sonar: Sonar, poses: Poses, method: str = "exact") -> Echoes:
    """Echoes of ``scene`` for every pose, straight from docs/model.md (``method`` is ignored: the
    reference is always the exact sum). Branches (§9) and shading (§10) by brute force."""
    leaves, branches = _parts(scene)
    if not isinstance(sonar, Sonar) or not isinstance(poses, Poses):
        raise TypeError("simulate(scene, sonar: Sonar, poses: Poses)")
    if sonar.is_auto:
        # the record holds the farthest counting scatterer of any pose plus the pulse tail
        provisional = sonar.resolve(sonar._provisional_n())
        k_top = 2.0 * np.pi * _grid(provisional)[2][-1] / sonar.sound_speed
        far = 0.0
        for i in range(len(poses)):
            if leaves is not None and sonar.receivers is not None:
                for mask, r_tx, _, r_rx, _, _ in _heard(leaves, provisional, poses, i):
                    far = max(far, float(((r_tx + r_rx) / 2.0)[mask].max(initial=0.0)))
            elif leaves is not None:
                mask, r, _, _ = _counting(leaves, provisional, poses, i)
                far = max(far, float(r[mask].max(initial=0.0)))
            if branches is not None and sonar.receivers is not None:
                for pc in _pieces_heard(branches, provisional, poses, i, k_top):
                    far = max(far, float(((pc[1] + pc[2]) / 2.0).max(initial=0.0)))
            elif branches is not None:
                rp = _pieces(branches, provisional, poses, i, k_top)[2]
                far = max(far, float(rp.max(initial=0.0)))
        sonar = sonar.resolve(sonar.record_length_for(far))
    k0, k1, f, w = _grid(sonar)
    k_lo = 2.0 * np.pi * f[0] / sonar.sound_speed
    k_top = 2.0 * np.pi * f[-1] / sonar.sound_speed
    for name, parts in (("leaf", leaves), ("branch", branches)):
        if parts is not None and sonar.min_ka > 0:
            ka = k_lo * parts.radii
            if ka.min() < sonar.min_ka:
                raise ValueError(f"{name} {int(np.argmin(ka))} has k a = {ka.min():.4g} < min_ka")
    if sonar.receivers is not None:
        return _simulate_heard(leaves, branches, sonar, poses, k0, k1, f, w)
    spectra, wood, counts, n_pieces, n_shaded = _zeros((len(poses),), f, branches)
    for i in range(len(poses)):
        idx = np.zeros(0, dtype=np.int64)
        if leaves is not None:
            mask, r, e, G = _counting(leaves, sonar, poses, i)
            idx = np.flatnonzero(mask)
        pc = (np.zeros(0, dtype=np.int64), np.zeros((0, 3)), *([np.zeros(0)] * 6))
        if branches is not None:
            pc = _pieces(branches, sonar, poses, i, k_top)
        seg, ref, rp, Gp, lp, ap, cg, sg = pc
        fl, fp = _shading(leaves, branches, sonar, poses.positions[i], idx, seg, ref)
        counts[i], n_pieces[i] = idx.size, seg.size
        n_shaded[i] = int((fl != 1.0).sum())
        if idx.size:
            leaves = cast(Leaves, leaves)
            beta = _incidence(e[idx], leaves.normals[idx])
            spectra[i] = _spectrum(sonar, r[idx], G[idx] * fl, beta, leaves.radii[idx], f, w)
        if wood is not None:
            wood[i] = _wood_spectrum(sonar, rp, Gp, lp, ap, cg, sg, fp, f, w)
            spectra[i] += wood[i]
    return _echoes(sonar, poses, k0, k1, f, spectra, wood, counts, n_pieces, n_shaded)


def _simulate_heard(
    leaves: Leaves | None, branches: Branches | None, sonar: Sonar, poses: Poses, k0, k1, f, w
) -> Echoes:
    """Every receiver's echoes (docs/model.md §5a): the amplitude ``g S_tx S_rx L / (k r_tx
    r_rx)``, the phase ``-k (r_tx + r_rx) - psi``, absorption over ``r_tx + r_rx``, the
    incidence from the bisector; with branches, each receiver's pieces (§9); with shading,
    times tau^(m_out + m_back) (§10)."""
    n_rx = len(cast(tuple, sonar.receivers))
    spectra, wood, counts, n_pieces, n_shaded = _zeros((len(poses), n_rx), f, branches)
    rxs = cast(tuple, sonar.receivers)
    k_top = 2.0 * np.pi * f[-1] / sonar.sound_speed
    for i in range(len(poses)):
        heard = _heard(leaves, sonar, poses, i) if leaves is not None else [None] * n_rx
        pieces = _pieces_heard(branches, sonar, poses, i, k_top) if branches else [None] * n_rx
        for j, (hd, pc) in enumerate(zip(heard, pieces, strict=True)):
            idx = np.zeros(0, dtype=np.int64)
            if hd is not None:
                mask, r_tx, e_tx, r_rx, e_rx, G = hd
                idx = np.flatnonzero(mask)
                counts[i, j] = idx.size
            seg, ref = (pc[0], pc[9]) if pc is not None else (idx[:0], np.zeros((0, 3)))
            at = _receiver_position(poses, i, rxs[j].offset_m)
            fl, fp = _shading(leaves, branches, sonar, poses.positions[i], idx, seg, ref, at)
            n_shaded[i, j] = int((fl != 1.0).sum())
            if hd is not None and idx.size:
                G = G.copy()
                G[idx] = G[idx] * fl
                leaves = cast(Leaves, leaves)
                beta = _bisector_incidence(e_tx[idx], e_rx[idx], leaves.normals[idx])
                r = (r_tx[idx] + r_rx[idx]) / 2.0
                spread = r_tx[idx] * r_rx[idx]
                spectra[i, j] = _spectrum(
                    sonar, r, G[idx], beta, leaves.radii[idx], f, w, spread=spread
                )
            if wood is not None and pc is not None:
                _, pr_tx, pr_rx, pG, pl, pa, pcg, psg, pcb, _ = pc
                n_pieces[i, j] = pl.size
                wood[i, j] = _wood_spectrum(
                    sonar,
                    (pr_tx + pr_rx) / 2.0,
                    pG,
                    pl,
                    pa,
                    pcg,
                    psg,
                    fp,
                    f,
                    w,
                    bistatic=(pr_tx, pr_rx, pcb),
                )
                spectra[i, j] += wood[i, j]
    return _echoes(sonar, poses, k0, k1, f, spectra, wood, counts, n_pieces, n_shaded)


def _zeros(shape: tuple[int, ...], f: np.ndarray, branches: Branches | None):
    """Zeroed spectra (``shape`` + (M,)), wood spectra (None without branches), and counts of
    leaves, pieces and shaded leaves (``shape``), for poses (and receivers)."""
    spectra = np.zeros((*shape, len(f)), dtype=np.complex128)
    wood = np.zeros_like(spectra) if branches is not None else None
    counts, n_pieces, n_shaded = (np.zeros(shape, dtype=np.int64) for _ in range(3))
    return spectra, wood, counts, n_pieces, n_shaded


def _echoes(
    sonar: Sonar, poses: Poses, k0: int, k1: int, f, spectra, wood, counts, n_pieces, n_shaded
) -> Echoes:
    """The Echoes of the band spectra (p, [R,] M), each impulse response 2 irfft(Y, n) of the
    spectrum placed at bins k0..k1."""
    n = cast(int, sonar.n_samples)
    impulses = np.zeros((*spectra.shape[:-1], n))
    for at in np.ndindex(spectra.shape[:-1]):
        full = np.zeros(n // 2 + 1, dtype=np.complex128)
        full[k0 : k1 + 1] = spectra[at]
        impulses[at] = 2.0 * np.fft.irfft(full, n)
    return Echoes(
        spectrum=spectra,
        freqs=f,
        impulse=impulses,
        times=np.arange(n) / sonar.fs,
        n_leaves=counts,
        sonar=sonar,
        poses=poses,
        wood_spectrum=wood,
        n_pieces=n_pieces,
        n_shaded=n_shaded,
    )
