"""
Prediction bands
================

A refined fit carries its covariance; :func:`iwp.sim.uncertainty.prediction_band`
propagates it through the model (linearised from the sensitivities, or by
Monte Carlo draws) into a 95 % band of the parameters' effect on each signal,
and adds the measurement noise and the uncertainty of the measured initial
state for the prediction band. :func:`iwp.validate` given the fit's
:class:`~iwp.sim.uncertainty.ParameterUncertainty` does both and says which
share of a held-out log lies inside the prediction band.
"""

import warnings

import matplotlib.pyplot as plt

from iwp import ValidationOptions, VirtualRig, identify, refine_identification, validate
from iwp.sim.uncertainty import ParameterUncertainty

train = [VirtualRig(seed=s).run("free-pendulum", duration=20, x0=[q, 0, 0, 0]) for s, q in ((0, -1.4), (2, -0.9))]
held = VirtualRig(seed=1).run("free-pendulum", duration=20, x0=[-1.2, 0, 0, 0])

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    ls = identify(train[0], "free", t_start=0.5)
    refined = refine_identification("free", train, ls.to_params(), window=(0.5, None), warn=False)
unc = ParameterUncertainty.from_refinement(refined)
print("standard errors:", {k: f"{v:.2g}" for k, v in unc.stderr.items()})

val = validate(held, unc, model="free", signals=("q1",), options=ValidationOptions(window=(0.5, None)))
print(f"held-out fit {val.fit['q1']:.2f} %; inside the 95 % prediction band: {val.coverage['q1']:.1%}")
assert val.coverage["q1"] > 0.8

val.plot()
plt.gcf().suptitle("a held-out free swing and the fit's 95 % prediction band")
