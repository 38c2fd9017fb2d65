"""The README's command-line examples work as written, run in order in an empty folder.

The block marked ``<!-- readme-sequence ... -->`` is split into commands
(shell comments dropped, ``*`` expanded in the folder as a shell would) and
each command runs through ``iwp.cli.main``, in one process so that the
sequence stays fast; each must exit 0, and the numbers they print and write
are checked against what the virtual rig's truth and the paper give.
"""

from __future__ import annotations

import glob
import json
import re
import shlex
from pathlib import Path

import numpy as np
import pytest

from iwp.cli import main
from iwp.data import read_experiment
from iwp.rig import default_truth

README = Path(__file__).resolve().parents[1] / "README.md"
MARK = "<!-- readme-sequence"


def sequence_blocks(text: str) -> list[list[str]]:
    """The commands of every block that follows a ``readme-sequence`` mark, one list per block."""
    blocks = []
    for m in re.finditer(re.escape(MARK) + r"[^\n]*-->\n```(?:bash|sh|console)\n(.*?)```", text, re.S):
        lines = [line for line in m.group(1).splitlines() if line.strip() and not line.lstrip().startswith("#")]
        blocks.append(lines)
    return blocks


def argv_of(line: str, folder: Path) -> list[str]:
    words = shlex.split(line, comments=True)
    assert words and words[0] == "iwp", f"a sequence line must be an iwp command: {line!r}"
    argv = []
    for w in words[1:]:
        if any(c in w for c in "*?["):
            found = sorted(glob.glob(w, root_dir=folder))
            argv += found if found else [w]  # bash leaves an unmatched pattern as it is
        else:
            argv.append(w)
    return argv


def test_blocks_are_found():
    blocks = sequence_blocks(README.read_text())
    assert len(blocks) == 1
    assert len(blocks[0]) >= 15
    assert argv_of("iwp fit c*.csv --out f/  # a comment", Path(".")) == ["fit", "c*.csv", "--out", "f/"]


#: the packages of the optional extras (pyproject.toml), by import name: the sequence must run without them (pillow,
#: in the anim extra, comes with matplotlib)
EXTRAS_ONLY = ("control", "gymnasium", "dask", "distributed", "bokeh", "websocket", "hypothesis", "xdist")


class _ExtrasBlocked:
    """A meta-path finder that refuses the extras' packages, as a plain ``pip install .`` lacks them."""

    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in EXTRAS_ONLY:
            raise ModuleNotFoundError(f"No module named {name!r} (an extra, not in a plain pip install .)", name=name)
        return None


@pytest.fixture
def base_install_only(monkeypatch):
    """The extras' packages unimportable for the test (those imported before are taken out of sys.modules and put
    back afterwards), so that the README's sequence runs as after ``pip install .`` alone (issue 51)."""
    import sys

    for mod in [m for m in sys.modules if m.split(".")[0] in EXTRAS_ONLY]:
        monkeypatch.delitem(sys.modules, mod)
    monkeypatch.setattr(sys, "meta_path", [_ExtrasBlocked(), *sys.meta_path])


def test_the_extras_are_blocked(base_install_only):
    with pytest.raises(ModuleNotFoundError, match="an extra"):
        import control  # noqa: F401


