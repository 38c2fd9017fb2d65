"""A sweep's folder on disk: chunk files, the manifest, the results table (:class:`SweepStore`).

Layout of ``OUT/``::

    manifest.json          the spec, the seeds, the chunks done, the runs that wrote them
    chunks/chunk-000000.csv  one file per chunk, written when the chunk is done
    results.csv            every chunk's rows in lane order, once all are done
    (results.parquet       with format="parquet")

Every file is written through a temporary file and renamed (never half
written). A chunk file on disk is a finished chunk: a run that was killed
resumes from the chunk files and computes only the missing chunks. A chunk
file that is not its chunk's table (emptied, cut, edited: not the header,
lanes or numbers it must hold) is set aside as ``chunk-NNNNNN.csv.damaged``
and computed again, with a warning; a results table that is not every
lane's in order is written again from the chunks. A folder that holds
another spec's sweep, or other files, is refused unless ``force``.
"""

from __future__ import annotations

import csv
import datetime
import hashlib
import json
import re
import warnings
from pathlib import Path

import numpy as np

from .. import __version__
from ..errors import DataFormatError, InputError, OutputExistsError
from ..files import atomic_write, check_output_dir, jsonable, read_json
from .chunk import ChunkResult, column_names
from .spec import SweepSpec

__all__ = ["SweepStore", "RESULT_FORMATS", "MANIFEST", "INT_COLUMNS", "read_table"]

MANIFEST = "manifest.json"
CHUNKS = "chunks"
#: Formats of the results table.
RESULT_FORMATS = ("csv", "parquet")
_FORMAT = "iwp sweep 1"
_CHUNK_RE = re.compile(r"^chunk-(\d{6,})\.csv$")


def _chunk_name(index: int) -> str:
    return f"chunk-{index:06d}.csv"


def _spec_record(spec: SweepSpec) -> dict:
    """The spec as it reads back from JSON (so that a resumed run compares equal)."""
    return json.loads(json.dumps(jsonable(spec.to_dict())))


def _write_csv(path: Path, columns: dict) -> None:
    names = list(columns)
    cols = [np.asarray(columns[n]) for n in names]
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(names)
        for row in zip(*(c.tolist() for c in cols)):
            w.writerow([repr(v) if isinstance(v, float) else v for v in row])


#: Columns of whole numbers in a sweep's table (the others are floats).
INT_COLUMNS = ("lane", "status", "rotating", "captured", "nfev")


def read_table(path) -> dict[str, np.ndarray]:
    """A sweep's CSV table (a chunk file or ``results.csv``) as columns; lane, status, flags and counts as integers.

    Parameters
    ----------
    path : str or path-like
        The CSV file, with a header line.

    Returns
    -------
    dict of str to ndarray, shape (n,)
        Each column by its header name; float, or int64 for :data:`INT_COLUMNS`.

    Raises
    ------
    DataFormatError
        An empty file, a body that is not numbers, or rows of another width than the header.
    """
    p = Path(path)
    with open(p, encoding="utf-8") as f:
        names = f.readline().strip().split(",")
    if names == [""]:
        raise DataFormatError(f"{p}: empty table")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # an empty body is a table of no rows
            data = np.loadtxt(p, delimiter=",", skiprows=1, ndmin=2, dtype=float)
    except ValueError as exc:
        # numpy's message, without its advice on its own arguments
        why = str(exc).split(";")[0].strip().rstrip(".")
        raise DataFormatError(f"{p}: not a sweep table ({why})") from None
    if data.size == 0:
        data = np.zeros((0, len(names)))
    if data.shape[1] != len(names):
        raise DataFormatError(f"{p}: {data.shape[1]} columns under a header of {len(names)}")
    return {n: data[:, j].astype(np.int64) if n in INT_COLUMNS else data[:, j] for j, n in enumerate(names)}


def _table_problem(read, names: list[str], lanes: range, what: str) -> str | None:
    """Why the table ``read()`` returns is not the one with header ``names`` and one row per lane of ``lanes`` in
    order (``what`` names those lanes in the answer), or None."""
    try:
        tab = read()
    except (DataFormatError, OSError, UnicodeDecodeError, ValueError) as exc:
        return str(exc).split(": ", 1)[-1]
    if list(tab) != names:
        return "its header is not the sweep's columns"
    if not np.array_equal(tab["lane"], np.arange(lanes.start, lanes.stop)):
        return f"{tab['lane'].size} rows where {what} are {len(lanes)}"
    return None


