"""How iwp compiles: one place for numba's options.

Every compiled function of iwp is decorated with :func:`jit`, so that the
fast-math flags and the on-disk cache are the same everywhere.

Fast math
    :data:`FASTMATH` allows contraction and reassociation but keeps NaN and
    inf with their IEEE meaning, so that a diverging simulation is still
    detected. :data:`FASTMATH_EXACT` also forbids reassociation, for code
    whose rounding is part of the algorithm (the sine and cosine of
    :mod:`iwp.models.mathfn`).

The on-disk cache follows the source it compiled
    numba stamps a cached function with the hash of its own source file
    only, but iwp's kernels inline the right-hand sides, laws and step
    logic of other modules: after an edit of :mod:`iwp.models.equations`
    the kernel of :mod:`iwp.sim.engine` would be loaded stale. Functions of
    iwp are therefore cached by :class:`SourceTreeLocator`, whose stamp is
    the hash of every iwp source file that holds compiled code
    (:func:`compiled_sources`) and of this module (the compile options):
    an edit of any of them recompiles every kernel, never a stale one.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from numba import njit
from numba.core import caching

#: LLVM fast-math flags of iwp's compiled code: contraction and
#: reassociation, NaN and inf kept.
FASTMATH = {"contract", "reassoc", "nsz", "arcp"}
#: The same without reassociation (code whose rounding order matters).
FASTMATH_EXACT = {"contract", "nsz", "arcp"}


def jit(func=None, *, inline: bool = False, parallel: bool = False, exact: bool = False, vector: bool = False):
    """``numba.njit`` with iwp's options: cached on disk, fast math, the GIL released.

    Every kernel releases the GIL while it runs, so that simulations run
    side by side on threads (:func:`iwp.threads.thread_map`).

    Parameters
    ----------
    inline : bool
        Inline into every caller at numba's IR level (``inline="always"``):
        for small functions in the hot loop of the integrator, where a call
        would cost reference counting of its array arguments.
    parallel : bool
        Compile ``prange`` loops for all cores.
    exact : bool
        Use :data:`FASTMATH_EXACT`.
    vector : bool
        numpy's error model: a division by zero gives inf or NaN instead of
        raising, so that loops with divisions vectorise (the lanes of
        :mod:`iwp.sim.lanes`; their results are checked as values, not
        trapped).
    """
    opts = {"cache": True, "nogil": True, "fastmath": FASTMATH_EXACT if exact else FASTMATH}
    if inline:
        opts["inline"] = "always"
    if parallel:
        opts["parallel"] = True
    if vector:
        opts["error_model"] = "numpy"
    if func is None:
        return njit(**opts)
    return njit(**opts)(func)


# --------------------------------------------------------------------------
# the cache follows the sources
# --------------------------------------------------------------------------
_PACKAGE = Path(__file__).resolve().parent
#: text that marks a source file holding compiled code, or constants compiled into it (a module whose values the
#: kernels read, such as the packed layout, says ``compiled-constants`` in a comment)
_MARKERS = ("@jit", "@njit", "@overload", "@intrinsic", "@register_model", "compiled-constants")
_STAMP: dict[str, str] = {}


def compiled_sources(root: str | os.PathLike = _PACKAGE) -> list[Path]:
    """The source files under ``root`` that hold compiled code (sorted)."""
    out = []
    for p in sorted(Path(root).rglob("*.py")):
        try:
            text = p.read_text(encoding="utf-8")
        except OSError:
            continue
        if any(m in text for m in _MARKERS):
            out.append(p)
    return out


def source_tree_stamp(root: str | os.PathLike = _PACKAGE) -> str:
    """SHA-256 of the contents of :func:`compiled_sources` (with their paths relative to ``root``) and of this
    module, whose options (:func:`jit`) every kernel is compiled with: numba's cache index does not hold them."""
    h = hashlib.sha256(Path(__file__).read_bytes())
    for p in compiled_sources(root):
        h.update(str(p.relative_to(root)).encode())
        h.update(b"\0")
        h.update(p.read_bytes())
    return h.hexdigest()


class _TreeStamp:
    """Mixin: the source stamp is the hash of iwp's compiled sources, computed once per process."""

    def get_source_stamp(self):
        key = str(_PACKAGE)
        if key not in _STAMP:
            _STAMP[key] = source_tree_stamp(_PACKAGE)
        return _STAMP[key]

    @classmethod
    def from_function(cls, py_func, py_file):
        try:
            inside = Path(py_file).resolve().is_relative_to(_PACKAGE)
        except (OSError, ValueError):
            inside = False
        if not inside:
            return None
        return super().from_function(py_func, py_file)


class SourceTreeLocator(_TreeStamp, caching.InTreeCacheLocator):
    """numba's in-tree cache locator (``__pycache__`` beside the source), stamped by the whole source tree."""


class UserDirSourceTreeLocator(_TreeStamp, caching.UserProvidedCacheLocator):
    """The same in ``NUMBA_CACHE_DIR`` when it is set."""


def _install_locators() -> None:
    classes = caching.CacheImpl._locator_classes
    for cls in (SourceTreeLocator, UserDirSourceTreeLocator):
        if cls not in classes:
            classes.insert(0, cls)


_install_locators()
