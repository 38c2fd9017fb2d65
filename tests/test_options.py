"""The simulation options: Tolerances, Feedforward, CommandChain, SimOptions, BatchOptions, BandOptions (checked when
built, shared by every entry point)."""

import numpy as np
import pytest

import iwp
from iwp.errors import InputError, SimulationError
from iwp.models import Plant, table1
from iwp.sim import (
    BatchOptions,
    CommandChain,
    Feedforward,
    HopfController,
    SimOptions,
    Sine,
    Tolerances,
    simulate,
    simulate_batch,
    simulate_scipy,
)
from iwp.sim.sensitivity import simulate_sensitivities
from iwp.sim.tasks import SimulationTask
from iwp.sim.uncertainty import BandOptions, ParameterUncertainty, prediction_band


def test_tolerances_defaults_and_per_state_atol():
    t = Tolerances()
    assert (t.rtol, t.atol, t.max_step, t.max_steps) == (1e-10, 1e-10, None, 50_000_000)
    assert Tolerances(atol=np.array([1e-9, 1e-8, 1e-9, 1e-8])).atol == (1e-9, 1e-8, 1e-9, 1e-8)
    assert hash(Tolerances(atol=[1e-9, 1e-9])) == hash(Tolerances(atol=(1e-9, 1e-9)))


@pytest.mark.parametrize("kw, field", [
    ({"rtol": 0.0}, "rtol"), ({"rtol": True}, "rtol"), ({"atol": -1.0}, "atol"), ({"atol": [1e-9, np.nan]}, "atol[1]"),
    ({"atol": [[1e-9]]}, "atol"), ({"max_step": 0.0}, "max_step"), ({"max_steps": 0}, "max_steps"),
    ({"max_steps": 1.5}, "max_steps"),
])
def test_tolerances_refuse_naming_the_field(kw, field):
    with pytest.raises(InputError, match=field.replace("[", r"\[")) as e:
        Tolerances(**kw)
    assert "\n" not in str(e.value)


def test_feedforward_and_chain():
    p = table1()
    ff = Feedforward.of_plant(Plant(p, model="raw"))
    assert (ff.v_pos, ff.v_neg) == (p.v_dz_pos, p.v_dz_neg) == (Feedforward.of_plant(p).v_pos, p.v_dz_neg)
    c = CommandChain(Sine(1.0, 2.0), ff, 30)
    assert c.saturation == 30.0 and c.feedforward_pair() == (p.v_dz_pos, p.v_dz_neg)
    assert CommandChain().feedforward_pair() is None
    with pytest.raises(InputError, match="feedforward"):
        CommandChain(feedforward=True)
    with pytest.raises(InputError, match="saturation"):
        CommandChain(saturation=-1.0)
    with pytest.raises(InputError, match="v_neg"):
        Feedforward(1.0, float("inf"))


def test_exported_from_iwp():
    assert iwp.Tolerances is Tolerances and iwp.CommandChain is CommandChain and iwp.Feedforward is Feedforward
    assert iwp.SimOptions is SimOptions and iwp.BatchOptions is BatchOptions and iwp.BandOptions is BandOptions


def test_run_options_defaults():
    o, b, band = SimOptions(), BatchOptions(), BandOptions()
    assert (o.feedforward, o.saturation, o.tolerances, o.check) == (None, None, None, True)
    assert (b.feedforward, b.saturation, b.tolerances, b.store, b.inputs) == (None, None, None, "samples", True)
    assert (band.method, band.draws, band.seed) == ("linear", 1000, 0)
    assert SimOptions(saturation=80).saturation == 80.0 and SimOptions().feedforward_pair() is None
    assert SimOptions(feedforward=Feedforward(31.0, 29.0)).feedforward_pair() == (31.0, 29.0)


