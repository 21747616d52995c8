"""Running untrusted work in child processes: a time limit, an address-space limit, and the
outcome classified (ok, a Python exception, a crash by signal, an abort, a hang).

The fuzzers run their inputs in batches through :func:`run_batch` (one child per batch, a
fresh one after any crash), and the regression tests run single snippets through
:func:`run_code`, so that a runaway allocation or an endless loop costs a child, never the
caller or the machine.
"""

from __future__ import annotations

import json
import os
import resource
import signal
import subprocess
import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path

#: Address-space limit of a child unless told otherwise (bytes): enough for NumPy, SciPy and
#: the extension, far below the machine's memory.
DEFAULT_MEMORY_BYTES = 3 * 2**30


def _limit(memory_bytes: int):
    def apply() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (memory_bytes, memory_bytes))
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
        os.setsid()  # a group of its own, so that a hang is killed with its children

    return apply


@dataclass
class Outcome:
    """What a child did: ``kind`` is "ok", "error" (it printed a Python exception and exited
    1), "crash" (killed by a signal, SIGABRT included), "hang" (over its time limit) or
    "exit" (another exit status)."""

    kind: str
    returncode: int | None
    stdout: str
    stderr: str

    @property
    def last_line(self) -> str:
        lines = [ln for ln in self.stderr.strip().splitlines() if ln.strip()]
        return lines[-1] if lines else ""


def run_code(
    code: str,
    timeout_s: float = 30.0,
    memory_bytes: int = DEFAULT_MEMORY_BYTES,
    env: dict[str, str] | None = None,
    cwd: str | Path | None = None,
) -> Outcome:
    """Run ``code`` with ``python -c`` in a child with the limits; classify its end."""
    return run_argv(
        [sys.executable, "-c", textwrap.dedent(code)], timeout_s, memory_bytes, env, cwd
    )


def run_argv(
    argv: list[str],
    timeout_s: float = 30.0,
    memory_bytes: int = DEFAULT_MEMORY_BYTES,
    env: dict[str, str] | None = None,
    cwd: str | Path | None = None,
    stdin: str | None = None,
) -> Outcome:
    """Run ``argv`` in a child with the limits; classify its end."""
    full_env = dict(os.environ)
    full_env.setdefault("RAYON_NUM_THREADS", "2")
    full_env.update(env or {})
    proc = subprocess.Popen(
        argv,
        stdin=subprocess.PIPE if stdin is not None else subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=full_env,
        cwd=cwd,
        preexec_fn=_limit(memory_bytes),
    )
    try:
        out, err = proc.communicate(stdin, timeout=timeout_s)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        return Outcome("hang", None, out, err)
    rc = proc.returncode
    if rc == 0:
        kind = "ok"
    elif rc < 0:
        kind = "crash"
    elif rc == 1 and "Traceback" in err:
        kind = "error"
    else:
        kind = "exit"
    if "panicked" in err or "memory allocation of" in err:
        kind = "crash"
    return Outcome(kind, rc, out, err)


def run_campaign(
    script: Path,
    label: str,
    n_cases: int,
    batch_size: int,
    timeout_s: float,
    seed: int,
    memory_bytes: int = DEFAULT_MEMORY_BYTES,
    budget_s: float | None = None,
    options: dict | None = None,
) -> int:
    """Run cases ``0 .. n_cases-1`` of ``script`` (each derived in the child from ``seed``
    and its index) in batches of children; stop early after ``budget_s`` seconds. A record
    whose result starts with ``"BUG"`` is a failure, and so is a child that crashes, aborts
    or hangs (the case it was on is named). Prints the counts; returns the exit status."""
    import collections
    import time

    t0 = time.perf_counter()
    counts: collections.Counter[str] = collections.Counter()
    failures: list[str] = []
    i = 0
    while i < n_cases and (budget_s is None or time.perf_counter() - t0 < budget_s):
        cases = list(range(i, min(n_cases, i + batch_size)))
        payload = {"seed": seed, "cases": cases, **(options or {})}
        done, oc = run_batch(script, payload, timeout_s, memory_bytes)
        for rec in done:
            r = str(rec.get("r", "?"))
            counts[r.split(":", 1)[0] if r.startswith("BUG") else r] += 1
            if r.startswith("BUG"):
                failures.append(f"case {rec.get('i')}: {r}")
        if len(done) == len(cases) and oc.kind == "ok":
            i += len(cases)
            continue
        culprit = cases[len(done)] if len(done) < len(cases) else cases[-1]
        counts[oc.kind] += 1
        failures.append(
            f"case {culprit}: the child ended with {oc.kind} (status {oc.returncode}): "
            f"{oc.last_line[:300]}"
        )
        i = culprit + 1
    elapsed = time.perf_counter() - t0
    total = sum(v for k, v in counts.items() if k not in ("crash", "hang", "exit", "error"))
    for f in failures[:30]:
        print(f"FAIL {label} (seed {seed}) {f}")
    if failures:
        print(f"  reproduce one case: python {script} --seed {seed} --case N --show")
    shown = ", ".join(f"{k} {v}" for k, v in sorted(counts.items()))
    print(f"{label}: {total} inputs in {elapsed:.0f} s ({shown}); {len(failures)} failures")
    return 1 if failures else 0


def child_main(run_case, argv: list[str] | None = None) -> None:
    """The child side of a batch: read the payload (JSON on stdin), run each case through
    ``run_case(seed, i, payload) -> str`` and print one JSON line per finished case."""
    payload = json.loads(sys.stdin.read())
    for i in payload["cases"]:
        r = run_case(payload["seed"], i, payload)
        print(json.dumps({"i": i, "r": r}), flush=True)


def run_batch(
    script: Path,
    cases: dict,
    timeout_s: float,
    memory_bytes: int = DEFAULT_MEMORY_BYTES,
) -> tuple[list[dict], Outcome]:
    """Run ``script`` as a child that reads a JSON payload of cases on stdin and prints one
    JSON line per case it finished. Returns the finished cases' records and the child's outcome;
    when the child dies or hangs, the case after the last finished one is the culprit."""
    oc = run_argv(
        [sys.executable, str(script), "--child"],
        timeout_s,
        memory_bytes,
        stdin=json.dumps(cases),
    )
    done = []
    for line in oc.stdout.splitlines():
        if line.startswith("{"):
            try:
                done.append(json.loads(line))
            except json.JSONDecodeError:
                break
    return done, oc
