"""Files that iwp writes and reads: overwrite policy and JSON."""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import secrets
import shutil
import signal
import threading
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Callable

from .errors import InputError, OutputExistsError
from .interruption import raise_pending

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows: no output lock
    fcntl = None

#: Extensions of the logs iwp writes, and their format.
LOG_SUFFIXES = {".csv": "csv", ".txt": "csv", ".parquet": "parquet", ".pq": "parquet", ".mat": "mat"}
#: Extensions of the figures iwp writes (matplotlib's formats).
FIGURE_SUFFIXES = (".png", ".svg", ".pdf", ".eps", ".ps", ".jpg", ".jpeg", ".tif", ".tiff", ".webp")


def _check_writable_place(p: Path, argument: str) -> None:
    """The folder ``p`` goes into (``p`` itself if it is a folder) must exist and be writable: iwp creates what the
    user names, never the folders above it (a typo in a path would otherwise leave folders anywhere)."""
    if p.is_symlink() and not p.exists():  # a link to nothing: writing through it would land elsewhere, or fail
        raise InputError(f"{argument} {p}: a link to {os.readlink(p)}, which does not exist; remove the link or give "
                         "another path", argument=argument)
    anc = p if p.is_dir() else p.parent
    if not anc.exists():
        raise InputError(f"{argument} {p}: folder {anc} does not exist; create it first, or give a path in an "
                         "existing folder", argument=argument)
    if not anc.is_dir():
        raise InputError(f"{argument} {p}: {anc} is a file, not a folder", argument=argument)
    if not os.access(anc, os.W_OK | os.X_OK):
        raise InputError(f"{argument} {p}: folder {anc} is not writable", argument=argument)


def check_output_file(path: str | Path, *, force: bool = False, argument: str = "out",
                      suffixes=None) -> Path:
    """Check, without touching anything, that ``path`` may be written.

    Refuses: an extension not in ``suffixes`` (when given), an existing file
    unless ``force``, a folder in the way, a parent that is a file or that
    is not writable. The message names ``argument`` (the CLI shows its flag:
    ``out`` -> ``--out``).

    Returns
    -------
    pathlib.Path
    """
    p = Path(path)
    if str(path).strip() == "":
        raise InputError(f"{argument}: empty file name", argument=argument)
    if suffixes is not None and p.suffix.lower() not in suffixes:
        got = f"extension {p.suffix!r}" if p.suffix else "no extension"
        raise InputError(f"{argument} {p}: {got}; use one of {', '.join(suffixes)}", argument=argument)
    if p.is_dir():
        raise InputError(f"{argument} {p}: is a folder, expected a file path", argument=argument)
    if p.exists() and not force:
        raise OutputExistsError(f"{argument} {p}: file exists; pass --force to overwrite it")
    _check_writable_place(p, argument)
    if p.exists() and not os.access(p, os.W_OK):
        raise InputError(f"{argument} {p}: file is not writable", argument=argument)
    return p


def prepare_output_file(path: str | Path, force: bool = False, *, argument: str = "out", suffixes=None) -> Path:
    """:func:`check_output_file` (its folder exists: nothing is created)."""
    return check_output_file(path, force=force, argument=argument, suffixes=suffixes)


#: Extensions that make a new output folder's name a file name (``--out report.html``): refused.
_FILE_SUFFIXES = frozenset(LOG_SUFFIXES) | frozenset(FIGURE_SUFFIXES) | {".html", ".htm", ".json", ".gif", ".zip"}


def check_output_dir(path: str | Path, *, force: bool = False, argument: str = "out") -> Path:
    """The one folder policy: an output folder must be new or empty, unless ``force``; nothing is created here."""
    p = Path(path)
    if str(path).strip() == "":
        raise InputError(f"{argument}: empty folder name", argument=argument)
    if p.exists() and not p.is_dir():
        raise InputError(f"{argument} {p}: exists and is not a folder", argument=argument)
    if not p.exists() and p.suffix.lower() in _FILE_SUFFIXES:
        raise InputError(f"{argument} {p}: names a file, but the command writes a folder of files (e.g. "
                         f"{argument} {p.with_suffix('')})", argument=argument)
    if p.is_dir() and any(p.iterdir()) and not force:
        raise OutputExistsError(f"{argument} {p}: folder exists and is not empty; pass --force to write into it")
    _check_writable_place(p, argument)
    return p


