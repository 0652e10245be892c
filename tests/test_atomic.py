"""Outputs written whole or not at all (nnmstop.atomic): folders swapped in whole, and the temporary file of a
writer killed with SIGKILL removed by the next build while a live writer's is kept (issue 33.7)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest

from nnmstop.atomic import atomic_folder, atomic_output, remove_stale_temporaries, set_commit_guard, temporary_name

WRITER = """
import sys, time
from pathlib import Path
from nnmstop.atomic import atomic_output
with atomic_output(Path(sys.argv[1])) as tmp:
    tmp.write_bytes(b"partial" * 1000)
    print("writing", flush=True)
    time.sleep(600)
"""


def test_a_killed_writer_leaves_a_temporary_the_next_build_removes_and_a_live_one_is_kept(tmp_path):
    target = tmp_path / "results" / "hbm" / "nnm1.nc"
    writer = subprocess.Popen([sys.executable, "-c", WRITER, str(target)], stdout=subprocess.PIPE, text=True)
    try:
        assert writer.stdout.readline().strip() == "writing"
        partial = temporary_name(target)
        assert partial.is_file()
        assert remove_stale_temporaries([tmp_path / "results"]) == []  # its writer lives: a concurrent build
        assert partial.is_file()
        os.kill(writer.pid, signal.SIGKILL)  # no handler runs: the temporary stays
        writer.wait(timeout=30)
        assert partial.is_file() and not target.exists()
        assert remove_stale_temporaries([tmp_path / "results", tmp_path / "nowhere"]) == [partial]
        assert not partial.exists() and not target.exists()
    finally:
        if writer.poll() is None:
            writer.kill()
            writer.wait()


def test_a_folder_is_replaced_whole_or_left_as_it_was(tmp_path):
    folder = tmp_path / "reference"
    folder.mkdir()
    (folder / "old.csv").write_text("old")
    with pytest.raises(RuntimeError, match="interrupted"):
        with atomic_folder(folder) as new:
            (new / "half.csv").write_text("half")
            raise RuntimeError("interrupted")
    assert sorted(p.name for p in folder.iterdir()) == ["old.csv"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["reference"]
    with atomic_folder(folder) as new:
        (new / "new.csv").write_text("new")
    assert sorted(p.name for p in folder.iterdir()) == ["new.csv"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["reference"]


def test_the_commit_guard_refuses_files_and_folders(tmp_path):
    def guard(path):
        raise RuntimeError(f"job ended: {path} not written")

    previous = set_commit_guard(guard)
    try:
        with pytest.raises(RuntimeError, match="page.html not written"):
            with atomic_output(tmp_path / "page.html") as tmp:
                tmp.write_text("<html>")
        with pytest.raises(RuntimeError, match="reference not written"):
            with atomic_folder(tmp_path / "reference") as new:
                (new / "files.json").write_text("{}")
    finally:
        set_commit_guard(previous)
    assert list(tmp_path.iterdir()) == []


def test_a_stale_folder_of_a_killed_reference_update_is_removed(tmp_path):
    stale = tmp_path / ".reference.new"
    stale.mkdir()
    (stale / "files.json").write_text("{}")
    (stale / ".writing").write_text("")
    assert remove_stale_temporaries([tmp_path]) == [stale] and not stale.exists()
