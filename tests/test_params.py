import json
import math

import pytest

from iwp.errors import InputError, OutputExistsError
from iwp.models import BeltParameters, load_params, save_params, table1
from tests.helpers import physical


def test_table1_values():
    p = table1()
    assert (p.p1, p.p2, p.p3, p.rho) == (26.0950, 0.0106, 0.0286, 247.24)
    assert (p.sigma_a1, p.sigma_b1, p.sigma_v1) == (0.0030, 0.0005, 0.01)
    assert p.v_dz_pos == p.v_dz_neg == 31.0
    assert p.natural_frequency == pytest.approx(math.sqrt(26.095))


def test_physical_to_lumped_mapping():
    ph = physical()
    lp = ph.to_lumped()
    I1h = 2e-3 + 0.2 * 0.12**2 + 0.3 * 0.25**2
    assert ph.I1_hat == pytest.approx(I1h)
    assert lp.p1 == pytest.approx((0.2 * 0.12 + 0.3 * 0.25) * 9.81 / I1h)
    assert lp.p2 == pytest.approx((13.5**2 * 0.02 * 0.02 / 5.0 + 1e-6) / I1h)
    assert lp.p3 == pytest.approx(0.12 * 13.5 * 0.02 / (I1h * 5.0))
    assert lp.rho == pytest.approx(I1h / 4e-5)
    assert lp.sigma_a1 == pytest.approx(0.01 * 0.5 * 9.81 * 0.004 / I1h)
    assert lp.sigma_b1 == pytest.approx(0.01 * (0.2 * 0.12 + 0.3 * 0.25) * 0.004 / I1h)
    assert lp.v_dz_pos == pytest.approx(3.7 / 0.12)
    assert lp.sigma_c2 == pytest.approx(2e-4 / I1h)


def test_json_round_trip(tmp_path):
    for params in (table1(), physical(), BeltParameters()):
        path = save_params(params, tmp_path / f"{type(params).__name__}.json")
        assert load_params(path) == params
    with pytest.raises(OutputExistsError, match="exists"):
        save_params(table1(), tmp_path / "LumpedParameters.json")
    save_params(table1().replace(p1=30.0), tmp_path / "LumpedParameters.json", force=True)
    assert load_params(tmp_path / "LumpedParameters.json").p1 == 30.0


def test_flat_json_and_builtin_name(tmp_path):
    path = tmp_path / "flat.json"
    path.write_text(json.dumps(table1().to_dict()))
    assert load_params(path) == table1()
    assert load_params("table1") == table1()


@pytest.mark.parametrize(
    "field,value,match",
    [
        ("p1", "NaN", "p1.*finite"),
        ("sigma_v1", -0.1, "sigma_v1.*>= 0"),
        ("p3", 0.0, "p3.*> 0"),
        ("rho", -1.0, "rho.*> 0"),
        ("p2", "text", "p2.*number"),
    ],
)
def test_load_rejects_bad_values(tmp_path, field, value, match):
    d = table1().to_dict()
    d[field] = float("nan") if value == "NaN" else value
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(d))
    with pytest.raises(InputError, match=f"bad.json.*{match}"):
        load_params(path)


def test_load_rejects_unknown_and_missing(tmp_path):
    d = table1().to_dict()
    d["p9"] = 1.0
    (tmp_path / "u.json").write_text(json.dumps(d))
    with pytest.raises(InputError, match="unknown parameter 'p9'"):
        load_params(tmp_path / "u.json")
    d = table1().to_dict()
    del d["p1"]
    (tmp_path / "m.json").write_text(json.dumps(d))
    with pytest.raises(InputError, match="missing parameter 'p1'"):
        load_params(tmp_path / "m.json")
    (tmp_path / "x.json").write_text("{not json")
    with pytest.raises(InputError, match="x.json: not valid JSON"):
        load_params(tmp_path / "x.json")
    with pytest.raises(InputError, match="no such parameter file"):
        load_params(tmp_path / "absent.json")


def test_unconstrained_fit_may_be_negative_but_not_physical():
    p = table1().replace(sigma_a1=-2.79)  # the paper's eq. (16) has a negative friction
    with pytest.raises(InputError, match="sigma_a1"):
        p.check_physical()
    with pytest.raises(InputError, match="finite"):
        table1().replace(p1=float("inf"))


def test_belt_from_rigid_limit():
    b = BeltParameters.from_rigid(2.2, 7.0, k_over_I2=60.0, d=2.0, b2_over_I2=0.5)
    assert b.rigid_p2rho == pytest.approx(2.2)
    assert b.rigid_p3rho == pytest.approx(7.0)
    with pytest.raises(InputError, match="b2_over_I2"):
        BeltParameters.from_rigid(2.2, 7.0, k_over_I2=60.0, d=2.0, b2_over_I2=10.0)


def test_unconstrained_fit_file_loads_with_a_warning(tmp_path):
    d = table1().replace(sigma_a1=-2.7905).to_dict()  # the paper's eq. (16)
    path = tmp_path / "fit.json"
    path.write_text(json.dumps({"kind": "lumped", "parameters": d, "unconstrained_fit": True}))
    with pytest.warns(UserWarning, match="fit.json: unconstrained fit.*sigma_a1"):
        p = load_params(path)
    assert p.sigma_a1 == -2.7905
    path.write_text(json.dumps({"kind": "lumped", "parameters": d}))  # no declaration: refused
    with pytest.raises(InputError, match="sigma_a1"):
        load_params(path)