def prepare_output_dir(path: str | Path, *, force: bool = False, argument: str = "out") -> Path:
    """:func:`check_output_dir`, then create the folder.

    Examples
    --------
    A new folder is created; one that holds files only with ``force``:

    >>> from iwp.report import prepare_output_dir
    >>> out = prepare_output_dir("report")
    >>> out.is_dir()
    True
    >>> _ = (out / "page.html").write_text("<html></html>")
    >>> prepare_output_dir("report")
    Traceback (most recent call last):
    ...
    iwp.errors.OutputExistsError: out report: folder exists and is not empty; pass --force to write into it
    >>> prepare_output_dir("report", force=True).name
    'report'
    """
    p = check_output_dir(path, force=force, argument=argument)
    p.mkdir(exist_ok=True)
    return p


#: Output paths this process holds the lock of, with the depth of nesting (the lock is re-entrant).
_HELD_LOCKS: dict[str, tuple[int, int]] = {}


def _lock_name(p: Path) -> Path:
    return p.parent / f".{p.name}.iwp-lock"


@contextlib.contextmanager
def output_lock(path: str | Path, *, argument: str = "out"):
    """Hold the lock of the output ``path`` (a file or a folder) for the duration of the block.

    A second run (another process) that asks for the same output while the
    block runs is refused with an :class:`InputError` naming ``argument``,
    so that two runs never mix or lose each other's files. The lock is a
    hidden file ``.NAME.iwp-lock`` beside ``path``, locked with ``flock``
    (released by the system if the process dies) and removed at the end.
    Re-entrant within one process; a no-op where ``fcntl`` does not exist
    or the parent folder does not exist yet and cannot be created.
    """
    p = Path(path)
    if fcntl is None or str(path).strip() == "":
        yield p
        return
    key = os.path.abspath(p)
    if key in _HELD_LOCKS:
        fd, depth = _HELD_LOCKS[key]
        _HELD_LOCKS[key] = (fd, depth + 1)
        try:
            yield p
        finally:
            fd, depth = _HELD_LOCKS[key]
            _HELD_LOCKS[key] = (fd, depth - 1)
        return
    lock = _lock_name(Path(key))
    fd = _acquire(lock, p, argument) if lock.parent.is_dir() else None
    if fd is None:  # no folder yet (nothing to mix), or a read-only one (the output checks refuse it)
        yield p
        return
    _HELD_LOCKS[key] = (fd, 1)
    try:
        yield p
    finally:
        del _HELD_LOCKS[key]
        with contextlib.suppress(OSError):
            lock.unlink()
        os.close(fd)


def _acquire(lock: Path, p: Path, argument: str) -> int | None:
    """Lock the file ``lock`` (created if missing); None where it cannot be created; refuse if another holds it."""
    while True:
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o666)
        except OSError:
            return None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            raise InputError(f"{argument} {p}: another iwp run is writing it; wait for it to end or choose "
                             "another output", argument=argument) from None
        try:
            same = os.fstat(fd).st_ino == os.stat(lock).st_ino
        except FileNotFoundError:
            same = False
        if same:
            return fd
        os.close(fd)  # the holder removed it between our open and our lock: take the new one


@contextlib.contextmanager
def signals_held():
    """Delay SIGINT and SIGTERM until the block has run (a rename of several files is not cut in two)."""
    sigs = {signal.SIGINT, signal.SIGTERM}
    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, sigs)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _name_output(exc: OSError, tmp: Path, final: Path) -> None:
    """Make ``exc`` name the output ``final`` where it names the temporary ``tmp`` (or nothing)."""
    name = exc.filename
    if name is None:
        exc.filename = str(final)
        return
    with contextlib.suppress(ValueError):
        exc.filename = str(final / Path(name).relative_to(tmp)) if Path(name) != tmp else str(final)


def _merge_into(src: Path, dst: Path) -> None:
    """Move every entry of folder ``src`` into folder ``dst``, entry by entry; folders are merged, not replaced."""
    for item in sorted(src.iterdir()):
        target = dst / item.name
        if item.is_dir() and not item.is_symlink() and target.is_dir() and not target.is_symlink():
            _merge_into(item, target)
            continue
        if target.is_dir() and not target.is_symlink():
            shutil.rmtree(target)  # a folder where the command writes a file of that name
        elif item.is_dir() and (target.exists() or target.is_symlink()):
            target.unlink()  # a file where the command writes a folder of that name
        os.replace(item, target)


