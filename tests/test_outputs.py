"""Outputs are whole or absent: staged folders, --force, a lock against a second run, interrupts and a full disk."""

from __future__ import annotations

import argparse
import errno
import os
import signal
import stat
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

import iwp.cli as cli
from iwp.cli import main
from iwp.cli.interrupts import interrupts_as_exceptions
from iwp.errors import OutputExistsError
from iwp.files import output_lock, staged_dir, write_all
from iwp.interruption import Terminated, deliveries, raise_if_replaced

SRC = str(Path(__file__).resolve().parents[1] / "src")


def _env() -> dict:
    return {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}


def _litter(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


# --------------------------------------------------------------------------
# staged folders and --force
# --------------------------------------------------------------------------
def test_force_replaces_only_the_commands_files(tmp_path):
    out = tmp_path / "D"
    (out / "figures").mkdir(parents=True)
    (out / "figures" / "mine.png").write_bytes(b"the user's own figure")
    (out / "figures" / "a.png").write_bytes(b"old a")
    (out / "notes.txt").write_text("mine")
    with pytest.raises(OutputExistsError):
        with staged_dir(out, force=False):
            pass
    with staged_dir(out, force=True) as tmp:
        (tmp / "figures").mkdir()
        (tmp / "figures" / "a.png").write_bytes(b"new a")
        (tmp / "report.html").write_text("<html></html>")
    assert (out / "figures" / "a.png").read_bytes() == b"new a"
    assert (out / "figures" / "mine.png").read_bytes() == b"the user's own figure"
    assert (out / "notes.txt").read_text() == "mine"
    assert (out / "report.html").is_file()
    assert _litter(tmp_path) == []


def test_force_replaces_a_file_and_a_folder_in_the_way(tmp_path):
    out = tmp_path / "D"
    out.mkdir()
    (out / "figures").write_text("a file where the command writes a folder")
    (out / "report.html").mkdir()  # a folder where it writes a file
    with staged_dir(out, force=True) as tmp:
        (tmp / "figures").mkdir()
        (tmp / "figures" / "a.png").write_bytes(b"a")
        (tmp / "report.html").write_text("<html></html>")
    assert (out / "figures" / "a.png").read_bytes() == b"a" and (out / "report.html").is_file()


def test_a_staged_folder_has_the_permissions_of_the_umask(tmp_path):
    old = os.umask(0o022)
    try:
        with staged_dir(tmp_path / "D") as tmp:
            (tmp / "sub").mkdir()
            (tmp / "sub" / "f.txt").write_text("x")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "D").stat().st_mode) == 0o755  # was 0700 (tempfile.mkdtemp)
    assert stat.S_IMODE((tmp_path / "D" / "sub").stat().st_mode) == 0o755


def test_an_error_inside_a_staged_folder_leaves_nothing_and_names_the_output(tmp_path):
    out = tmp_path / "D"
    with pytest.raises(OSError) as info:
        with staged_dir(out) as tmp:
            (tmp / "a.csv").write_text("1")
            raise OSError(errno.ENOSPC, "No space left on device", str(tmp / "a.csv"))
    assert info.value.filename == str(out / "a.csv")  # the output's name, not the hidden folder's
    assert not out.exists() and _litter(tmp_path) == []


def test_write_all_does_not_replace_a_file_that_appeared_meanwhile(tmp_path):
    p = tmp_path / "s.csv"

    def write(tmp):
        p.write_text("another run's")  # another writer creates the file while this one writes
        tmp.write_text("mine")

    with pytest.raises(OutputExistsError):
        write_all([(p, write)], force=False)
    assert p.read_text() == "another run's" and _litter(tmp_path) == []
    write_all([(p, lambda tmp: tmp.write_text("mine"))], force=True)
    assert p.read_text() == "mine"


