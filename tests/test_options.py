"""The simulation options: Tolerances, Feedforward, CommandChain (checked when built, shared by every entry point)."""

import numpy as np
import pytest

import iwp
from iwp.errors import InputError
from iwp.models import Plant, table1
from iwp.sim import CommandChain, Feedforward, Sine, Tolerances, simulate_scipy
from iwp.sim.tasks import SimulationTask


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


def test_task_refuses_other_objects():
    with pytest.raises(InputError, match="command"):
        SimulationTask(Plant(table1()), Sine(1.0, 2.0))
    with pytest.raises(InputError, match="tolerances"):
        SimulationTask(Plant(table1()), tolerances=1e-9)
    with pytest.raises(InputError, match="tolerances"):
        simulate_scipy(table1(), t_end=1.0, tolerances=1e-9)
