"""Issue 21: one output lock for every command that writes (io/exclusive.py), created
with O_EXCL|O_NOFOLLOW: it never follows a symbolic link nor truncates a file it
did not create; the same for the temporaries renamed into place."""
from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from elastica_petsc.io.exclusive import LockError, OutputLock, lock_path

TINY = ["workspace", "--mode", "tensions", "--tension-spacing", 10, "--tension-max", 20,
        "--elements", 30, "--chunk", 2]


def run_main(args, capsys) -> tuple[int, str]:
    from elastica_petsc.cli import main

    capsys.readouterr()
    status = main([str(a) for a in args])
    return status, capsys.readouterr().err


def one_line(err: str, *words) -> None:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("elastica-petsc: error:"), err
    for word in words:
        assert word in lines[0], lines[0]


def test_a_planted_symlink_lock_leaves_its_target_untouched(tmp_path, monkeypatch, capsys):
    """`ln -s victim.txt .w2.h5.lock; workspace ... --out w2.h5` truncated victim.txt
    and wrote a process id into it."""
    monkeypatch.chdir(tmp_path)
    victim = tmp_path / "victim.txt"
    victim.write_text("the user's words\n")
    os.symlink("victim.txt", tmp_path / ".w2.h5.lock")
    status, err = run_main(TINY + ["--out", "w2.h5"], capsys)
    assert status == 2
    one_line(err, ".w2.h5.lock", "symbolic link")
    assert victim.read_text() == "the user's words\n"
    assert not (tmp_path / "w2.h5").exists()
    # the same through every writer: solve's --out
    os.symlink("victim.txt", tmp_path / ".s.h5.lock")
    status, err = run_main(["solve", "--tensions", 1, 1, "--elements", 30, "--out", "s.h5"],
                           capsys)
    assert status == 2 and victim.read_text() == "the user's words\n"


def test_a_foreign_file_at_the_lock_name_is_not_truncated(tmp_path):
    out = tmp_path / "x.h5"
    lock = lock_path(out)
    lock.write_text("not a lock\n")
    with pytest.raises(LockError, match="not a lock file of this tool"):
        OutputLock(out)
    assert lock.read_text() == "not a lock\n"


def test_the_lock_of_a_run_that_died_is_replaced(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    lock_path(tmp_path / "s.h5").write_text("999999999")        # no flock held: stale
    status, err = run_main(["solve", "--tensions", 1, 1, "--elements", 30, "--out", "s.h5"],
                           capsys)
    assert status == 0, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.h5"]   # lock and temporary gone


def test_the_lock_is_reentrant_in_a_process(tmp_path):
    out = tmp_path / "x.h5"
    with OutputLock(out):
        with OutputLock(out):
            assert lock_path(out).read_text() == str(os.getpid())
        assert lock_path(out).exists()
    assert not lock_path(out).exists()


HOLDER = textwrap.dedent("""
    import sys, time
    from elastica_petsc.io.exclusive import OutputLock
    with OutputLock(sys.argv[1]):
        print("held", flush=True)
        time.sleep(60)
""")


@pytest.fixture
def held(tmp_path):
    """Another process (as a running workspace does) holding the lock of tmp/X.h5."""
    out = tmp_path / "X.h5"
    out.write_bytes(b"the workspace's file")
    proc = subprocess.Popen([sys.executable, "-c", HOLDER, str(out)], stdout=subprocess.PIPE,
                            text=True)
    assert proc.stdout.readline().strip() == "held"
    yield out, proc
    proc.kill()
    proc.wait()


@pytest.mark.parametrize("command", [
    ["solve", "--tensions", 1, 1, "--elements", 30],
    ["control", "--target", 500, 100, "--elements", 30],
    ["stability", "--tensions", 1, 1, "--elements", 30],
    ["lengths", "--lengths", 147.1, 472.5, "--elements", 30],
    ["trace", "--shape", "line", "--center", 400, 200, "--end", 410, 200, "--elements", 30],
    TINY])
def test_no_command_replaces_a_file_another_run_is_writing(command, held, capsys):
    """`solve --out X --overwrite` replaced the X of a running workspace: only `workspace`
    took the lock.  Every writer is refused now, before computing."""
    out, proc = held
    t0 = time.perf_counter()
    status, err = run_main(command + ["--out", out, "--overwrite"], capsys)
    assert status == 2 and time.perf_counter() - t0 < 1.0
    one_line(err, "being written by another run", f"pid {proc.pid}")
    assert out.read_bytes() == b"the workspace's file"


def test_temporaries_are_created_exclusively(tmp_path):
    from elastica_petsc.io.exclusive import replace_file, temporary_beside

    out = tmp_path / "f.vtu"
    with temporary_beside(out) as (raw, tmp):
        assert tmp.name.startswith(".f.vtu.tmp-") and tmp.name.endswith(f"-{os.getpid()}")
        with pytest.raises(FileExistsError):
            os.close(os.open(tmp, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
    assert not tmp.exists()
    replace_file(out, b"data")
    assert out.read_bytes() == b"data" and sorted(p.name for p in tmp_path.iterdir()) == \
        ["f.vtu"]
    Path(tmp_path / "link.vtu").symlink_to("f.vtu")
    replace_file(tmp_path / "link.vtu", b"new")          # the link is replaced, not followed
    assert out.read_bytes() == b"data" and (tmp_path / "link.vtu").read_bytes() == b"new"
