"""Atomic outputs: a write that fails (a full disk, a kill) keeps the previous good file and
leaves no temporary file; a set of files is replaced as a whole or not at all.

Oracles: the bytes of the previous output (byte-identical after a failed write), the listing
of the directory (no temporary file), and the errno contract of :class:`OutputError`.
"""

from __future__ import annotations

import errno
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from ufmt import files
from ufmt.errors import OutputError

REPO = Path(__file__).resolve().parents[1]


def on_disk(fd: int, where: Path) -> bool:
    """Whether descriptor ``fd`` is a file below ``where`` (pipes and other files are left
    alone by the fault injection: loky's resource tracker writes to a pipe)."""
    try:
        return os.readlink(f"/proc/self/fd/{fd}").startswith(str(where))
    except OSError:
        return False


def full_disk_after(monkeypatch, budget: int, where: Path) -> None:
    """Make ``os.write`` to a file below ``where`` raise ENOSPC once ``budget`` bytes have
    been written there."""
    real = os.write
    left = [budget]

    def write(fd, data):
        if not on_disk(fd, where):
            return real(fd, data)
        if left[0] <= 0:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        n = real(fd, bytes(data)[: left[0]])
        left[0] -= n
        return n

    monkeypatch.setattr(os, "write", write)


def test_a_full_disk_keeps_the_previous_file_and_leaves_no_temporary(tmp_path, monkeypatch):
    target = tmp_path / "report.html"
    files.write_text(target, "good\n" * 100)
    full_disk_after(monkeypatch, 50, tmp_path)
    with pytest.raises(OutputError, match=r"cannot write .*report.html: No space left") as info:
        files.write_text(target, "new\n" * 1000)
    assert info.value.errno == errno.ENOSPC and isinstance(info.value, OSError)
    assert target.read_text() == "good\n" * 100
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.html"]


