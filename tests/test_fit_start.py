"""The least-squares start of ``iwp fit`` refuses, in a second, what a wrong rig description makes of a log
(issue 51: a wheel, input or pendulum of the wrong sign, times in minutes read as seconds, ran past 60 s), and
refuses nothing right: on logs of ``tests/independent.py`` (scipy's DOP853, three rigs unlike each other, held
and continuous inputs, AR(1) sensor noise)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from iwp.cli import main
from iwp.errors import InputError
from iwp.ident.fit_start import PENDULUM_PERIOD_RANGE, least_squares_start

from . import independent as ind


def _logs(truth, hold, seed=0, duration=12.0):
    """Two logs of one rig, as iwp's container, and their raw columns."""
    rng = np.random.default_rng(seed)
    w = math.sqrt(truth.p1)
    inputs = [ind.Multisine.random(truth.amplitude, 0.3 * w, 3 * w, 8, rng), ind.Chirp(truth.amplitude, 0.3 * w, w / 10)]
    runs = ind.simulate(truth, inputs, duration, hold=hold)
    cols = [(r.t, ind.encode(r.X[:, 0], rng, noise=1e-3, corr_time=0.02),
             ind.encode(r.X[:, 1], rng, noise=1e-3, corr_time=0.02), r.u) for r in runs]
    return cols, [ind._experiment(t=t, q1=q1, q2=q2, u=u, source=f"log{j}.csv") for j, (t, q1, q2, u) in
                  enumerate(cols)]


@pytest.fixture(scope="module")
def direct_columns():
    return _logs(ind.TRUTHS["direct"], "zoh")[0]


@pytest.mark.parametrize("rig", sorted(ind.TRUTHS))
@pytest.mark.parametrize("hold", ["zoh", "continuous"])
def test_the_start_takes_right_logs_of_three_rigs_and_finds_their_gravity_term(rig, hold):
    truth = ind.TRUTHS[rig]
    _cols, logs = _logs(truth, hold, seed=1)
    start = least_squares_start(logs)
    assert start.method == "least squares"
    assert start.params.p1 == pytest.approx(truth.p1, rel=0.1)
    assert start.params.p3 * start.params.rho == pytest.approx(truth.p3 * truth.rho, rel=0.1)
    lo, hi = PENDULUM_PERIOD_RANGE
    assert lo < 2 * math.pi / math.sqrt(truth.p1) < hi


@pytest.mark.parametrize("flip, key", [((1, -1, 1), "'wheel.sign': -1"), ((1, 1, -1), "negative 'input.scale'"),
                                       ((-1, 1, 1), "'pendulum.sign': -1"), ((-1, -1, 1), "negative 'input.scale'")])
def test_a_log_of_the_wrong_sign_is_refused_naming_the_key_that_turns_it(tmp_path, capsys, direct_columns, flip,
                                                                         key):
    """Both angles counted the other way are the input counted the other way: (9) is odd in (q, u)."""
    s1, s2, su = flip
    names = []
    for j, (t, q1, q2, u) in enumerate(direct_columns):
        names.append(str(ind.write_csv(tmp_path / f"log{j}.csv", t, s1 * q1, s2 * q2, su * u)))
    status = main(["fit", *names, "--out", str(tmp_path / "fit")])
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and key in line and "standard errors below 0" in line, line
    assert not (tmp_path / "fit").exists()


def test_times_in_minutes_are_refused_by_the_pendulums_period_and_read_with_time_unit_min(tmp_path, capsys,
                                                                                        direct_columns):
    rig = {"pendulum": {"column": "q1"}, "wheel": {"column": "q2", "quantity": "angle"},
           "input": {"column": "u"}}
    names = []
    for j, (t, q1, q2, u) in enumerate(direct_columns):
        names.append(str(ind.write_csv(tmp_path / f"log{j}.csv", t / 60.0, q1, q2, u, digits=12)))
    (tmp_path / "rig.json").write_text(json.dumps(rig))
    status = main(["fit", *names, "--rig", str(tmp_path / "rig.json"), "--out", str(tmp_path / "fit")])
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and "'time.unit': \"min\"" in line and "period of 0.0" in line, line
    from iwp.data.rig_description import load_rig
    from iwp.ident.logfit import load_logs
    rig["time"] = {"unit": "min"}
    (tmp_path / "rig.json").write_text(json.dumps(rig))
    logs = load_logs(names, load_rig(tmp_path / "rig.json"))
    assert logs[0].Ts == pytest.approx(0.005, rel=1e-6)
    assert least_squares_start(logs).params.p1 == pytest.approx(ind.TRUTHS["direct"].p1, rel=0.1)


def test_a_start_on_logs_of_the_wrong_sign_raises_in_python_too(direct_columns):
    logs = [ind._experiment(t=t, q1=q1, q2=-q2, u=u, source="x.csv") for t, q1, q2, u in direct_columns]
    with pytest.raises(InputError, match="wheel.sign"):
        least_squares_start(logs)


def test_a_log_given_as_clamped_whose_pendulum_swings_is_refused_not_fitted(tmp_path, capsys, direct_columns):
    """It ended in an internal bounds error (the wheel of a free swing stood still: bounds (0, 0)) or raw numpy
    warnings; the data contradict the flag, which the line names."""
    names = [str(ind.write_csv(tmp_path / f"log{j}.csv", *cols)) for j, cols in enumerate(direct_columns)]
    status = main(["fit", names[0], "--clamped", names[1], "--out", str(tmp_path / "fit")])
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and line.startswith("iwp: error: --clamped ") and "was not clamped" in line, line
    assert not (tmp_path / "fit").exists()


def test_a_clamped_log_alone_is_refused_with_the_set_up_that_takes_it(tmp_path, capsys):
    """The independent simulator's clamped disk chirp given alone ended in "output q1 is constant in every
    experiment (nothing to fit); choose other outputs"."""
    truth = ind.TRUTHS["long"]
    (run,) = ind.simulate(truth, [ind.Chirp(truth.amplitude, 1.0, 2.0)], 8.0, locked=True)
    rng = np.random.default_rng(3)
    path = ind.write_csv(tmp_path / "disk.csv", run.t, ind.encode(run.X[:, 0], rng), ind.encode(run.X[:, 1], rng),
                         run.u)
    status = main(["fit", str(path), "--out", str(tmp_path / "fit")])
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and "no training log shows a free pendulum" in line and "--setup motor-disk" in line, line


def test_a_closed_loops_input_is_no_sign_to_read():
    """A feedback law's input (the twin's Hopf loop, u = k1 q3 + k2 q3^3 from the encoders) is nearly the
    friction's columns again: the pendulum's row read p3 = -0.168, 24 standard errors below 0, and the start
    refused a right log for a pendulum counted the other way."""
    from iwp.ident.fit_start import _terms, sign_errors
    from iwp.rig import VirtualRig

    log = VirtualRig().run("closed-loop", duration=30.0)
    assert sign_errors(_terms(log)) == []
    assert least_squares_start([log]).params.p1 == pytest.approx(26.1, rel=0.1)
