"""pytest's root configuration (tests/ and docs/test_code_blocks.py): numba's caches outside the source tree, and
the ``realtime`` marker on the tests that keep wall-clock deadlines.

numba writes a kernel's cache beside its source (``src/iwp/*/__pycache__``) unless ``NUMBA_CACHE_DIR`` is set,
and a wheel built after a test run would pack those caches too (setup.py now builds its own, but a clean source
tree is the rule). Tests, and the commands they start, cache in the user's cache folder instead; a value set
by the caller wins.
"""

import os
from pathlib import Path

import pytest

os.environ.setdefault(
    "NUMBA_CACHE_DIR", str(Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "iwp" / "numba"))


#: Test files whose tests keep wall-clock deadlines (a device's watchdog, a real-time loop, signals sent into a
#: running command, a browser's refresh rate): marked ``realtime``. The README's test command runs the others on
#: two processes (pytest-xdist) and these alone afterwards, so that no other test takes their cores meanwhile.
REALTIME_FILES = ("test_device.py", "test_firmware.py", "test_live.py", "test_live_browser.py", "test_outputs.py",
                  "test_pins.py", "test_sweep.py", "test_threads.py")


def pytest_configure(config):
    config.addinivalue_line("markers", "realtime: keeps wall-clock deadlines; run alone (conftest.REALTIME_FILES)")
    config.addinivalue_line("markers", "no_deadline: in a file of REALTIME_FILES, keeps no wall-clock deadline (runs "
                                       "with the others; checked passing beside two processes that take both cores)")
    if config.pluginmanager.hasplugin("xdist") and config.getoption("numprocesses", None) \
            and not hasattr(config, "workerinput"):
        # pytest-xdist's controller, before its workers start: iwp's kernels compiled once, in parallel processes
        # (iwp warmup, one per core), not by each worker as it meets them (a cold cache cost the first phase
        # 173 s, 306 -> 479 s)
        from iwp.warmup import warmup

        warmup()


def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.path.name in REALTIME_FILES and item.get_closest_marker("no_deadline") is None:
            item.add_marker(pytest.mark.realtime)
