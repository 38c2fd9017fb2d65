"""pytest's root configuration (tests/ and docs/test_code_blocks.py): numba's caches outside the source tree.

numba writes a kernel's cache beside its source (``src/iwp/*/__pycache__``) unless ``NUMBA_CACHE_DIR`` is set,
and a wheel built after a test run would pack those caches too (setup.py now builds its own, but a clean source
tree is the rule). Tests, and the commands they start, cache in the user's cache folder instead; a value set
by the caller wins.
"""

import os
from pathlib import Path

os.environ.setdefault(
    "NUMBA_CACHE_DIR", str(Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "iwp" / "numba"))