def _sha256(path: Path) -> str:
    """The SHA-256 of a file's bytes (hex)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


class SweepStore:
    """The output folder of one sweep.

    Parameters
    ----------
    out : str or Path
        The folder: new, empty, or holding a sweep of the same spec (then it resumes).
    spec : SweepSpec
    force : bool
        Start afresh, in a folder that holds this sweep (no resuming), another
        sweep or other files (the sweep's own files are replaced; nothing else
        is removed).
    """

    def __init__(self, out, spec: SweepSpec, *, force: bool = False):
        self.path = Path(out)
        self.spec = spec
        record = _spec_record(spec)
        manifest = self.path / MANIFEST
        resumable = False
        if self.path.is_dir() and manifest.is_file():
            try:
                old = read_json(manifest, argument="out")
            except InputError:
                old = None
            same = isinstance(old, dict) and old.get("format") == _FORMAT and old.get("spec") == record
            resumable = same and not force  # --force: start afresh, even on the same sweep
            if not same and not force:
                raise OutputExistsError(f"out {self.path}: holds a sweep of another spec (or an unreadable "
                                        "manifest.json); pass --force to replace it, or choose another folder")
        if not resumable:
            check_output_dir(self.path, force=force, argument="out")
        self.resumable = resumable
        self.created = not self.path.exists()  # a failed fresh start removes what it made, not the user's folder
        #: each chunk file's SHA-256 as this sweep wrote it (the manifest keeps them): a file edited since differs
        self.hashes: dict[str, str] = {}
        if resumable and isinstance(old.get("hashes"), dict):
            self.hashes = {str(k): str(v) for k, v in old["hashes"].items()}
        #: chunk files found on disk that are not their chunk's table: index -> why (set aside by :meth:`open`)
        self.damaged: dict[int, str] = self._damaged_chunks() if resumable else {}
        self.runs: list = list(old.get("runs", [])) if resumable and isinstance(old.get("runs"), list) else []
        self.opened = False
        #: the results table last read, with the file's (format, mtime_ns, size) it was read from
        self._results: tuple[tuple, dict[str, np.ndarray]] | None = None

    def open(self) -> None:
        """Create the folder (a fresh start: remove this sweep's own earlier files; a resumed one: set its damaged
        chunk files aside, with a warning); the checks were made before."""
        if not self.resumable:
            self._clear()
        self.path.mkdir(parents=True, exist_ok=True)
        (self.path / CHUNKS).mkdir(exist_ok=True)
        for i, why in sorted(self.damaged.items()):
            p = self.path / CHUNKS / _chunk_name(i)
            p.replace(p.with_name(p.name + ".damaged"))
            warnings.warn(f"out {self.path}: {CHUNKS}/{p.name} is not the table of its chunk ({why}); it is set "
                          f"aside as {p.name}.damaged and the chunk computed again", UserWarning, stacklevel=3)
        self.damaged = {}
        self.opened = True

    def discard(self) -> None:
        """Remove what :meth:`open` made for a fresh start that computed nothing (a failure, an interrupt before
        the first chunk): the manifest, the empty chunks folder, the folder if this sweep made it."""
        if self.resumable:
            return
        manifest = self.path / MANIFEST
        if manifest.is_file():
            manifest.unlink()
        chunks = self.path / CHUNKS
        if chunks.is_dir() and not any(chunks.iterdir()):
            chunks.rmdir()
        if self.created and self.path.is_dir() and not any(self.path.iterdir()):
            self.path.rmdir()

    def _damaged_chunks(self) -> dict[int, str]:
        """The chunk files on disk that are not their chunk's table, with why (read only)."""
        names = column_names(self.spec)
        out = {}
        for i in sorted(self._chunk_files()):
            lanes = self.spec.chunk_range(i)
            path = self.path / CHUNKS / _chunk_name(i)
            why = _table_problem(lambda: read_table(path), names, lanes, f"its lanes {lanes.start}..{lanes.stop - 1}")
            recorded = self.hashes.get(str(i))
            if why is None and recorded is not None and _sha256(path) != recorded:
                why = "its numbers differ from those this sweep wrote (SHA-256 recorded in manifest.json)"
            if why is not None:
                out[i] = why
        return out

    def _chunk_files(self) -> set[int]:
        chunks = self.path / CHUNKS
        if not chunks.is_dir():
            return set()
        out = set()
        for p in chunks.iterdir():
            m = _CHUNK_RE.match(p.name)
            if m and int(m.group(1)) < self.spec.n_chunks:
                out.add(int(m.group(1)))
        return out

    def _clear(self) -> None:
        """Remove this sweep's own files (a --force restart)."""
        for name in [MANIFEST] + [f"results.{f}" for f in RESULT_FORMATS]:
            p = self.path / name
            if p.is_file():
                p.unlink()
        chunks = self.path / CHUNKS
        if chunks.is_dir():
            for p in chunks.iterdir():
                if _CHUNK_RE.match(p.name) and p.is_file():
                    p.unlink()

    # ---------------------------------------------------------------- chunks
    def done(self) -> set[int]:
        """Indices of the chunks on disk (a chunk file is written whole or not at all), less the damaged ones."""
        return self._chunk_files() - set(self.damaged)

    def missing(self) -> list[int]:
        """The chunks still to compute, in order."""
        have = self.done() if self.resumable or self.opened else set()
        return [i for i in range(self.spec.n_chunks) if i not in have]

    def write_chunk(self, result: ChunkResult) -> Path:
        """Write one chunk's rows (atomically), its SHA-256 kept for the manifest."""
        path = atomic_write(self.path / CHUNKS / _chunk_name(result.index),
                            lambda tmp: _write_csv(tmp, result.columns))
        self.hashes[str(result.index)] = _sha256(path)
        return path

    def read_chunk(self, index: int) -> dict[str, np.ndarray]:
        return read_table(self.path / CHUNKS / _chunk_name(index))

    # -------------------------------------------------------------- manifest
    def write_manifest(self, *, results: str | None = None, run: dict | None = None) -> Path:
        """Write ``manifest.json``: the spec, the seeds, the chunks done, the runs (atomically)."""
        if run is not None:
            self.runs.append(run)
        done = sorted(self.done())
        doc = {
            "format": _FORMAT,
            "iwp": __version__,
            "spec": _spec_record(self.spec),
            "lanes": self.spec.n_lanes,
            "chunk_size": self.spec.chunk_size,
            "chunks": self.spec.n_chunks,
            "seeds": {"seed": self.spec.seed,
                      "chunk": "numpy.random.SeedSequence(seed, spawn_key=(chunk,)): the normal and uniform "
                               "dimensions, in the order of vary",
                      "uncertainty": "numpy.random.SeedSequence(seed, spawn_key=(chunk, 1)): the draws of the "
                                     "fit's covariance"},
            "done": done,
            "hashes": {str(i): self.hashes[str(i)] for i in done if str(i) in self.hashes},
            "complete": len(done) == self.spec.n_chunks,
            "results": results,
            "updated": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "runs": self.runs,
        }
        return atomic_write(self.path / MANIFEST,
                            lambda tmp: tmp.write_text(json.dumps(jsonable(doc), indent=1) + "\n", encoding="utf-8"))

    # --------------------------------------------------------------- results
    def write_results(self, format: str = "csv") -> Path:
        """Join the chunks in lane order into ``results.csv`` or ``results.parquet`` (atomically)."""
        if format not in RESULT_FORMATS:
            raise InputError(f"format must be one of {', '.join(RESULT_FORMATS)}, got {format!r}", argument="format")
        missing = self.missing()
        if missing:
            raise InputError(f"out {self.path}: {len(missing)} chunks are not done yet")
        files = [self.path / CHUNKS / _chunk_name(i) for i in range(self.spec.n_chunks)]
        target = self.path / f"results.{format}"
        if format == "csv":
            def write(tmp: Path) -> None:
                with open(tmp, "w", encoding="utf-8", newline="") as out:
                    for k, p in enumerate(files):
                        with open(p, encoding="utf-8", newline="") as f:
                            header = f.readline()
                            if k == 0:
                                out.write(header)
                            for line in f:
                                out.write(line)
        else:
            try:
                import pyarrow as pa  # optional dependency
                import pyarrow.parquet as pq
            except ImportError:
                raise InputError("format parquet needs pyarrow: pip install 'iwp[parquet]'",
                                 argument="format") from None

            def write(tmp: Path) -> None:
                parts = [self.read_chunk(i) for i in range(self.spec.n_chunks)]
                cols = {n: np.concatenate([c[n] for c in parts]) for n in parts[0]}
                pq.write_table(pa.table(cols), tmp)
        return atomic_write(target, write)

    def results_problem(self, format: str = "csv") -> str | None:
        """Why the results table on disk is not every lane's row in order (missing, cut, edited), or None."""
        if not (self.path / f"results.{format}").is_file():
            return "there is none"
        return _table_problem(lambda: self.read_results(format), column_names(self.spec), range(self.spec.n_lanes),
                              "the sweep's lanes")

    def read_results(self, format: str = "csv") -> dict[str, np.ndarray]:
        """The results table's columns (written by :meth:`write_results`); read once while the file is unchanged
        (a finished sweep run again checks its table, then returns it)."""
        path = self.path / f"results.{format}"
        st = path.stat()
        key = (format, st.st_mtime_ns, st.st_size)
        if self._results is None or self._results[0] != key:
            if format == "csv":
                tab = read_table(path)
            else:
                import pyarrow.parquet as pq  # optional dependency (write_results checked it)

                pt = pq.read_table(path)
                tab = {n: pt.column(n).to_numpy() for n in pt.column_names}
            self._results = (key, tab)
        return dict(self._results[1])

    def table(self) -> dict[str, np.ndarray]:
        """Every done chunk's rows, in lane order."""
        parts = [self.read_chunk(i) for i in sorted(self.done())]
        if not parts:
            return {}
        return {n: np.concatenate([c[n] for c in parts]) for n in parts[0]}

