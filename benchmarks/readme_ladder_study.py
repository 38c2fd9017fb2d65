"""The README's short logs through ``iwp fit``'s default ladder, over seeds of sensor noise (issue 39).

As a user following the README does, on the built-in virtual rig: a 20 s
full chirp to train and a 15 s chirp of amplitude 40 held out, each with
1 mrad of position noise of its own seed (``iwp rig run ... --noise 0.001
--seed S``), then ``iwp fit chirp.csv --validate heldout.csv`` with the
default ladder. Reported per seed: the structure chosen, the held-out fit
of each rung (the lower of q1 and q4), and the time. The twin has the
wheel's Coulomb friction (``sigma_c2``) and no pendulum Coulomb friction,
widths or input offset, so ``9`` and ``coulomb`` are the structures without
a term the twin lacks.

    python benchmarks/readme_ladder_study.py [--seeds 10] [--work DIR]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

#: the ladder's structures that hold no term the virtual rig's truth lacks
TWIN_HAS = ("9", "coulomb")


def iwp(*args: str) -> None:
    r = subprocess.run([sys.executable, "-m", "iwp", *args], capture_output=True, text=True)
    if r.returncode not in (0, 1):  # 1: a fit that predicts poorly (--accept-poor not given) still writes fit.json
        raise SystemExit(f"iwp {' '.join(args)}: exit {r.returncode}\n{r.stderr[-2000:]}")


def one_seed(work: Path, seed: int) -> dict:
    d = work / f"seed{seed}"
    d.mkdir(parents=True, exist_ok=True)
    iwp("rig", "run", "full-chirp", "--duration", "20", "--seed", str(100 + seed), "--noise", "0.001",
        "--out", str(d / "chirp.csv"), "--force")
    iwp("rig", "run", "full-chirp", "--duration", "15", "--amplitude", "40", "--seed", str(200 + seed),
        "--noise", "0.001", "--out", str(d / "heldout.csv"), "--force")
    iwp("fit", str(d / "chirp.csv"), "--validate", str(d / "heldout.csv"), "--out", str(d / "fit"), "--force")
    fit = json.loads((d / "fit" / "fit.json").read_text())
    s = fit["structures"]
    return {"seed": seed, "chosen": s["chosen"], "elapsed_s": fit["elapsed_s"],
            "fits": {r["name"]: min(r["fit"].values()) for r in s["rungs"] if r.get("fit")}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--work", type=Path, default=None, help="folder for the logs and fits (default: a temporary one)")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = a.work or Path(tmp)
        rows = [one_seed(work, s) for s in range(a.seeds)]
    names = list(rows[0]["fits"])
    print("| seed | chosen | " + " | ".join(f"held-out fit, {n}" for n in names) + " | time [s] |")
    print("|---:|---|" + "---:|" * len(names) + "---:|")
    for r in rows:
        print(f"| {r['seed']} | {r['chosen']} | " + " | ".join(f"{r['fits'].get(n, float('nan')):.1f} %"
                                                           for n in names) + f" | {r['elapsed_s']:.0f} |")
    ok = sum(r["chosen"] in TWIN_HAS for r in rows)
    print(f"\nno term the twin lacks chosen in {ok} of {len(rows)} seeds; chosen: "
          + ", ".join(f"{n} {sum(r['chosen'] == n for r in rows)}" for n in names if any(r['chosen'] == n for r in rows)))


if __name__ == "__main__":
    main()