@contextlib.contextmanager
def staged_dir(path: str | Path, *, force: bool = False, argument: str = "out"):
    """Write a folder's files into a hidden sibling, and move them into ``path`` only when all are written.

    ``with staged_dir(out, force=...) as tmp: ...write into tmp...``: on an
    error or an interrupt inside the block nothing of the output appears and
    the hidden folder is removed; on success every file of ``tmp`` replaces
    its namesake in ``path`` (the folder policy of :func:`check_output_dir`
    holds): ``force`` replaces the files the command writes and leaves the
    others in ``path`` as they were. The folder gets the permissions of the
    user's umask, as any folder the user makes. The output is locked
    (:func:`output_lock`) from the start to the end.
    """
    p = check_output_dir(path, force=force, argument=argument)
    with output_lock(p, argument=argument):
        check_output_dir(p, force=force, argument=argument)
        tmp = p.parent / f".{p.name}.{os.getpid()}.{secrets.token_hex(4)}.partial"
        os.mkdir(tmp)  # mode 0o777 less the umask (tempfile.mkdtemp would make it 0700)
        try:
            try:
                yield tmp
            except OSError as exc:  # a full disk: name the output, not the hidden folder
                _name_output(exc, tmp, p)
                raise
            with signals_held():
                raise_pending()  # an interrupt whose exception a callback dropped: nothing is committed
                check_output_dir(p, force=force, argument=argument)  # written meanwhile by something else?
                if not p.exists():
                    os.replace(tmp, p)
                else:
                    _merge_into(tmp, p)
        finally:
            if tmp.exists():
                shutil.rmtree(tmp, ignore_errors=True)


#: Largest JSON file iwp reads (parameter, truth and rig files are a few kB).
MAX_JSON_BYTES = 16 * 2**20


#: Longest integer a JSON file of iwp may hold (a float holds at most 1.8e308).
_MAX_INT_DIGITS = 300


class _HugeInteger(Exception):
    pass


class _DuplicateKey(Exception):
    pass


def _unique_keys(pairs: list) -> dict:
    """A JSON object's pairs as a dict, refusing a key given twice (json keeps the last one without a word)."""
    out: dict = {}
    for k, v in pairs:
        if k in out:
            raise _DuplicateKey(k)
        out[k] = v
    return out


def _json_int(text: str) -> int:
    digits = len(text.lstrip("-"))
    if digits > _MAX_INT_DIGITS:
        raise _HugeInteger(digits, text)
    return int(text)


def _place(text: str, token: str) -> str:
    """Where ``token`` first stands in JSON ``text``: ``"key 'K' (line L, column C): "``, the key it is the value of."""
    at = text.find(token)
    if at < 0:
        return ""
    line = text.count("\n", 0, at) + 1
    column = at - (text.rfind("\n", 0, at) + 1) + 1
    key = re.search(r'"((?:[^"\\]|\\.)*)"\s*:\s*\[?\s*$', text[max(0, at - 400):at])
    return (f"key {key.group(1)!r} " if key else "") + f"(line {line}, column {column}): "


