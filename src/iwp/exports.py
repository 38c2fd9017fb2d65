"""A package's public names loaded on first use (PEP 562), so that importing it stays cheap.

``iwp``, ``iwp.models`` and ``iwp.rig`` list their public names and the
modules that define them; a name is imported when first read, then kept in
the package. ``iwp --help`` and ``iwp rig list`` so start without the
numerical libraries.
"""

from __future__ import annotations

import importlib
import sys
from typing import Callable

__all__ = ["lazy_exports"]


def lazy_exports(package: str, exports: dict[str, str]) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of ``package`` whose public names ``exports`` maps to modules.

    Parameters
    ----------
    package : str
        The package's name (its ``__name__``).
    exports : dict of str to str
        Public name -> the module that defines it.

    Returns
    -------
    getattr : callable
        ``getattr(name)``: the name imported from its module and kept in the package; ``AttributeError`` for a
        name the package does not export.
    dir : callable
        ``dir()``: the package's names, loaded or not.
    """

    def module_getattr(name: str) -> object:
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        setattr(sys.modules[package], name, value)
        return value

    def module_dir() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(exports))

    return module_getattr, module_dir
