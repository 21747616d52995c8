"""The echo envelope straight from the band spectrum: the magnitude of the analytic signal of
the impulse response (docs/model.md §5) at every ``stride``-th sample, by one inverse FFT of
``n_samples / stride`` points, without the impulse response or a Hilbert transform."""

from __future__ import annotations

import numpy as np

__all__ = ["band_envelope", "envelope_stride"]


def envelope_stride(n_samples: int, fs: float, band_hz: tuple[float, float], oversampling: float):
    """The largest divisor ``s`` of ``n_samples`` with ``s <= fs / (oversampling * B)``
    (``B = f_hi - f_lo``; at least 1): a sampling of the envelope, whose spectrum spans ``B``,
    ``oversampling`` times finer than its Nyquist rate."""
    limit = fs / (oversampling * (band_hz[1] - band_hz[0]))
    return max(s for s in range(1, int(max(1.0, limit)) + 1) if n_samples % s == 0)


def band_envelope(spectrum: np.ndarray, k0: int, n_samples: int, stride: int) -> np.ndarray:
    """(..., n_samples / stride) the envelope ``|analytic signal|`` of the impulse response
    ``y = 2 irfft(Y, n)`` at samples ``0, stride, 2 stride, ...``, where ``spectrum`` (..., M)
    holds ``Y`` at the band bins ``k0 .. k0 + M - 1`` (below Nyquist, above 0).

    The analytic signal of ``y`` is ``(4 / n) sum_k Y_k exp(2 pi i k t / n)`` (only band bins
    are non-zero); at ``t = stride j`` the phase is ``2 pi i k j / n'`` with
    ``n' = n / stride``, so it is ``(4 n' / n) ifft_{n'}(Z)[j]`` with ``Z[k mod n'] += Y_k``:
    exact at those samples (the bins fold onto distinct or summed slots of ``Z``).
    """
    if stride < 1 or n_samples % stride:
        raise ValueError(f"stride must divide n_samples = {n_samples}, got {stride}")
    m = spectrum.shape[-1]
    n_out = n_samples // stride
    z = np.zeros((*spectrum.shape[:-1], n_out), dtype=np.complex128)
    slots = (k0 + np.arange(m)) % n_out
    if m <= n_out:
        z[..., slots] = spectrum
    else:
        for j in range(m):
            z[..., slots[j]] += spectrum[..., j]
    return (4.0 * n_out / n_samples) * np.abs(np.fft.ifft(z, axis=-1))