@pytest.mark.parametrize("argv", [["simulate", "--t-end", "1", "--out"], ["reproduce", "--out"]])
def test_an_output_in_a_folder_that_does_not_exist_is_refused_and_nothing_is_created(tmp_path, capsys, argv):
    """iwp creates what the user names (a file, or a report's folder), never the folders above it: a typo in a
    path (``/nonexistent/dir/x.csv``) would otherwise leave folders anywhere."""
    target = tmp_path / "missing" / "deeper" / ("x.csv" if argv[0] == "simulate" else "report")
    assert main([*argv, str(target)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("iwp: error: --out") and f"folder {target.parent} does not exist" in err and "\n" not in err
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------
# a second run into the same output
# --------------------------------------------------------------------------
def test_a_second_run_into_a_locked_output_is_refused(tmp_path, capsys):
    out = tmp_path / "s.csv"
    holder = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(f"""
            import sys, time
            from iwp.files import output_lock
            with output_lock({str(out)!r}):
                print("locked", flush=True)
                time.sleep(60)
            """)], stdout=subprocess.PIPE, text=True, env=_env())
    try:
        assert holder.stdout.readline().strip() == "locked"
        status = main(["simulate", "--t-end", "1", "--out", str(out)])
        err = capsys.readouterr().err.strip()
        assert status == 2 and err.startswith("iwp: error: --out") and "another iwp run" in err, err
        assert "\n" not in err and not out.exists()
    finally:
        holder.kill()
        holder.wait()
    # the holder died: its lock went with it, and the run goes through
    assert main(["simulate", "--t-end", "1", "--out", str(out)]) == 0
    assert out.is_file() and _litter(tmp_path) == []


def test_the_lock_is_reentrant_and_leaves_no_file(tmp_path):
    with output_lock(tmp_path / "D"):
        with output_lock(tmp_path / "D"):
            assert _litter(tmp_path) == [".D.iwp-lock"]
        assert _litter(tmp_path) == [".D.iwp-lock"]
    assert _litter(tmp_path) == []


# --------------------------------------------------------------------------
# interrupts
# --------------------------------------------------------------------------
_KERNEL_LOOP = """
import signal
from collections import namedtuple
import numba
import numba.core.serialize as serialize
from iwp.cli.interrupts import interrupts_as_exceptions

Stats = namedtuple("Stats", ["status", "t"])


@numba.njit
def kernel(t):
    return Stats(0, t)  # boxing a namedtuple runs numba.core.serialize._numba_unpickle


# numba's own function, wrapped (compiled under its file name) so that the interrupt arrives inside it; before the
# first call, which keeps a reference to it
armed = []
wrapper = "def wrapped(address, data, hashed, _f=_f, _armed=armed):\\n    if _armed:\\n        _armed.pop()\\n        signal.raise_signal(SIGNAL)\\n    return _f(address, data, hashed)\\n"
ns = {"_f": serialize._numba_unpickle, "signal": signal, "armed": armed}
exec(compile(wrapper, serialize.__file__, "exec"), ns)
serialize._numba_unpickle = ns["wrapped"]
kernel(1.0)
caught = 0
with interrupts_as_exceptions():
    for trial in range(TRIALS):
        armed.append(True)
        try:
            while True:
                kernel(1.0)
        except KeyboardInterrupt:
            caught += 1
print(caught)
"""


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_interrupts_while_numba_boxes_a_result_raise_and_never_crash(sig):
    """An interrupt that lands while numba boxes a compiled function's result is an exception, not a crash.

    numba calls Python code (``numba.core.serialize``) to box a named tuple and does not check it for an
    exception: a plain ``KeyboardInterrupt`` there is a segmentation fault (exit -11; ``iwp reproduce`` died so
    in 4 of 5 tries). Here every interrupt is raised there, ten times."""
    code = _KERNEL_LOOP.replace("TRIALS", "10").replace("SIGNAL", f"signal.{sig.name}")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=_env(), timeout=300)
    assert done.returncode == 0, f"exit {done.returncode}: {done.stderr[-2000:]}"
    assert done.stdout.split()[-1] == "10"


