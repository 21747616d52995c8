#!/usr/bin/env python3
"""Hypothesis-driven fuzzer of the Python API: ``Leaves``, ``Poses``, ``Scene``, ``Sonar``,
``Beam``, ``Atmosphere``, ``simulate`` and ``lobe_members`` called with random arrays
(dtypes, shapes, byte orders, non-contiguous and read-only views, NaN, infinities, 1e308,
subnormals, -0.0) and random parameters (extreme, negative, huge integers, wrong types,
absurd sizes).

A call must either succeed or raise ValueError, TypeError or MemoryError with a message.
When it succeeds: the caller's arrays are unchanged, the outputs are finite, and what
``Leaves`` and ``Poses`` accept the core accepts (a Scene builds, a simulation runs). Any
other exception, a crash, an abort or a hang is a failure.

    python tools/fuzz/api_fuzz.py              # short seeded run (CI)
    python tools/fuzz/api_fuzz.py --long       # 1e5 examples
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from harness import run_campaign  # noqa: E402

#: The memory limit the children set (bytes): below their address-space limit, so that a
#: request the guard lets through still fits.
CHILD_LIMIT = 2**30

EXPECTED = (ValueError, TypeError, MemoryError)


def strategies():
    import numpy as np
    from hypothesis import strategies as st

    specials = st.sampled_from(
        [
            0.0,
            -0.0,
            1.0,
            -1.0,
            np.nan,
            np.inf,
            -np.inf,
            1e308,
            -1e308,
            5e-324,
            1e-160,
            1e160,
            1e-300,
            1e15,
            2.0**53,
        ]
    )
    plain = st.floats(-50.0, 50.0)
    reals = st.one_of(plain, plain, plain, plain, plain, plain, specials, st.floats())

    @st.composite
    def arrays(draw, cols=3, rows=None):
        n = draw(st.sampled_from([0, 1, 1, 2, 3, 5])) if rows is None else rows
        shape = draw(
            st.sampled_from([(n, cols), (n,), (cols,), (n, cols + 1), (n, cols, 1), ()])
            if draw(st.integers(0, 9)) == 0
            else st.just((n, cols) if cols else (n,))
        )
        size = int(np.prod(shape)) if shape else 1
        vals = draw(st.lists(reals, min_size=size, max_size=size))
        a = np.asarray(vals, dtype=np.float64).reshape(shape)
        kind = draw(st.integers(0, 12))
        if kind == 1:
            a = a.astype(">f8")
        elif kind == 2:
            a = a.astype(np.float32)
        elif kind == 3:
            with np.errstate(all="ignore"):
                a = np.nan_to_num(a).clip(-1e9, 1e9).astype(np.int64)
        elif kind == 4:
            a = a.astype(np.complex128)
        elif kind == 5:
            a = a.astype(object)
        elif kind == 6 and a.ndim:
            big = np.repeat(a, 2, axis=0)
            a = big[::2]  # not contiguous
        elif kind == 7:
            a.setflags(write=False)
        elif kind == 8:
            return a.tolist()
        elif kind == 9:
            return a.astype(bool)
        elif kind == 10:
            return np.asfortranarray(a)
        return a

    small_ints = st.integers(-3, 2**20)
    weird = st.one_of(
        st.none(),
        st.booleans(),
        st.text(max_size=3),
        small_ints,
        st.sampled_from([2**31, 2**31 + 1, 2**63, 2**64, -(2**63), 10**30, "auto"]),
        reals,
    )
    sonar_params = st.fixed_dictionaries(
        {},
        optional={
            "beamwidth_deg": st.one_of(
                st.floats(0.5, 179.0), st.floats(0.5, 179.0), st.floats(0.5, 179.0), weird
            ),
            "fs": st.one_of(st.sampled_from([100e3, 250e3, 400e3, 1e6, 1e9, 1e12]), weird),
            "n_samples": st.one_of(
                st.integers(2, 40000),
                st.just("auto"),
                st.sampled_from([2**22, 2**26, 2**31, 10**9]),
                weird,
            ),
            "band_hz": st.one_of(
                st.tuples(st.floats(1.0, 1e5), st.floats(1.0, 2e5)),
                weird,
                st.tuples(reals, reals),
            ),
            "sound_speed": st.one_of(
                st.floats(1e-3, 1e5), st.floats(1e-3, 1e5), st.floats(1e-3, 1e5), weird
            ),
            "lobe": st.sampled_from(["detectable", "cone", "x"]),
            "threshold_db": st.one_of(
                st.floats(-300.0, 300.0), st.floats(-300.0, 300.0), st.floats(-300.0, 300.0), weird
            ),
            "cone_half_angle_deg": st.one_of(
                st.floats(0.1, 179.9), st.floats(0.1, 179.9), st.floats(0.1, 179.9), weird
            ),
            "max_range_m": st.one_of(
                st.floats(1e-3, 1e300), st.floats(1e-3, 1e300), st.floats(1e-3, 1e300), weird
            ),
            "gain": st.one_of(
                st.floats(1e-10, 1e308), st.floats(1e-10, 1e308), st.floats(1e-10, 1e308), weird
            ),
            "leaf_model": st.sampled_from(["paper", "physical_optics"]),
            "spreading": st.booleans(),
            "window": st.sampled_from(["hann", "rect", "x"]),
            "min_range_m": st.one_of(
                st.floats(1e-9, 10.0), st.floats(1e-9, 10.0), st.floats(1e-9, 10.0), weird
            ),
            "too_close": st.sampled_from(["raise", "skip"]),
            "min_ka": st.one_of(
                st.floats(0.0, 10.0), st.floats(0.0, 10.0), st.floats(0.0, 10.0), weird
            ),
            "record_tail_s": st.one_of(
                st.floats(0.0, 1e7), st.floats(0.0, 1e7), st.floats(0.0, 1e7), weird
            ),
            "r0_m": st.one_of(
                st.floats(1e-6, 10.0), st.floats(1e-6, 10.0), st.floats(1e-6, 10.0), weird
            ),
            "p0_pa": st.one_of(
                st.floats(1e-6, 1e9), st.floats(1e-6, 1e9), st.floats(1e-6, 1e9), weird
            ),
        },
    )
    beam_params = st.fixed_dictionaries(
        {},
        optional={
            "sigma_deg": st.one_of(st.floats(1e-12, 200.0), weird, st.tuples(reals, reals)),
            "rotation_deg": st.one_of(reals, weird),
            "center_deg": st.one_of(st.tuples(reals, reals), weird),
            "amplitude": st.one_of(
                st.floats(1e-300, 1e300), st.floats(1e-300, 1e300), st.floats(1e-300, 1e300), weird
            ),
        },
    )
    atm_params = st.fixed_dictionaries(
        {},
        optional={
            "temperature_c": st.one_of(reals, weird),
            "relative_humidity": st.one_of(reals, weird),
            "pressure_pa": st.one_of(
                st.floats(1e-310, 1e310), st.floats(1e-310, 1e310), st.floats(1e-310, 1e310), weird
            ),
        },
    )
    return {
        "arrays": arrays,
        "sonar": sonar_params,
        "beam": beam_params,
        "atm": atm_params,
        "method": st.sampled_from(["exact", "fast", "auto", "x"]),
        "sonar_n": st.sampled_from([1000, 4000]),
        "tol": st.one_of(st.sampled_from([1e-12, 1e-6, 1e-3, 1e-14, 0.5]), weird),
        "what": st.integers(0, 6),
        "many": st.sampled_from([2, 100, 1_000, 100_000]),
    }


#: The last refusal's message (for --stats).
LAST_REFUSAL = [""]


class Bug(Exception):
    """An invariant broke (not an expected refusal)."""


def snapshot(x):
    import numpy as np

    if isinstance(x, np.ndarray):
        return (x.dtype.str, x.shape, x.tobytes() if x.dtype != object else repr(x.tolist()))
    return repr(x)


def finite_echoes(e) -> None:
    import numpy as np

    if not (np.isfinite(e.spectrum).all() and np.isfinite(e.impulse).all()):
        raise Bug("simulate returned non-finite echoes")
    if e.impulse.shape != (len(e.poses), int(e.sonar.n_samples)):
        raise Bug(f"impulse shape {e.impulse.shape} is not (poses, n_samples)")


def one_example(data, s) -> str:
    """One random API call; returns "ok" or "refused"; raises Bug on a broken invariant."""
    import warnings

    import numpy as np

    import batecho
    from batecho import Atmosphere, Beam, Leaves, Poses, Scene, Sonar

    what = data.draw(s["what"])
    leaves0 = Leaves(
        [[2.0, 0.0, 0.0], [3.0, 0.5, 0.2]], [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], [0.02, 0.03]
    )
    pose0 = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    args: list = []
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if what == 0:  # Leaves, then the core
                c, n, r = (
                    data.draw(s["arrays"]()),
                    data.draw(s["arrays"]()),
                    data.draw(s["arrays"](cols=0)),
                )
                args = [c, n, r]
                before = [snapshot(a) for a in args]
                lv = Leaves(c, n, r)
                if [snapshot(a) for a in args] != before:
                    raise Bug("Leaves changed the caller's arrays")
                sc = Scene(lv)  # what Leaves accepts the core accepts
                e = batecho.simulate(sc, Sonar(too_close="skip", min_ka=0.0, n_samples=4000), pose0)
                finite_echoes(e)
            elif what == 1:  # Poses, then the core
                p, f, u = (data.draw(s["arrays"]()) for _ in range(3))
                args = [p, f, u]
                before = [snapshot(a) for a in args]
                ps = Poses(p, f, u)
                if [snapshot(a) for a in args] != before:
                    raise Bug("Poses changed the caller's arrays")
                e = batecho.simulate(leaves0, Sonar(too_close="skip", n_samples=4000), ps)
                finite_echoes(e)
            elif what == 2:  # Sonar, then a simulation
                kw = data.draw(s["sonar"])
                so = Sonar(**kw)
                e = batecho.simulate(
                    leaves0,
                    so.replace(too_close="skip"),
                    pose0,
                    method=data.draw(s["method"]),
                    tol=data.draw(s["tol"]),
                )
                finite_echoes(e)
            elif what == 3:  # Beam: its gain, and a sonar with it
                b = Beam(**data.draw(s["beam"]))
                g = b.gain(np.array([0.0, 0.1, -3.0]), np.array([0.0, 0.2, 1.5]))
                if not np.isfinite(g).all():
                    raise Bug(f"Beam.gain is not finite: {g}")
                so = Sonar(beam=b, too_close="skip", n_samples=4000)
                e = batecho.simulate(leaves0, so, pose0)
                finite_echoes(e)
            elif what == 4:  # Atmosphere, its absorption, and a sonar with it
                a = Atmosphere(**data.draw(s["atm"]))
                al = a.alpha_db_per_m(np.array([1e3, 7e4, 2e5]))
                if not np.isfinite(al).all():
                    raise Bug(f"absorption is not finite: {al}")
                so = Sonar(absorption=a, too_close="skip", n_samples=4000)
                e = batecho.simulate(leaves0, so, pose0)
                finite_echoes(e)
            elif what == 6:  # many poses at once: simulated, or refused for memory
                p = data.draw(s["many"])
                ps = Poses(np.zeros((p, 3)), [1.0, 0.0, 0.0])
                e = batecho.simulate(leaves0, Sonar(n_samples=data.draw(s["sonar_n"])), ps)
                finite_echoes(e)
            else:  # odd pose arrays, lobe members
                k = data.draw(s["arrays"](rows=None))
                args = [k]
                before = [snapshot(k)]
                ps = Poses(k, [1.0, 0.0, 0.0])
                idx = batecho.lobe_members(leaves0, Sonar(too_close="skip", n_samples=4000), ps[0])
                if [snapshot(k)] != before:
                    raise Bug("Poses changed the caller's array")
                if not (idx.dtype == np.int64 and (np.diff(idx) > 0).all()):
                    raise Bug("lobe_members is not ascending int64")
    except Bug:
        raise
    except EXPECTED as exc:
        msg = str(exc)
        if not msg.strip() or "panicked" in msg:
            raise Bug(f"{type(exc).__name__} without a clear message: {msg!r}") from None
        if [snapshot(a) for a in args] != before if args else False:
            raise Bug("a refused call changed the caller's arrays") from None
        LAST_REFUSAL[0] = f"{type(exc).__name__}: {msg}"
        return "refused"
    return "ok"


def child() -> None:
    from hypothesis import HealthCheck, given, seed, settings
    from hypothesis import strategies as st

    import batecho

    batecho.set_memory_limit(CHILD_LIMIT)
    payload = json.loads(sys.stdin.read())
    cases = payload["cases"]
    s = strategies()
    state = {"k": 0}

    @seed(payload["seed"] * 1_000_003 + cases[0])
    @settings(
        max_examples=len(cases),
        deadline=None,
        database=None,
        derandomize=False,
        suppress_health_check=list(HealthCheck),
        phases=["generate"],
    )
    @given(st.data())
    def examples(data):
        try:
            r = one_example(data, s)
        except Bug as exc:
            r = f"BUG: {exc}"
        except Exception as exc:  # anything but the expected refusals
            r = f"BUG: {type(exc).__name__}: {str(exc)[:300]}"
        if state["k"] < len(cases):  # (a replay of an example is not counted again)
            print(json.dumps({"i": cases[state["k"]], "r": r}), flush=True)
            state["k"] += 1

    examples()
    # (hypothesis may run fewer examples than asked; the rest count as run, with no result)
    for i in cases[state["k"] :]:
        print(json.dumps({"i": i, "r": "skipped"}), flush=True)


def stats(n: int, seed_: int) -> None:
    """Run ``n`` examples in this process and print the commonest refusals (to see what the
    fuzzer reaches)."""
    import collections
    import re

    from hypothesis import HealthCheck, given, seed, settings
    from hypothesis import strategies as st

    import batecho

    batecho.set_memory_limit(CHILD_LIMIT)
    s = strategies()
    seen: collections.Counter[str] = collections.Counter()

    @seed(seed_)
    @settings(
        max_examples=n,
        deadline=None,
        database=None,
        suppress_health_check=list(HealthCheck),
        phases=["generate"],
    )
    @given(st.data())
    def examples(data):
        r = one_example(data, s)
        key = re.sub(r"[-+]?[0-9][0-9.e+-]*|\[.*?\]|'.*?'", "#", LAST_REFUSAL[0])[:90]
        seen[r if r != "refused" else key] += 1

    examples()
    for msg, k in seen.most_common(40):
        print(f"{k:6d}  {msg}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--long", action="store_true", help="1e5 examples")
    ap.add_argument("-n", type=int, help="number of examples")
    ap.add_argument("--seed", type=int, default=36)
    ap.add_argument("--budget-s", type=float, help="stop after this many seconds")
    ap.add_argument("--stats", action="store_true", help="the commonest refusals, in-process")
    args = ap.parse_args(argv)
    if args.child:
        child()
        return 0
    if args.stats:
        stats(args.n or 1000, args.seed)
        return 0
    n = args.n or (100_000 if args.long else 1500)
    return run_campaign(
        Path(__file__),
        "api fuzz",
        n,
        batch_size=500,
        timeout_s=600.0,
        seed=args.seed,
        budget_s=args.budget_s,
    )


if __name__ == "__main__":
    sys.exit(main())