def read_json(path: str | Path, *, argument: str | None = None) -> Any:
    """Parse a JSON file; raise :class:`InputError` naming the file (and ``argument``) if it cannot be.

    Refuses a missing or unreadable file, a folder, a file over
    :data:`MAX_JSON_BYTES`, text that is not UTF-8 or not JSON (with its line
    and column), and nesting too deep to parse.
    """
    p = Path(path)
    where = f"{argument} {p}" if argument else f"{p}"
    try:
        if p.is_dir():
            raise InputError(f"{where}: is a folder, expected a JSON file", argument=argument)
        if p.stat().st_size > MAX_JSON_BYTES:
            raise InputError(f"{where}: {p.stat().st_size / 2**20:.0f} MB is too large for a JSON file of iwp "
                             f"(at most {MAX_JSON_BYTES // 2**20} MB)", argument=argument)
        text = p.read_bytes().decode("utf-8-sig")
        return json.loads(text, parse_int=_json_int, object_pairs_hook=_unique_keys)
    except InputError:  # said above (an InputError is a ValueError: not the last clause's)
        raise
    except _DuplicateKey as exc:
        raise InputError(f"{where}: key {exc.args[0]!r} is given twice in one object (only one would count); give it "
                         "once", argument=argument) from None
    except _HugeInteger as exc:
        raise InputError(f"{where}: {_place(text, exc.args[1])}an integer of {exc.args[0]} digits is beyond any "
                         f"number iwp reads (at most {_MAX_INT_DIGITS})", argument=argument) from None
    except FileNotFoundError:
        raise InputError(f"{where}: no such file", argument=argument) from None
    except OSError as exc:
        raise InputError(f"{where}: cannot be read ({exc.strerror or exc})", argument=argument) from None
    except UnicodeDecodeError as exc:
        raise InputError(f"{where}: not UTF-8 text (byte {exc.start})", argument=argument) from None
    except json.JSONDecodeError as exc:
        raise InputError(f"{where}: not valid JSON: {exc.msg} (line {exc.lineno}, column {exc.colno})",
                         argument=argument) from None
    except RecursionError:
        raise InputError(f"{where}: JSON nested too deeply", argument=argument) from None
    except ValueError as exc:  # e.g. an integer of thousands of digits
        raise InputError(f"{where}: not valid JSON ({str(exc).split(';')[0]})", argument=argument) from None


def _temp_name(path: Path) -> Path:
    # the extension is kept: writers (matplotlib, scipy.io) pick the format from it
    return path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")


def atomic_write(path: Path, write: Callable[[Path], None], *, force: bool = True) -> Path:
    """Write through a temporary file in the same folder, then rename: never a half-written ``path``."""
    return write_all([(Path(path), write)], force=force)[0]


def write_all(writes, *, force: bool = True) -> list[Path]:
    """Write several files as one: each through a temporary file; all renamed only when every one is written.

    Parameters
    ----------
    writes : sequence of (path, write)
        ``write(tmp_path)`` writes one file; missing parent folders are created.
    force : bool
        Replace a file that exists. ``False``: a file that appeared since the
        command's checks (another run's) is not replaced: :class:`OutputExistsError`.

    Returns
    -------
    list of Path
        The paths written. On an error or an interrupt no target is touched and the temporary files are
        removed; each path is locked (:func:`output_lock`) while it is written.
    """
    pairs = [(Path(p), w) for p, w in writes]
    temps: list[Path] = []
    with contextlib.ExitStack() as locks:
        for p, _ in pairs:
            locks.enter_context(output_lock(p))
        try:
            for p, write in pairs:
                p.parent.mkdir(parents=True, exist_ok=True)
                tmp = _temp_name(p)
                temps.append(tmp)
                try:
                    write(tmp)
                except OSError as exc:  # a full disk: name the output, not the temporary file
                    _name_output(exc, tmp, p)
                    raise
            with signals_held():
                raise_pending()  # an interrupt whose exception a callback dropped: nothing is committed
                if not force:
                    for p, _ in pairs:
                        if p.exists():
                            raise OutputExistsError(f"{p}: file exists (written meanwhile by another run); "
                                                    "pass --force to overwrite it")
                for (p, _), tmp in zip(pairs, temps):
                    os.replace(tmp, p)
        finally:
            for tmp in temps:
                if tmp.exists():
                    tmp.unlink()
    return [p for p, _ in pairs]


def json_float(x) -> float | None:
    """A float for JSON: NaN and infinities become ``None`` (JSON has no NaN)."""
    x = float(x)
    return x if math.isfinite(x) else None


def jsonable(obj: Any) -> Any:
    """Numpy scalars and arrays, tuples and NaN turned into JSON-ready values (NaN, inf -> None)."""
    if isinstance(obj, Mapping):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if type(obj).__module__ == "numpy":  # an array or a scalar: told by its module, so that numpy is not loaded
        # here for the commands that compute nothing (iwp rig list)
        return jsonable(obj.tolist())
    if isinstance(obj, bool):
        return obj
    if isinstance(obj, int):
        return int(obj)
    if isinstance(obj, float):
        return json_float(obj)
    return obj