_COMPILE_LOOP = """
import importlib, os, signal, sys
import numba
import numba.core.codegen as cg
from iwp.cli.interrupts import interrupts_as_exceptions

# numba's hook that LLVM calls back through llvmlite's ctypes callback when it has compiled an object to cache:
# the interrupt arrives inside it
armed = []
orig = cg.JITCodeLibrary._object_compiled_hook.__func__


def hook(cls, ll_module, buf):
    if armed:
        armed.pop()
        signal.raise_signal(SIGNAL)
    return orig(cls, ll_module, buf)


cg.JITCodeLibrary._object_compiled_hook = classmethod(hook)
sys.path.insert(0, os.getcwd())
caught = 0
with interrupts_as_exceptions():
    for trial in range(TRIALS):
        with open(f"m{trial}.py", "w") as fh:
            fh.write(f"import numba\\n@numba.njit(cache=True)\\ndef f(x):\\n    return x * {trial + 2}.0 + 1.0\\n")
        m = importlib.import_module(f"m{trial}")
        armed.append(True)
        try:
            m.f(1.0)
        except KeyboardInterrupt:
            caught += 1
print(caught, m.f(1.0), numba.njit(lambda x: x * 2.0)(2.0))
"""


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_interrupts_while_numba_compiles_raise_and_leave_numba_working(tmp_path, sig):
    """An interrupt that lands in LLVM's callback while numba compiles (a cold cache) is an exception, raised when
    the callback returns: ctypes would print and drop it there, and numba would go on with a broken library ("no
    compiled object yet for <Library 'sens_views'>": iwp reproduce's step failed, exit 1 instead of 130, in CI)."""
    code = _COMPILE_LOOP.replace("TRIALS", "5").replace("SIGNAL", f"signal.{sig.name}")
    env = {**_env(), "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=tmp_path,
                          timeout=300)
    assert done.returncode == 0, f"exit {done.returncode}: {done.stderr[-2000:]}"
    assert done.stdout.split() == ["5", "7.0", "4.0"], done.stdout + done.stderr[-2000:]
    assert "Exception ignored" not in done.stderr, done.stderr[-2000:]


_DROPPED = """
import gc, signal, sys, weakref
from iwp.cli.interrupts import interrupts_as_exceptions
from iwp.files import staged_dir, atomic_write


class Thing:
    pass


def dropped():
    # the interrupt lands in a weakref callback, where Python prints its exception and drops it
    t = Thing()
    weakref.finalize(t, signal.raise_signal, SIGNAL)
    del t
    gc.collect()


out = []
with interrupts_as_exceptions():
    for kind in ("folder", "file"):
        try:
            dropped()
            out.append("ran on")  # the command does not know ...
            if kind == "folder":
                with staged_dir(sys.argv[1]) as tmp:
                    (tmp / "a.txt").write_text("x")
            else:
                atomic_write(sys.argv[2], lambda p: p.write_text("x"))
            out.append("committed")
        except KeyboardInterrupt as exc:
            out.append(type(exc).__name__)  # ... but its output is not committed
print(" ".join(out))
"""


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_an_interrupt_whose_exception_a_callback_dropped_commits_no_output(tmp_path, sig):
    """A signal that lands in a weakref or GC callback raises there and Python drops the exception ("Exception
    ignored in ..."; iwp reproduce then ran to its end and exit 0 in a fresh-clone CI): the interrupt is remembered,
    the outputs, a staged folder and a file, are not committed, and no traceback is printed for it."""
    code = _DROPPED.replace("SIGNAL", f"signal.{sig.name}")
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "D"), str(tmp_path / "f.txt")],
                          capture_output=True, text=True, env=_env(), cwd=tmp_path, timeout=120)
    name = "Terminated" if sig == signal.SIGTERM else "KeyboardInterrupt"
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["ran", "on", name, "ran", "on", name], done.stdout + done.stderr[-2000:]
    # "ran on": the callback dropped the exception, as the test intends; and printed no traceback for it
    assert "Exception ignored" not in done.stderr and "Traceback" not in done.stderr, done.stderr[-2000:]
    assert sorted(p.name for p in tmp_path.iterdir()) == []


@pytest.mark.parametrize("sig, step", [(signal.SIGINT, "[ 3/12]"), (signal.SIGTERM, "[11/12]")],
                         ids=["SIGINT", "SIGTERM"])
