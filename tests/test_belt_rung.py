"""The belt (15) as a rung of ``iwp fit``'s ladder, for a rig whose drive is a belt."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest

from iwp.cli import main
from iwp.data import ExperimentData
from iwp.data.rig_description import RigDescription
from iwp.errors import InputError
from iwp.ident import fit_ladder as logfit  # where the ladder looks them up
from iwp.ident.drives import BELT_STARTS, belt_bounds, belt_start
from iwp.ident.logfit import LogFitOptions, fit_logs
from iwp.ident.structure import RUNGS, ladder
from iwp.ident.validation import validation_plant
from iwp.models.parameters import BeltParameters, LumpedParameters, stored_belt
from iwp.models.terms import BELT_FREE
from iwp.rig.described import DescribedRig, prbs, write_rig_csv
from iwp.sim.inputs import Chirp

#: the direct-drive rig of issue 21 (50 ms, PWM duty, 20,000-count pendulum encoder, mean-sampled wheel speed)
RIG = {
    "kind": "iwp-rig", "name": "virtual rig", "sample_period": 0.05,
    "time": {"column": "t", "unit": "s"},
    "pendulum": {"column": "theta", "unit": "counts", "counts_per_rev": 20000},
    "wheel": {"column": "phidot", "quantity": "speed", "unit": "rad/s", "sampling": "mean", "counts_per_rev": 4096},
    "input": {"column": "u", "kind": "duty", "limits": [-1, 1]},
    "drive": {"kind": "direct"},
}
#: the same rig with a belt drive
BELT_RIG = dict(RIG, drive={"kind": "belt", "ratio": 13.5})
TRUTH = LumpedParameters(p1=40.0, p2=0.06, p3=12.0, rho=30.0, sigma_a1=0.02, sigma_v1=0.05, sigma_b1=1e-4,
                         sigma_c2=0.5, sigma_c1=0.4, eps_c1=0.1, eps_c2=0.5)
#: a soft belt with play (resonance sqrt(k/I2) near 1.2 Hz), whose rigid limit is TRUTH's disk
BELT = BeltParameters.from_rigid(TRUTH.p2 * TRUTH.rho, TRUTH.p3 * TRUTH.rho, k_over_I2=60.0, d=0.3, N=13.5,
                                 b2_over_I2=0.5)


def rig(doc) -> RigDescription:
    return RigDescription.from_dict(doc, where="rig.json")


def test_a_stiff_belt_without_play_converges_to_the_rigid_drive_at_first_order():
    """Belt (15) with d = 0 and k -> inf tends to the rigid model (9) it was built from; the error is O(1/k)."""
    inp = Chirp(0.5, 2.0, 6.0)
    rigid = DescribedRig(rig(BELT_RIG), TRUTH).run(inp, duration=10.0).x
    scale = np.max(np.abs(rigid), axis=0)
    errs = []
    for k in (1e3, 1e4, 1e5):
        b = BeltParameters.from_rigid(TRUTH.p2 * TRUTH.rho, TRUTH.p3 * TRUTH.rho, k_over_I2=k, d=0.0, N=13.5,
                                      b2_over_I2=0.5)
        errs.append(np.max(np.abs(DescribedRig(rig(BELT_RIG), TRUTH, belt=b).run(inp, duration=10.0).x - rigid),
                           axis=0))
    for coarse, fine in zip(errs, errs[1:]):
        np.testing.assert_allclose(coarse / fine, 10.0, rtol=0.05)  # first order in 1/k, every state
    assert np.all(errs[-1] < 1e-4 * scale)
    # the belt rig refuses a belt whose ratio is not the drive's, and a dead zone (the belt takes u)
    with pytest.raises(InputError, match="drive.ratio"):
        DescribedRig(rig(BELT_RIG), TRUTH, belt=BeltParameters(N=10.0))
    with pytest.raises(InputError, match="dead zone"):
        DescribedRig(rig(BELT_RIG), TRUTH.replace(v_dz_pos=0.05), belt=BELT)


def test_the_belt_rung_is_on_the_ladder_of_a_belt_drive_only_and_frees_the_belt_for_p2_p3():
    names = [r.name for r in ladder(False, belt_drive=True)]
    assert names == ["9", "coulomb", "pendulum-coulomb", "widths", "offset", "belt"]
    assert "belt" not in [r.name for r in ladder(True)] and "belt" in [r.name for r in ladder(True, True)]
    assert RUNGS["widths"].terms < RUNGS["belt"].terms
    widths = LogFitOptions(terms=RUNGS["widths"].terms)
    belt = LogFitOptions(terms=RUNGS["belt"].terms)
    assert belt.model == "belt-full"
    assert set(belt.free()) == (set(widths.free()) - {"p2", "p3"}) | set(BELT_FREE)
    with pytest.raises(InputError, match="--belt and --dead-zone exclude each other"):
        LogFitOptions(terms={"belt", "dead_zone"})


def test_the_belt_start_has_the_rigid_fit_as_its_limit_inside_the_bounds():
    # a rigid fit with little or almost no disk damping still gives a start inside the bounds (another rigid limit)
    for p2 in (0.005, 1e-9):
        b = belt_start(TRUTH.replace(p2=p2), ratio=13.5, Ts=0.05)
        for name, (lo, hi) in belt_bounds(ratio=13.5, Ts=0.05, speed_per_input=b.kTbeta_over_Rgamma).items():
            assert lo < getattr(b, name) < hi
    # whatever the input's unit (duty, or DAC counts: p3 a thousand times smaller)
    for Ts, p in ((0.05, TRUTH), (0.01, TRUTH), (0.05, TRUTH.replace(p2=0.03, p3=20.0)),
                  (0.05, TRUTH.replace(p3=0.012))):
        b = belt_start(p, ratio=13.5, Ts=Ts)
        assert b.rigid_p2rho == pytest.approx(p.p2 * p.rho, rel=1e-12)
        assert b.rigid_p3rho == pytest.approx(p.p3 * p.rho, rel=1e-12)
        nyquist = math.pi / Ts
        assert math.sqrt(b.k_over_I2) <= nyquist / 4 * (1 + 1e-12)
        assert b.k_over_gamma / b.N ** 2 <= nyquist * (1 + 1e-12)  # the motor's relaxation rate
        for name, (lo, hi) in belt_bounds(ratio=13.5, Ts=Ts, speed_per_input=b.kTbeta_over_Rgamma).items():
            assert lo < getattr(b, name) < hi


def belt_logs(folder, sampling="mean"):
    """Two training chirps and three held-out PRBS runs of 20 s of the belt rig (seed 3), and its description (its
    wheel speed sampled as ``sampling`` says)."""
    doc = dict(BELT_RIG, wheel=dict(BELT_RIG["wheel"], sampling=sampling))
    vr = DescribedRig(rig(doc), TRUTH, noise_std=0.002, seed=3, belt=BELT)
    train = [write_rig_csv(vr.run(Chirp(a, w0, tau), duration=20.0), folder / f"chirp{i}.csv")
             for i, (a, w0, tau) in enumerate(((0.5, 2.0, 6.0), (0.4, 2.5, 7.0)))]
    n = int(round(20.0 / 0.05)) + 1
    held = [write_rig_csv(vr.run(prbs(n, hold=6, amplitude=a, seed=k), duration=20.0), folder / f"prbs{k}.csv")
            for k, a in enumerate((0.4, 0.35, 0.45))]
    rig_path = folder / "rig.json"
    rig_path.write_text(json.dumps(doc))
    return train, held, rig_path


def test_a_forced_belt_fit_keeps_the_best_of_its_starts_from_the_rigid_fits(tmp_path, monkeypatch):
    train, held, rig_path = belt_logs(tmp_path, sampling="instant")
    options = LogFitOptions(terms={"belt", "coulomb", "pendulum_coulomb", "widths"})
    compared, keep = [], logfit.lowest_cost

    def lowest(fits):
        compared.append(list(fits))
        return keep(fits)

    monkeypatch.setattr(logfit, "lowest_cost", lowest)
    monkeypatch.setattr(logfit, "hold_unidentified", lambda fitting, fitted: fitted)  # the starts alone
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = fit_logs(train, rig=rig_path, validate=held, options=options, warn=False)
    assert res.belt is not None and res.model == "belt-full" and res.structures is None
    # one belt fit from each rigid fit (with the widths and without: they start apart), the lowest cost kept
    (fits,) = compared
    assert len(fits) == BELT_STARTS == 2 and fits[0].cost_start != fits[1].cost_start
    assert res.refinement is min(fits, key=lambda f: f.cost) and all(math.isfinite(f.cost) for f in fits)
    assert res.validation_fit["q4"] > 97.0
    # the held-out logs inside the belt fit's 95 % prediction band (its sensitivities forward differences of whole
    # runs; before, a belt fit had no band): 95-98 % of q1's samples, all of q4's (its residual spread is the
    # speed's quantisation and noise, larger than what the parameters leave)
    for f in res.validation:
        assert set(f.coverage) == {"q1", "q4"} and not f.band_misses, f.source
        assert 0.9 <= f.coverage["q1"] <= 1.0 and f.coverage["q4"] >= 0.95, f.coverage
    assert res.band_holds is True


def test_the_ladder_fits_the_belt_of_a_belt_drive_and_predicts_held_out_logs(tmp_path, capsys):
    train, held, rig_path = belt_logs(tmp_path)
    out = tmp_path / "out"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        status = main(["fit", *map(str, train), "--rig", str(rig_path), "--validate", *map(str, held),
                       "--out", str(out)])
    assert status == 0
    doc = json.loads((out / "fit.json").read_text())
    rungs = {r["name"]: r for r in doc["structures"]["rungs"]}
    assert doc["structures"]["chosen"] == "belt" and doc["model"] == "belt-full"
    # the belt predicts the held-out wheel speed far better than the best rigid structure
    rigid_best = max(r["held_out_fit"]["q4"] for name, r in rungs.items() if name != "belt")
    assert rungs["belt"]["held_out_fit"]["q4"] > 97.0 > rigid_best + 4.0 and rungs["belt"]["success"]
    # three held out, two training logs: each training log predicted by a fit on the other joins the ranking
    assert doc["structures"]["n_scored"] == 5 and len(rungs["belt"]["scores"]) == 5
    assert doc["validation_fit"]["q1"] > 90.0
    # the fitted belt is in fit.json and parameters.json; p2, p3 hold its rigid limit
    fitted = stored_belt(out / "parameters.json")
    assert fitted == BeltParameters(**doc["belt"]) and fitted.N == 13.5
    lumped = doc["lumped"]
    assert lumped["p2"] * lumped["rho"] == pytest.approx(fitted.rigid_p2rho, rel=1e-12)
    # the rigid limit of the fitted belt is the truth's disk (p3 rho: 3 %), and the belt is the truth's: before the
    # play was integrated as a hybrid system and the fits ran at rtol 1e-10, k/I2 came out at 81 (36 % off), the
    # play at 0.145 rad (52 % off), b2/I2 at 0.10, and four of the 14 values outside their intervals
    assert fitted.rigid_p3rho == pytest.approx(TRUTH.p3 * TRUTH.rho, rel=0.03)
    assert fitted.k_over_I2 == pytest.approx(BELT.k_over_I2, rel=0.1)
    assert fitted.d == pytest.approx(BELT.d, rel=0.1)
    assert fitted.b2_over_I2 == pytest.approx(BELT.b2_over_I2, rel=0.25)
    truth = {**TRUTH.to_dict(), **BELT.to_dict()}
    rows = {n: doc["parameters"][n] for n in doc["free"]}
    outside = [n for n, row in rows.items() if not row["ci95"][0] <= truth[n] <= row["ci95"][1]]
    # a pendulum friction coefficient the fit says nothing of is held at 0, where the fit drove it, out of the free
    # list; the other pendulum friction coefficients then carry its share of the damping and their intervals may
    # miss this rig's values: every other parameter's interval holds its truth
    held = set(doc["options"].get("fixed", {}))
    friction = {"sigma_a1", "sigma_v1", "sigma_b1"}
    assert held <= friction and len(rows) + len(held) == 14
    assert set(outside) <= (friction if held else set())
    assert not any("no prediction band" in w for w in doc["warnings"])
    # the fit's parameters.json drives a simulation of the belt with its band; a file without a belt is refused
    capsys.readouterr()
    sim = tmp_path / "sim.csv"
    assert main(["simulate", "--params", str(out / "parameters.json"), "--model", "belt-full", "--input", "chirp",
                 "--amplitude", "0.4", "--t-end", "4", "--band", "linear", "--out", str(sim)]) == 0
    header = next(line for line in sim.read_text().splitlines() if not line.startswith("#")).split(",")
    assert header[:6] == ["t", "q1", "q2", "q3", "q4", "u"] and "q4_phi" in header
    rows = np.loadtxt(sim, delimiter=",", comments="#", skiprows=1 + sum(
        line.startswith("#") for line in sim.read_text().splitlines()))
    col = {c: rows[:, i] for i, c in enumerate(header)}
    late = col["t"] > 1.0  # (the wheel stays at rest while the motor takes up the play: no spread there)
    assert np.all(col["q4_hi"] >= col["q4_lo"]) and np.all(col["q4_hi"][late] > col["q4_lo"][late])
    assert np.all(col["q4_phi"] >= col["q4_hi"])
    capsys.readouterr()
    assert main(["simulate", "--params", "table1", "--model", "belt-full", "--t-end", "1",
                 "--out", str(tmp_path / "s2.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--params table1: model 'belt-full' needs the belt's parameters" in err[0]
    # beside its intervals, how the belt's Jacobian is taken and how often such intervals held in the ladder study
    assert any("belt's play" in n and "132 of 140" in n for n in doc["uncertainty"]["notes"])
    capsys.readouterr()
    # --belt on a rig whose drive is not a belt: one line naming the flag, exit 2, nothing written
    rig_path.write_text(json.dumps(RIG))
    assert main(["fit", str(train[0]), "--rig", str(rig_path), "--belt", "--out", str(tmp_path / "o2")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("iwp: error: --belt: the belt model") and "a direct drive" in err[0]
    assert not (tmp_path / "o2").exists()
    # nor on a belt drive whose wheel is measured at the motor shaft (the belt's stretch lies between)
    rig_path.write_text(json.dumps(dict(BELT_RIG, wheel=dict(BELT_RIG["wheel"], at="motor"))))
    assert main(["fit", str(train[0]), "--rig", str(rig_path), "--belt", "--out", str(tmp_path / "o3")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "wheel.at 'motor'" in err[0] and not (tmp_path / "o3").exists()


def test_a_parameter_file_s_belt_is_read_back_or_refused_by_name(tmp_path):
    path = tmp_path / "p.json"
    path.write_text(json.dumps({"kind": "lumped", "parameters": TRUTH.to_dict(), "belt": BELT.to_dict()}))
    assert stored_belt(path) == BELT
    assert stored_belt("table1") is None
    path.write_text(json.dumps({"kind": "lumped", "parameters": TRUTH.to_dict(), "belt": {"stiffness": 3.0}}))
    with pytest.raises(InputError, match=r"p.json: unknown parameter 'stiffness' for a belt set; known: N, b2_over_I2"):
        stored_belt(path)
    path.write_text(json.dumps({"kind": "lumped", "parameters": TRUTH.to_dict(), "belt": {"d": float("nan")}}))
    with pytest.raises(InputError, match=r"p.json: parameter 'd' must be finite, got nan"):
        stored_belt(path)
    path.write_text(json.dumps({"kind": "lumped", "parameters": TRUTH.to_dict(), "belt": [60.0, 0.3]}))
    with pytest.raises(InputError, match=r"p.json: 'belt' must be an object of the belt's parameters"):
        stored_belt(path)


def test_the_validating_plant_of_a_belt_model_takes_the_fits_belt_or_is_refused_by_name():
    t = np.arange(0.0, 1.0, 0.01)
    data = ExperimentData(t=t, q1=np.zeros_like(t), q2=np.zeros_like(t), u=np.zeros_like(t))
    plant = validation_plant(TRUTH, data, "belt-full", belt=BELT)
    assert plant.model == "belt-full" and plant.belt == BELT and plant.params == TRUTH
    with pytest.raises(InputError, match=r"^--params p.json: model 'belt-full' needs the belt's parameters \(15\)"):
        validation_plant(TRUTH, data, "belt-full", source="--params p.json")
    # a rigid model ignores a belt
    assert validation_plant(TRUTH, data, "compensated", belt=BELT).model == "compensated"
