"""Running a call in a child process with a time limit and an address-space limit (the
fuzzers' harness, tools/fuzz/harness.py), so that a test of a crash, an abort, a hang or a
runaway allocation can fail without taking the test run down with it."""

from __future__ import annotations

import json
import sys
import textwrap
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools" / "fuzz"))
import harness
from harness import Outcome, run_argv, run_code

__all__ = ["Outcome", "call_in_child", "harness", "run_argv", "run_code"]

_WRAP = """
import json, time
{setup}
def attempt():
{body}
t0 = time.perf_counter()
try:
    attempt()
    out = {{"raised": None}}
except BaseException as exc:
    out = {{"raised": type(exc).__name__, "message": str(exc)}}
out["elapsed_s"] = time.perf_counter() - t0
print("RESULT " + json.dumps(out), flush=True)
"""


def call_in_child(
    body: str, setup: str = "import batecho", timeout_s: float = 120.0, memory_gb: float = 3.0
) -> dict:
    """Run ``body`` (the statements of a function) in a child after ``setup``; returns
    ``{"raised": exception name or None, "message": ..., "elapsed_s": the call's time}``.
    Fails (AssertionError) when the child crashes, aborts, hangs or prints no result."""
    code = _WRAP.format(
        setup=textwrap.dedent(setup), body=textwrap.indent(textwrap.dedent(body), "    ")
    )
    oc = run_code(code, timeout_s=timeout_s, memory_bytes=int(memory_gb * 2**30))
    assert oc.kind == "ok", f"the child ended with {oc.kind} ({oc.returncode}): {oc.stderr[-2000:]}"
    lines = [ln for ln in oc.stdout.splitlines() if ln.startswith("RESULT ")]
    assert lines, f"no result from the child: {oc.stdout[-500:]} {oc.stderr[-1000:]}"
    return json.loads(lines[-1][len("RESULT ") :])