@pytest.mark.parametrize("build, field", [
    (lambda: SimOptions(feedforward=True), "feedforward"),
    (lambda: SimOptions(feedforward=(31.0, 31.0)), "feedforward"),
    (lambda: SimOptions(saturation=0.0), "saturation"),
    (lambda: SimOptions(tolerances=1e-9), "tolerances"),
    (lambda: SimOptions(check="no"), "check"),
    (lambda: BatchOptions(store="all"), "store"),
    (lambda: BatchOptions(inputs=None), "inputs"),
    (lambda: BatchOptions(tolerances={"rtol": 1e-9}), "tolerances"),
    (lambda: BandOptions(method="bootstrap"), "band"),
    (lambda: BandOptions(draws=0), "draws"),
    (lambda: BandOptions(draws=2.5), "draws"),
    (lambda: BandOptions(seed=-1), "seed"),
])
def test_run_options_refuse_naming_the_field(build, field):
    with pytest.raises(InputError) as e:
        build()
    assert e.value.argument == (field,) and field in str(e.value) and "\n" not in str(e.value)


def test_entry_points_refuse_another_options_object_in_one_line():
    p = table1()
    t = np.linspace(0.0, 0.1, 11)
    calls = [
        (lambda: simulate(p, t_end=0.1, options=BatchOptions()), "options must be an iwp.sim.SimOptions, got "
                                                                 "BatchOptions"),
        (lambda: simulate_batch(p, t_end=0.1, options=SimOptions()), "options must be an iwp.sim.BatchOptions, got "
                                                                     "SimOptions"),
        (lambda: simulate_sensitivities(Plant(p), t_eval=t, options=Tolerances()), "options must be an "
                                                                                   "iwp.sim.SimOptions, got Tolerances"),
        (lambda: prediction_band(Plant(p), ParameterUncertainty(p, ("p1",), np.eye(1)), t_eval=t, options="linear"),
         "options must be an iwp.sim.uncertainty.BandOptions, got str"),
    ]
    for call, msg in calls:
        with pytest.raises(InputError) as e:
            call()
        assert str(e.value) == msg and e.value.argument == ("options",)


def test_the_options_reach_the_run():
    """Each field changes what it should: the tolerances the steps, the saturation the command, check the raise."""
    p = table1()
    law = HopfController(-10.0, 0.1)
    loose = simulate(p, input=law, x0=[0.1, 0, 0, 0], t_end=5.0, options=SimOptions(tolerances=Tolerances(1e-6, 1e-6)))
    tight = simulate(p, input=law, x0=[0.1, 0, 0, 0], t_end=5.0)
    assert loose.n_steps < tight.n_steps
    clipped = simulate(p, input=Sine(80.0, 5.0), t_end=1.0, options=SimOptions(saturation=50.0))
    assert np.max(np.abs(clipped.command)) == 50.0 < np.max(np.abs(clipped.u))
    unstable = p.replace(sigma_v1=-5.0, sigma_a1=0.0, sigma_b1=0.0)
    with pytest.raises(SimulationError):
        simulate(unstable, x0=[0.1, 0, 0, 0], t_end=200.0)
    assert not simulate(unstable, x0=[0.1, 0, 0, 0], t_end=200.0, options=SimOptions(check=False)).success
    b = simulate_batch(p, input=[law, law], x0=[0.1, 0, 0, 0], t_end=1.0,
                       options=BatchOptions(saturation=50.0, store="final"))
    assert b.x is None and b.x_final.shape == (2, 4)
    np.testing.assert_array_equal(b.x_final[0], b.x_final[1])


def test_task_refuses_other_objects():
    with pytest.raises(InputError, match="command"):
        SimulationTask(Plant(table1()), Sine(1.0, 2.0))
    with pytest.raises(InputError, match="tolerances"):
        SimulationTask(Plant(table1()), tolerances=1e-9)
    with pytest.raises(InputError, match="tolerances"):
        simulate_scipy(table1(), t_end=1.0, options=SimOptions(tolerances=1e-9))
    with pytest.raises(InputError, match="options must be an iwp.sim.SimOptions, got Tolerances"):
        simulate_scipy(table1(), t_end=1.0, options=Tolerances())
