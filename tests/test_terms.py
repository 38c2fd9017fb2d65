"""One object per model term (iwp.models.terms): fields, slots, flags, rungs and fits all derive from it; the
Stribeck term, added as one Term, is recovered end to end on the virtual rig."""

from __future__ import annotations

import dataclasses
import json
import math
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from iwp.cli import build_parser, main
from iwp.errors import InputError
from iwp.ident.logfit import LogFitOptions, fit_logs
from iwp.ident.structure import RUNGS, ladder
from iwp.models import MODELS, LumpedParameters, Plant
from iwp.models.layout import LUMPED_INDEX, N_PACK, SWITCH_SLOTS
from iwp.models.terms import SWITCHES, TERMS, closure, free_parameters

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from ladder_study import BASE, logs  # noqa: E402  (the ladder study's virtual direct-drive rig)

#: a wheel whose friction rises to twice its Coulomb level at rest, over a Stribeck speed of 2 rad/s
STRIBECK_TRUTH = BASE.replace(sigma_c2=0.5, sigma_s2=0.5, v_s2=2.0)


def test_every_term_is_a_field_a_slot_a_flag_and_a_rung():
    fields = {f.name: f.default for f in dataclasses.fields(LumpedParameters)}
    slots = list(LUMPED_INDEX.values())
    assert len(set(slots)) == len(slots) and max(slots) < N_PACK
    parser = build_parser()
    for t in TERMS.values():
        for p in t.parameter_names:
            assert fields[p] == 0.0  # off by default
            assert p in LUMPED_INDEX
        args = parser.parse_args(["fit", "log.csv", "--out", "d", t.flag])
        assert getattr(args, t.name) is True
        assert t.name in RUNGS[t.rung.name].terms
        rung = RUNGS[t.rung.name]
        assert RUNGS[t.rung.extends].terms < rung.terms  # a rung extends the one it names
        freed = set(free_parameters(rung.terms)) - set(free_parameters(RUNGS[t.rung.extends].terms))
        assert freed == set(t.freed(rung.terms)) - (set(t.replacement.replaces) if t.replacement else set())
        if t.replacement is not None:  # a drive model: fitted on the model that declares that drive, its own params
            info = MODELS[t.replacement.model]
            assert info.drive == t.replacement.name == t.drive and not t.parameters
            assert set(t.replacement.free) <= set(info.parameters)
            assert not set(t.replacement.replaces) & set(t.replacement.free)
    assert [LUMPED_INDEX[n] for n in SWITCHES] == list(SWITCH_SLOTS)
    # the registry's rules: requirements joined, exclusions refused with both flags named
    assert closure({"stribeck"}) == {"stribeck", "coulomb"}
    with pytest.raises(InputError, match="--belt and --dead-zone exclude each other"):
        LogFitOptions(terms={"belt", "dead_zone"})
    with pytest.raises(InputError, match="unknown term 'cubic'"):
        LogFitOptions(terms={"cubic"})
    # the Stribeck rung is off the default ladder, on it when asked for
    assert "stribeck" not in [r.name for r in ladder(False)]
    assert [r.name for r in ladder(False, extra=("stribeck",))][-1] == "stribeck"


def test_the_stribeck_rise_follows_its_law_and_vanishes_at_speed():
    plain = BASE.replace(sigma_c2=0.5)
    p = STRIBECK_TRUTH
    for q4 in (-3.0, -0.7, 0.05, 1.0, 2.0, 6.0):
        x = np.array([0.3, 0.0, 0.2, q4])
        with_rise = Plant(p, model="compensated").rhs(x, 0.1)
        without = Plant(plain, model="compensated").rhs(x, 0.1)
        # the disk's net torque less the rise: q3' = -xi - m, q4' = xi + (1 + rho) m
        rise = p.sigma_s2 * math.exp(-(q4 / p.v_s2) ** 2) * math.tanh(q4 / 0.01)
        assert with_rise[2] - without[2] == pytest.approx(rise, rel=1e-12, abs=1e-15)
        assert with_rise[3] - without[3] == pytest.approx(-(1 + p.rho) * rise, rel=1e-12, abs=1e-15)
    # far above the Stribeck speed only Coulomb's level is left; with sigma_s2 = 0 the model is the plain one
    x = np.array([0.3, 0.0, 0.2, 20.0])
    assert Plant(p, model="compensated").rhs(x, 0.1)[3] == pytest.approx(
        Plant(plain, model="compensated").rhs(x, 0.1)[3], abs=1e-12)
    assert np.array_equal(Plant(plain.replace(v_s2=2.0), model="compensated").rhs(x, 0.1),
                          Plant(plain, model="compensated").rhs(x, 0.1))


