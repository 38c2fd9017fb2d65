"""Run every benchmark in this folder and write BENCHMARKS.md.

Each ``bench_*.py`` prints Markdown; timings inside one script are compared
as ratios against a baseline measured in the same run. Usage::

    python benchmarks/run.py            # all benchmarks, rewrite BENCHMARKS.md
    python benchmarks/run.py simulate   # only bench_simulate.py
"""

from __future__ import annotations

import datetime
import os
import platform
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main(argv: list[str]) -> int:
    names = sorted(p for p in HERE.glob("bench_*.py"))
    if argv:
        names = [p for p in names if any(a in p.stem for a in argv)]
    parts = [
        "# Benchmarks\n",
        f"Measured {datetime.date.today().isoformat()} on {platform.processor() or platform.machine()}, "
        f"{os.cpu_count()} cores, Python {platform.python_version()}. "
        "Produced by `python benchmarks/run.py`; each section is the output of one script.\n",
    ]
    status = 0
    for p in names:
        print(f"running {p.name} ...", flush=True)
        r = subprocess.run([sys.executable, str(p)], capture_output=True, text=True)
        if r.returncode != 0:
            status = 1
            parts.append(f"\n# {p.stem}\n\nFAILED (exit {r.returncode}):\n\n```\n{r.stderr[-2000:]}\n```\n")
        else:
            parts.append(f"\n# {p.stem}\n\n{r.stdout}\n")
    history = HERE / "history.md"
    if history.exists():
        parts.append(history.read_text())
    if not argv:
        (HERE.parent / "BENCHMARKS.md").write_text("".join(parts))
        print("wrote BENCHMARKS.md")
    else:
        print("".join(parts))
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