@pytest.mark.slow
def test_readme_sequence_runs_in_order(tmp_path, monkeypatch, capsys, base_install_only):
    monkeypatch.chdir(tmp_path)
    printed = {}
    for line in sequence_blocks(README.read_text())[0]:
        argv = argv_of(line, tmp_path)
        status = main(argv)
        out, err = capsys.readouterr()
        assert status == 0, f"{line}\n{err}"
        printed[" ".join(argv[:2])] = out
    # what the sequence wrote, checked against the truth it came from
    assert {"chirp.csv", "heldout.csv", "free.csv", "static.csv", "P.json", "hopf.csv", "sim.csv", "raw.csv",
            "chirp.parquet", "sine.csv", "hopf-rig.csv"} <= {p.name for p in tmp_path.iterdir()}
    assert (tmp_path / "fit" / "parameters.json").is_file() and (tmp_path / "mine" / "report.html").is_file()
    chirp, parquet = read_experiment(tmp_path / "chirp.csv"), read_experiment(tmp_path / "chirp.parquet")
    np.testing.assert_array_equal(chirp.q1, parquet.q1)
    # the free pendulum with the wheel held: p1 rho/(1 + rho) of the twin's truth, and its p1 of model (9)
    truth = default_truth().lumped
    free = json.loads(printed["identify free.csv"])
    assert free["parameters"]["p1"]["value"] == pytest.approx(truth.p1 * truth.rho / (1 + truth.rho), rel=1e-3)
    assert free["details"]["p1_of_model_9"] == pytest.approx(truth.p1, rel=2e-3)
    # the Hopf law k1 = -10, k2 = 0.1 oscillates at the paper's 2.58 rad, so the design returns k1 close to -10
    k1 = float(re.search(r"k1\s*=\s*(-?[\d.]+)", printed["design hopf"]).group(1))
    assert k1 == pytest.approx(-10.0, abs=0.3)
    hopf = read_experiment(tmp_path / "hopf.csv")
    assert np.abs(hopf.q1[hopf.t > 150]).max() == pytest.approx(2.58, rel=0.02)
    # the full set-up on a 20 s chirp: p1 and p3 within 1 % of the twin's truth; the pendulum friction the swing
    # cannot identify is held at its prior (Table 1), never negative as the unconstrained (13) gives it
    P = json.loads((tmp_path / "P.json").read_text())
    ident = P["identification"]
    held = ident["details"]["held"]
    assert {"sigma_a1", "sigma_v1"} <= set(held)
    for name in ("sigma_a1", "sigma_v1", "sigma_b1"):
        assert ident["parameters"][name]["value"] >= 0.0
        # admissible or held: no 95 % interval reaching into negative friction (sigma_b1 = 0.066 [-0.158, 0.291]
        # was printed before it was held)
        lo = ident["parameters"][name]["ci95"][0]
        assert (name in held and lo is None) or lo >= 0.0, name
    assert ident["parameters"]["p1"]["value"] == pytest.approx(truth.p1, rel=0.01)
    assert "held at its prior" in printed["identify chirp.csv"]
    # ... which predicts the held-out chirp's pendulum angle and wheel speed above 80 % (88.5 %, 92.2 % when written)
    fits = {s: float(v) for s, v in re.findall(r"(q[14]): fit (-?[\d.]+) %", printed["validate heldout.csv"])}
    assert set(fits) == {"q1", "q4"} and min(fits.values()) > 80.0
    # model (9) fitted on chirp.csv by simulation error on q1 and the wheel speed: p1 within 0.5 % of the truth and
    # the held-out chirp predicted above 85 % on both (88.1 %, 92.7 % when written; the twin is richer than (9))
    fit = json.loads((tmp_path / "fit" / "fit.json").read_text())
    assert fit["outputs"] == ["q1", "q4"]
    assert fit["parameters"]["p1"]["value"] == pytest.approx(truth.p1, rel=0.005)
    assert min(fit["validation_fit"].values()) > 85.0
    # its 95 % prediction band either holds (80 % of each judged signal inside) or the fit says it does not: the twin's
    # belt and dead zone, which model (9) lacks, leave the held-out q1 outside (60 % inside when written), and one
    # training log cannot check the structure
    (held_out,) = fit["validation"]
    inside = {o: held_out["band_coverage"][o] for o in ("q1", "q4")}
    if min(inside.values()) >= 0.8:
        assert fit["band_holds"] is True and held_out["band_holds"] is True
    else:
        assert fit["band_holds"] is False and held_out["band_holds"] is False
        assert any("lie inside the 95 % prediction band" in w and "the band does not hold on this log" in w
                   for w in fit["warnings"])
        assert "(the band does not hold for q" in printed["fit chirp.csv"]
    assert inside["q1"] < 0.8 and fit["band_holds"] is False  # what the sequence shows today (q1 60 %)