@pytest.fixture(scope="module")
def stribeck_logs(tmp_path_factory):
    """Three 40 s chirps and eight held-out PRBS runs of the ladder study's rig with the Stribeck truth (seed 0)."""
    folder = tmp_path_factory.mktemp("stribeck")
    rig, train, held, _ = logs(STRIBECK_TRUTH, 0, folder, duration=40.0, n_held=8)
    rig_path = folder / "rig.json"
    rig_path.write_text(json.dumps(rig.to_dict()))
    return rig_path, train, held


def test_iwp_fit_terms_stribeck_recovers_the_rise(stribeck_logs, tmp_path, capsys):
    rig_path, train, held = stribeck_logs
    out = tmp_path / "fit"
    code = main(["fit", *map(str, train), "--rig", str(rig_path), "--validate", *map(str, held[:3]),
                 "--terms", "stribeck", "--accept-poor", "--out", str(out)])
    printed = capsys.readouterr().out
    assert code == 0  # (the held-out swings' q1 drifts apart from the measured state: see the next test)
    fit = json.loads((out / "fit.json").read_text())
    assert fit["options"]["stribeck"] is True and fit["options"]["coulomb"] is True
    for name in ("sigma_c2", "sigma_s2", "v_s2"):
        pe = fit["parameters"][name]
        true = getattr(STRIBECK_TRUTH, name)
        assert pe["value"] == pytest.approx(true, rel=0.05), name
        assert pe["ci95"][0] <= true <= pe["ci95"][1], name
        assert f"  {name}" in printed
    assert fit["validation_fit"]["q4"] > 97.0
    params = json.loads((out / "parameters.json").read_text())
    assert params["parameters"]["v_s2"] == pytest.approx(2.0, rel=0.05)


def test_the_ladder_fits_the_stribeck_rung_when_asked_and_ranks_it_best(stribeck_logs):
    """On the ladder (``--try stribeck``) the Stribeck rung is fitted from the Coulomb fit it extends, recovers the
    truth and predicts the held-out logs best. Which rung is *kept* is the selection rule's: on these 8 logs it keeps
    the Coulomb rung, for the truth itself predicts 2 of them worse than the Coulomb fit does (swings that a
    simulation from the measured state follows apart: the truth's scores 0.071 and 0.017 against 0.027 and 0.016),
    and the signed-rank test then finds no consistent gain (p = 0.098)."""
    rig_path, train, held = stribeck_logs
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = fit_logs(train, rig=rig_path, validate=held,
                       options=LogFitOptions(select=True, try_terms={"stribeck"}), warn=False)
    outcomes = res.structures.outcomes
    assert [o.rung.name for o in outcomes][-1] == "stribeck"
    stribeck = outcomes[-1]
    assert res.structures.selection.best == len(outcomes) - 1
    fitted = stribeck.result.parameters
    for name in ("sigma_s2", "v_s2"):
        true = getattr(STRIBECK_TRUTH, name)
        assert fitted[name].value == pytest.approx(true, rel=0.05)
        assert fitted[name].ci95_low <= true <= fitted[name].ci95_high
    # on the held-out logs' scores (q1 and q4) it is the best; on q1 alone the best rigid structure comes within
    # 0.3 points now that initial states are bounded by the measured ones (82.4 against 82.7 %; it was 3 points
    # ahead when the fits could move them freely): the gain is on the wheel's speed
    rigid = [o for o in outcomes if o.rung.name != "stribeck"]
    assert stribeck.score < min(o.score for o in rigid)
    assert stribeck.fit["q4"] > max(o.fit["q4"] for o in rigid)
