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


def run_batch(
    script: Path,
    cases: list,
    timeout_s: float,
    memory_bytes: int = DEFAULT_MEMORY_BYTES,
) -> tuple[list[dict], Outcome]:
    """Run ``script`` as a child that reads a JSON list of cases on stdin and prints one JSON
    line per case it finished. Returns the finished cases' records and the child's outcome;
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