def test_an_interrupted_reproduction_leaves_nothing(tmp_path, sig, step):
    """The signal comes while a step runs (its progress line printed, its end not), whatever the machine's speed."""
    out = tmp_path / "run"
    proc = subprocess.Popen([sys.executable, "-m", "iwp", "reproduce", "--quick", "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env(), cwd=tmp_path)
    seen = []
    for line in proc.stdout:
        seen.append(line)
        if line.startswith(step):
            break
    assert seen and seen[-1].startswith(step), "".join(seen)
    time.sleep(0.3)  # into the step (sines: 7 s, refine: 1.5 s on 2 cores)
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=120)
    lines = [ln for ln in stderr.splitlines() if not ln.startswith("iwp: compiling")]
    assert proc.returncode == 130, stderr
    assert lines == ["iwp: interrupted" if sig == signal.SIGINT else "iwp: terminated"], stderr
    assert not out.exists() and _litter(tmp_path) == []


def test_a_full_disk_during_a_reproduction_leaves_nothing(tmp_path, monkeypatch, capsys):
    import iwp.reproduce.pipeline as pipeline

    def writes_then_fills(ctx):
        (ctx.out / "data").mkdir()
        (ctx.out / "data" / "a.csv").write_text("t,q1\n")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(pipeline, "STEPS", [pipeline.Step("report", writes_then_fills, "report", "")])
    out = tmp_path / "run"
    assert main(["reproduce", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"iwp: error: {out}: no space left on device", err
    assert not out.exists() and _litter(tmp_path) == []


def _matplotlib_like(sig):
    """Compiled code that catches the interrupt's exception and raises its own (matplotlib's "Invalid bounding
    box" when a signal lands while its C code converts a bounding box)."""
    try:
        signal.raise_signal(sig)
    except KeyboardInterrupt:
        raise ValueError("Invalid bounding box") from None


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_an_error_that_replaced_an_interrupt_is_the_interrupt(sig):
    expected = Terminated if sig == signal.SIGTERM else KeyboardInterrupt
    with interrupts_as_exceptions():
        since = deliveries()
        with pytest.raises(ValueError) as err:
            _matplotlib_like(sig)
        with pytest.raises(expected) as got:
            raise_if_replaced(since, err.value)
        assert got.value.__cause__ is err.value
        assert type(got.value) is expected
        # an error with no interrupt delivered while its block ran is left to the caller
        since = deliveries()
        raise_if_replaced(since, ValueError("a bug"))


@pytest.mark.parametrize("sig, word", [(signal.SIGINT, "interrupted"), (signal.SIGTERM, "terminated")])
def test_the_cli_reports_an_error_that_replaced_an_interrupt_as_the_interrupt(monkeypatch, capsys, sig, word):
    parser = argparse.ArgumentParser(prog="iwp")
    parser.set_defaults(func=lambda args: _matplotlib_like(sig), command="fake")
    monkeypatch.setattr(cli, "build_parser", lambda: parser)
    assert cli.main([]) == 130
    assert capsys.readouterr().err.strip().splitlines()[-1] == f"iwp: {word}"
    # the same error without an interrupt is an internal error (exit 3)
    parser.set_defaults(func=lambda args: (_ for _ in ()).throw(ValueError("Invalid bounding box")))
    assert cli.main([]) == 3
    assert "internal error: ValueError: Invalid bounding box" in capsys.readouterr().err


def test_an_interrupt_while_the_command_loads_is_one_line_and_130():
    """Ctrl-C before the command runs (the parser and numba loading) is reported like any other interrupt,
    and importing the CLI loads no numerical library, so the window before main can report it is short."""
    code = textwrap.dedent("""
        import os, signal, sys
        import iwp.cli as c
        assert "numba" not in sys.modules and "scipy" not in sys.modules, "the CLI's import loads numba or scipy"
        build = c.build_parser
        def interrupted_build():
            os.kill(os.getpid(), signal.SIGINT)
            return build()
        c.build_parser = interrupted_build
        raise SystemExit(c.main(["fit", "a.csv", "--out", "D"]))
    """)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=_env(), timeout=120)
    assert done.returncode == 130, done.stderr
    assert done.stderr.strip().splitlines() == ["iwp: interrupted"], done.stderr