def test_the_written_file_has_the_umask_mode_and_exact_bytes(tmp_path):
    data = bytes(range(256)) * 10
    path = files.write_bytes(tmp_path / "sub" / "x.bin", data)
    assert path.read_bytes() == data
    umask = os.umask(0)
    os.umask(umask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask


def test_a_planted_link_at_the_target_is_replaced_not_followed(tmp_path):
    victim = tmp_path / "victim"
    victim.write_text("precious")
    (tmp_path / "out.csv").symlink_to(victim)
    files.write_text(tmp_path / "out.csv", "a,b\n")
    assert victim.read_text() == "precious"
    assert not (tmp_path / "out.csv").is_symlink()


def test_a_directory_in_the_way_is_one_error(tmp_path):
    (tmp_path / "d").mkdir()
    with pytest.raises(OutputError, match="is a directory"):
        files.write_text(tmp_path / "d", "x")


def test_a_kill_at_the_write_keeps_the_previous_file(tmp_path):
    """kill -9 of the writing process in the middle of its write (the signal sent from inside
    ``os.write``): the earlier file is intact; the next write removes the killed one's
    temporary file."""
    target = tmp_path / "ufmt.toml"
    target.write_text("the good model\n")
    script = textwrap.dedent(
        f"""
        import os, signal
        from ufmt import files
        real = os.write
        def write(fd, data):
            real(fd, bytes(data)[:10])
            os.kill(os.getpid(), signal.SIGKILL)
        os.write = write
        files.write_text({str(target)!r}, "x" * 100000)
        """
    )
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    result = subprocess.run([sys.executable, "-c", script], env=env, cwd=REPO, timeout=60)
    assert result.returncode == -9
    assert target.read_text() == "the good model\n"
    files.write_text(target, "the next model\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ufmt.toml"]


def test_a_file_set_fails_as_a_whole(tmp_path, monkeypatch):
    out = tmp_path / "save"
    with files.FileSet(out, manifest="m.json") as written:
        written.add("a.csv", b"old a")
        written.add("m.json", b"old m")
    full_disk_after(monkeypatch, 8, tmp_path)
    with pytest.raises(OutputError):
        with files.FileSet(out, manifest="m.json") as written:
            written.add("a.csv", b"new a")
            written.add("m.json", b"new m: longer than the room left")
    assert (out / "a.csv").read_bytes() == b"old a" and (out / "m.json").read_bytes() == b"old m"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["save"]
    assert sorted(p.name for p in out.iterdir()) == ["a.csv", "m.json"]


def test_a_file_set_into_a_new_directory_appears_whole(tmp_path):
    with files.FileSet(tmp_path / "new") as written:
        written.add("x.csv", b"x")
        assert not (tmp_path / "new").exists()  # staged, not yet visible
    assert (tmp_path / "new" / "x.csv").read_bytes() == b"x"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["new"]


def test_a_file_set_where_a_file_is_refuses_in_one_error(tmp_path):
    (tmp_path / "f").write_text("keep")
    with pytest.raises(OutputError, match="not a directory"):
        with files.FileSet(tmp_path / "f"):
            pass
    assert (tmp_path / "f").read_text() == "keep"


# ---------------------------------------------------------------------------------------------
# a set of files under kill -9

OLD_SET = {"a.csv": b"old a", "b.csv": b"old b", "m.json": b"old m"}
NEW_SET = {"a.csv": b"new a\n", "b.csv": b"new b\n", "m.json": b"new m\n"}
KILLED_SET = textwrap.dedent(
    """
    import os, shutil, signal, sys
    from ufmt import files
    step, calls = int(sys.argv[1]), [0]
    def killing(step_of_the_set):
        def step_or_kill(*args, **kwargs):
            calls[0] += 1
            if calls[0] == step:
                os.kill(os.getpid(), signal.SIGKILL)
            return step_of_the_set(*args, **kwargs)
        return step_or_kill
    os.rename, os.replace = killing(os.rename), killing(os.replace)
    shutil.rmtree = killing(shutil.rmtree)
    if hasattr(files, "exchange"):
        files.exchange = killing(files.exchange)
    with files.FileSet(sys.argv[2], manifest="m.json") as out:
        for name, data in {new!r}.items():
            out.add(name, data)
    """
).format(new=NEW_SET)


def write_set(directory: Path, members: dict[str, bytes]) -> None:
    with files.FileSet(directory, manifest="m.json") as out:
        for name, data in members.items():
            out.add(name, data)


def killed_writes(directory: Path):
    """For k = 1, 2, ...: the old set written in place, then a process writing the new set
    killed (-9) just before its k-th rename, exchange or folder removal; yields (exit status,
    the entries of the parent left by the kill) until a write runs to its end."""
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    for step in range(1, 20):
        write_set(directory, OLD_SET)  # sweeps what the previous kill left
        args = [sys.executable, "-c", KILLED_SET, str(step), str(directory)]
        status = subprocess.run(args, env=env, cwd=REPO, timeout=60).returncode
        yield status, sorted(p.name for p in directory.parent.iterdir())
        if status == 0:
            return
    raise AssertionError("the set never completed")


def contents(directory: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in directory.iterdir() if p.is_file()}


def test_a_kill_at_any_step_of_a_set_leaves_the_old_set_or_the_new_one(tmp_path):
    """Into a directory holding only the set: after a kill -9 at each step, the directory
    holds the old set or the new one, byte for byte, never a mix; the killed writer's staging
    folder is removed by the next write."""
    a, b = tmp_path / "probe-a", tmp_path / "probe-b"
    a.mkdir()
    b.mkdir()
    if not files.exchange(a, b):
        pytest.skip("this file system cannot exchange two folders")
    a.rmdir()
    b.rmdir()
    out = tmp_path / "save"
    seen, leftovers = [], []
    for status, entries in killed_writes(out):
        assert status in (0, -9)
        state = contents(out)
        assert state in (OLD_SET, NEW_SET), f"a mixed set after a kill: {state}"
        seen.append(state == NEW_SET)
        leftovers += [e for e in entries if e != "save"]
    assert seen[-1] and not seen[0] and True in seen[:-1]  # killed before and after the swap
    assert leftovers  # kills left staging folders ...
    write_set(out, NEW_SET)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["save"]  # ... that were swept


def test_a_kill_into_a_shared_directory_keeps_its_other_files_and_the_manifest_last(tmp_path):
    """Into a directory holding other files too (a folder of another command's outputs): the
    members are renamed one by one, manifest last; after a kill at each step the other files
    are intact and a new manifest means every member is new."""
    out = tmp_path / "validation"
    (out / "reference-process").mkdir(parents=True)
    (out / "reference-process" / "keep.csv").write_bytes(b"keep")
    mixed = False
    for _status, _entries in killed_writes(out):
        state = contents(out)
        assert (out / "reference-process" / "keep.csv").read_bytes() == b"keep"
        if state["m.json"] == NEW_SET["m.json"]:
            assert state == NEW_SET
        mixed |= state not in (OLD_SET, NEW_SET)
    assert mixed  # this scheme can leave a mix, which the manifest tells apart
    write_set(out, NEW_SET)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["validation"]
    assert sorted(p.name for p in out.iterdir()) == sorted([*NEW_SET, "reference-process"])
