"""The fuzzers' harness (tools/fuzz/harness.py) tells a crash, an abort, a hang and a
runaway allocation from a clean refusal, names the case a child died on, and goes on with
the cases after it: a fuzz run can fail."""

from __future__ import annotations

import textwrap

from _isolated import harness, run_argv, run_code


def test_an_abort_is_a_crash():
    assert run_code("import os; os.abort()", timeout_s=30).kind == "crash"


def test_a_rust_style_panic_message_is_a_crash_even_with_status_one():
    oc = run_code("import sys; sys.stderr.write('thread panicked at x\\n'); sys.exit(1)")
    assert oc.kind == "crash"


def test_an_endless_loop_is_a_hang_and_is_killed():
    oc = run_code("while True: pass", timeout_s=2)
    assert oc.kind == "hang" and oc.returncode is None


def test_a_runaway_allocation_fails_in_the_child_only():
    oc = run_code("x = bytearray(8 * 2**30)", timeout_s=30, memory_bytes=2**30)
    assert oc.kind == "error" and "MemoryError" in oc.last_line


def test_a_python_exception_is_an_error_and_success_is_ok():
    assert run_code("raise ValueError('no')").kind == "error"
    assert run_argv(["true"]).kind == "ok"


def test_a_campaign_names_the_case_its_child_died_on_and_goes_on(tmp_path, capsys):
    script = tmp_path / "fake_fuzz.py"
    script.write_text(
        textwrap.dedent(
            f"""
            import os, sys
            sys.path.insert(0, {str(harness.Path(harness.__file__).parent)!r})
            from harness import child_main
            def run_case(seed, i, payload):
                if i == 3:
                    os.abort()
                return "BUG: odd" if i == 7 else "fine"
            child_main(run_case)
            """
        )
    )
    status = harness.run_campaign(script, "fake", 10, batch_size=4, timeout_s=30, seed=1)
    out = capsys.readouterr().out
    assert status == 1
    assert "case 3: the child ended with crash" in out
    assert "case 7: BUG: odd" in out
    assert "fake: 9 inputs" in out  # every case but the one it died on
