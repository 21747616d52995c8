"""Datasets under faults: one generate per store (a lock), workers that end with a killed
run, verify that checks the coordinates and names the damaged array and chunk in one line,
and a resume that re-checks the chunks it would skip."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

zarr = pytest.importorskip("zarr")

from _isolated import run_argv  # noqa: E402
from test_dataset import tiny_spec  # noqa: E402

from batecho.dataset import DatasetError, generate, verify  # noqa: E402
from batecho.dataset.guard import StoreLock, StoreLockedError  # noqa: E402


@pytest.fixture(scope="module")
def made(tmp_path_factory) -> tuple[Path, object]:
    """A complete tiny store (4 samples in 2 chunks) and its spec."""
    spec = tiny_spec(n_samples=4, pulses_per_sample=2, **{"output.chunk_size": 2})
    store = tmp_path_factory.mktemp("made") / "store.zarr"
    generate(spec, store, workers=1, progress=False)
    return store, spec


def copy_of(made, tmp_path: Path) -> Path:
    import shutil

    dst = tmp_path / "copy.zarr"
    shutil.copytree(made[0], dst)
    return dst


def flip_byte(path: Path, at: int = -1) -> None:
    data = bytearray(path.read_bytes())
    data[at] ^= 0x10
    path.write_bytes(bytes(data))


def test_a_second_generate_on_a_store_being_written_is_refused_naming_the_holder(tmp_path):
    store = tmp_path / "s.zarr"
    with StoreLock(store):
        with pytest.raises(StoreLockedError, match=rf"being written .*pid {os.getpid()}"):
            generate(tiny_spec(n_samples=2), store, workers=1, progress=False)
    assert not store.exists()  # the refused run wrote nothing


def test_two_generates_started_together_leave_one_whole_store(tmp_path):
    spec_path = tmp_path / "spec.toml"
    spec_path.write_text(tiny_spec(n_samples=8, pulses_per_sample=2).to_toml())
    store = tmp_path / "s.zarr"
    argv = [sys.executable, "-m", "batecho", "dataset", "generate", str(spec_path), str(store)]
    runs = [subprocess.Popen(argv + ["--quiet"], stderr=subprocess.PIPE, text=True)]
    time.sleep(0.1)
    runs.append(subprocess.Popen(argv + ["--quiet"], stderr=subprocess.PIPE, text=True))
    ends = [(r.wait(timeout=300), r.stderr.read()) for r in runs]
    for rc, err in ends:
        assert rc == 0 or (rc == 2 and "being written by another" in err), (rc, err)
    verify(store)


def _session_alive(sid: int) -> list[int]:
    alive = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:
                continue
            fields = stat[stat.rindex(")") + 2 :].split()
            if fields[0] != "Z" and int(fields[3]) == sid:
                alive.append(int(d.name))
    return alive


def test_the_workers_of_a_killed_run_end_with_it(tmp_path):
    spec_path = tmp_path / "spec.toml"
    spec_path.write_text(tiny_spec(n_samples=40, pulses_per_sample=2).to_toml())
    argv = [sys.executable, "-m", "batecho", "dataset", "generate", str(spec_path),
            str(tmp_path / "s.zarr"), "--workers", "2", "--quiet"]  # fmt: skip
    run = subprocess.Popen(argv, start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while len(_session_alive(run.pid)) < 3 and time.monotonic() < deadline:
            time.sleep(0.05)  # until the workers are up
        assert len(_session_alive(run.pid)) >= 3, "the workers never started"
        run.send_signal(signal.SIGKILL)  # the run only, not its group
        run.wait()
        deadline = time.monotonic() + 15
        while _session_alive(run.pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert _session_alive(run.pid) == []
    finally:
        for pid in _session_alive(run.pid):
            os.kill(pid, signal.SIGKILL)


@pytest.mark.parametrize("coord", ["freq", "time", "range", "sample", "pulse", "chunk"])
@pytest.mark.parametrize("damage", ["flip", "truncate", "delete"])
def test_verify_refuses_a_store_with_a_damaged_coordinate_naming_it(made, tmp_path, coord, damage):
    store = copy_of(made, tmp_path)
    chunk = store / coord / "c" / "0"
    if damage == "flip":
        flip_byte(chunk, len(chunk.read_bytes()) // 2)
    elif damage == "truncate":
        chunk.write_bytes(chunk.read_bytes()[:3])
    else:
        chunk.unlink()
    with pytest.raises(DatasetError, match=rf"coordinate '{coord}'"):
        verify(store)


def test_a_damaged_compressed_chunk_is_named_by_array_and_chunk(made, tmp_path):
    store = copy_of(made, tmp_path)
    chunk = store / "impulse" / "c" / "1" / "0" / "0"
    chunk.write_bytes(b"\x28\xb5\x2f\xfd" + b"\x00" * 40)  # a zstd header, then nonsense
    with pytest.raises(DatasetError, match=r"chunk 1: array 'impulse' cannot be read"):
        verify(store)


def test_a_truncated_array_metadata_file_gives_one_line_and_no_traceback(made, tmp_path):
    store = copy_of(made, tmp_path)
    meta = store / "n_leaves" / "zarr.json"
    meta.write_bytes(meta.read_bytes()[:100])
    oc = run_argv([sys.executable, "-m", "batecho", "dataset", "verify", str(store)], 120)
    assert oc.returncode == 1 and oc.kind == "exit", oc.stderr
    assert len(oc.stderr.strip().splitlines()) == 1, oc.stderr
    assert "array 'n_leaves' has unreadable metadata" in oc.stderr


def test_a_resume_recomputes_a_chunk_marked_complete_but_damaged(made, tmp_path):
    store = copy_of(made, tmp_path)
    before = np.asarray(zarr.open_group(str(made[0]), mode="r")["position"][...])
    chunk = store / "position" / "c" / "1" / "0" / "0"
    flip_byte(chunk, len(chunk.read_bytes()) // 2)
    with pytest.raises(DatasetError):
        verify(store)
    with pytest.warns(UserWarning, match="chunk 1 was marked complete but is damaged"):
        report = generate(made[1], store, workers=1, progress=False)
    assert report.chunks_computed == 1
    verify(store)
    after = np.asarray(zarr.open_group(str(store), mode="r")["position"][...])
    assert after.tobytes() == before.tobytes()


def test_the_command_line_tells_of_a_damaged_chunk_in_one_line(made, tmp_path, capsys):
    from batecho.cli import main

    store = copy_of(made, tmp_path)
    chunk = store / "position" / "c" / "1" / "0" / "0"
    flip_byte(chunk, len(chunk.read_bytes()) // 2)
    spec = tmp_path / "spec.toml"
    spec.write_text(made[1].to_toml(), encoding="utf-8")
    assert main(["dataset", "generate", str(spec), str(store), "--workers", "1", "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "batecho dataset: warning: " in err and "chunk 1 was marked complete" in err
    assert "UserWarning" not in err and "open_for_generate" not in err


@pytest.mark.parametrize("command", ["verify", "show"])
def test_a_toml_spec_given_for_a_store_is_named_as_a_spec_not_as_missing(tmp_path, capsys, command):
    from batecho.cli import main

    spec = Path(__file__).parents[1] / "examples" / "dataset-small.toml"
    assert main(["dataset", command, str(spec)]) != 0
    err = capsys.readouterr().err
    assert f"{spec} is a TOML spec, not a dataset: this expects a zarr store" in err
    assert "does not exist" not in err


@pytest.mark.parametrize("command", ["verify", "show"])
def test_a_folder_given_for_a_store_is_named_as_not_a_store_not_as_missing(
    tmp_path, capsys, command
):
    from batecho.cli import main

    (tmp_path / "notes.txt").write_text("not a dataset")
    assert main(["dataset", command, str(tmp_path)]) != 0
    err = capsys.readouterr().err
    assert f"{tmp_path} is a folder but not a zarr store" in err
    assert "does not exist" not in err


def test_a_users_file_where_the_lock_goes_is_refused_and_left_as_it_was(tmp_path):
    from batecho.dataset.guard import StoreLock

    own = tmp_path / "out.zarr.lock"
    own.write_text("my notes\n")
    with pytest.raises(ValueError, match="not a lock"):
        with StoreLock(tmp_path / "out.zarr"):
            pass
    assert own.read_text() == "my notes\n"


def test_a_users_folder_where_the_partial_store_goes_is_refused_and_left_as_it_was(tmp_path):
    spec = tiny_spec(n_samples=2, pulses_per_sample=1, **{"output.chunk_size": 2})
    own = tmp_path / "out.zarr.partial"
    own.mkdir()
    (own / "notes.txt").write_text("my notes\n")
    with pytest.raises(DatasetError, match="out.zarr.partial"):
        generate(spec, tmp_path / "out.zarr", workers=1, progress=False)
    assert (own / "notes.txt").read_text() == "my notes\n"
    assert not (tmp_path / "out.zarr").exists()


def test_a_partial_store_left_by_a_killed_run_is_cleared_and_the_store_made(tmp_path):
    from batecho.dataset.store import _lay_out

    spec = tiny_spec(n_samples=2, pulses_per_sample=1, **{"output.chunk_size": 2})
    _lay_out(tmp_path / "out.zarr.partial", spec, False)
    generate(spec, tmp_path / "out.zarr", workers=1, progress=False)
    assert verify(tmp_path / "out.zarr").n_chunks == 1
    assert not (tmp_path / "out.zarr.partial").exists()


@pytest.mark.parametrize("with_root", [True, False])
def test_a_partial_store_killed_in_a_metadata_write_is_cleared_and_the_store_made(
    tmp_path, with_root
):
    # zarr writes each file through a temporary `<stem>.<32 hex>.partial` beside it; a kill in
    # that write leaves the temporary, with or without the root's zarr.json
    from batecho.dataset.store import _lay_out

    spec = tiny_spec(n_samples=2, pulses_per_sample=1, **{"output.chunk_size": 2})
    partial = tmp_path / "out.zarr.partial"
    if with_root:
        _lay_out(partial, spec, False)
    else:
        partial.mkdir()
    (partial / "zarr.0123456789abcdef0123456789abcdef.partial").write_text("{")
    generate(spec, tmp_path / "out.zarr", workers=1, progress=False)
    assert verify(tmp_path / "out.zarr").n_chunks == 1
    assert not partial.exists()


def test_a_partial_folder_holding_a_users_file_named_like_a_zarr_temporary_is_refused(tmp_path):
    spec = tiny_spec(n_samples=2, pulses_per_sample=1, **{"output.chunk_size": 2})
    own = tmp_path / "out.zarr.partial"
    own.mkdir()
    (own / "notes.partial").write_text("my notes\n")
    with pytest.raises(DatasetError, match="out.zarr.partial"):
        generate(spec, tmp_path / "out.zarr", workers=1, progress=False)
    assert (own / "notes.partial").read_text() == "my notes\n"


def test_a_local_run_counts_each_chunk_on_the_progress_bar_as_it_completes(monkeypatch):
    import threading
    from concurrent.futures import ThreadPoolExecutor

    from batecho.dataset import pipeline

    spec = tiny_spec(n_samples=4, pulses_per_sample=2, **{"output.chunk_size": 2})
    counted = threading.Event()
    seen_before_last: list[bool] = []

    def run_chunk(store, text, k):  # chunk 1 ends only once chunk 0 is counted (or in 5 s)
        if k == 1:
            seen_before_last.append(counted.wait(timeout=5))
        return k, 1, 0.0

    class Bar:
        def update(self, n):
            counted.set()

    monkeypatch.setattr(pipeline, "_run_chunk", run_chunk)
    monkeypatch.setattr(
        pipeline, "ProcessPoolExecutor", lambda max_workers, **kw: ThreadPoolExecutor(max_workers)
    )
    pipeline._run_local("store", spec.to_toml(), [0, 1], 2, Bar(), spec)
    assert seen_before_last == [True]


def test_sigterm_stops_a_run_as_ctrl_c_does_with_its_message_and_status_143(tmp_path):
    spec_path = tmp_path / "spec.toml"
    spec_path.write_text(tiny_spec(n_samples=400, pulses_per_sample=2).to_toml())
    store = tmp_path / "s.zarr"
    argv = [sys.executable, "-m", "batecho", "dataset", "generate", str(spec_path), str(store),
            "--workers", "2", "--quiet"]  # fmt: skip
    run = subprocess.Popen(argv, start_new_session=True, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while not any(store.glob("chunk_checksum/c/*")) and time.monotonic() < deadline:
            time.sleep(0.05)  # until the workers have written a chunk
        run.send_signal(signal.SIGTERM)
        rc, err = run.wait(timeout=60), run.stderr.read()
    finally:
        for pid in _session_alive(run.pid):
            os.kill(pid, signal.SIGKILL)
    assert rc == 143
    assert (
        "batecho dataset generate: interrupted; complete chunks are kept, run the same "
        "command again to finish"
    ) in err.splitlines()
