"""``iwp fit --fix NAME=VALUE``: a parameter known from elsewhere is held in every structure fitted."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from iwp.cli import main
from iwp.errors import InputError
from iwp.ident.logfit import LogFitOptions

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from ladder_study import BASE, logs  # noqa: E402  (the ladder study's virtual direct-drive rig)


def test_fixed_parameters_are_held_and_the_rest_recovered(tmp_path, capsys):
    rig, train, held, _ = logs(BASE, 2, tmp_path, duration=20.0, n_train=2, n_held=2)
    (tmp_path / "rig.json").write_text(json.dumps(rig.to_dict()))
    out = tmp_path / "fit"
    code = main(["fit", *map(str, train), "--rig", str(tmp_path / "rig.json"), "--validate", *map(str, held),
                 "--model", "9", "--fix", "rho=30", "--fix", "sigma_b1=1e-4", "--out", str(out)])
    printed = capsys.readouterr().out
    assert code == 0
    fit = json.loads((out / "fit.json").read_text())
    assert fit["options"]["fixed"] == {"rho": 30.0, "sigma_b1": 1e-4}
    assert "rho" not in fit["free"] and "sigma_b1" not in fit["free"]
    assert fit["parameters"]["rho"]["fixed"] is True and fit["parameters"]["rho"]["value"] == 30.0
    assert fit["lumped"]["sigma_b1"] == 1e-4
    assert "  rho " not in printed  # the summary lists the free parameters
    for name in ("p1", "p2", "p3"):  # held at the truth, the others come back as well
        assert fit["parameters"][name]["value"] == pytest.approx(getattr(BASE, name), rel=0.01), name


@pytest.mark.parametrize("fixed, message", [({"foo": 1.0}, "'foo' is not a lumped parameter"),
                                            ({"rho": -1.0}, "rho = -1.0 is not a physical value"),
                                            ({"k_over_I2": 60.0}, "'k_over_I2' is not a lumped parameter"),
                                            ({"p1": "x"}, "p1 = 'x' is not a number")])
def test_a_fixed_value_is_checked(fixed, message):
    with pytest.raises(InputError, match=message):
        LogFitOptions(fixed=fixed)


def test_fix_without_a_value_is_one_line(tmp_path, capsys):
    assert main(["fit", "a.csv", "--out", str(tmp_path / "o"), "--fix", "rho"]) == 2
    assert capsys.readouterr().err.strip() == "iwp: error: --fix rho: give NAME=VALUE, e.g. --fix rho=247.2"
