"""Logs of an inertia wheel pendulum made by code that shares nothing with iwp (issue 50).

iwp's own studies run on its own twin, whose engine, encoders and inputs are
iwp's: a defect shared by the twin and the tools cancels there. This module
makes logs the way a user's simulator or rig would, with numpy and scipy only
(nothing of iwp's engine, models, inputs or sensors; :func:`study_logs` hands its logs over in iwp's
container, ``ExperimentData``):

* the equations of the paper written out here again: model (9) (the
  compensated system), optionally with the wheel's Coulomb friction that (9)
  lacks, the motor-disk model (14) with the pendulum clamped, and a free
  pendulum whose damping is quadratic air drag (a law none of the paper's);
* integrated by scipy's DOP853 (``solve_ivp``, rtol = atol = 1e-10);
* inputs **held** between samples (a digital controller: each sample's value
  until the next, integrated interval by interval) or **continuous** (a
  Simulink or scipy user's input evaluated at every instant, logged at the
  samples): chirps, multisines, and random multilevel steps (held only);
* sensors: white or AR(1) noise of a given standard deviation and
  correlation time, then an encoder of ``counts`` per revolution whose zero
  falls anywhere within a count;
* parameter sets unlike Table 1 (:data:`TRUTHS`).

Many logs of one length are integrated side by side (one stacked state), so a
study of tens of logs takes seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np
from scipy.integrate import solve_ivp

__all__ = ["Truth", "TRUTHS", "Chirp", "Multisine", "Steps", "Run", "simulate", "encode", "write_csv",
           "COULOMB_WIDTH", "TOL", "Logs", "study_logs"]

#: the tolerances of every integration (rtol = atol)
TOL = 1e-10
#: the wheel's Coulomb friction is ``sigma_c2 tanh(q4 / COULOMB_WIDTH)`` [rad/s] (smooth for the integrator)
COULOMB_WIDTH = 0.05


@dataclass(frozen=True)
class Truth:
    """The lumped parameters of model (9) (the paper's names, its units) and the terms (9) lacks.

    ``sigma_c2``: the wheel's Coulomb friction ``sigma~_c2 sgn q4`` of section 5.1 [rad/s^2] (not in (9));
    ``drag``: a quadratic air drag ``drag q3 |q3|`` of the pendulum [1/rad] (not in (9), none of its laws);
    ``sigma_c1``: the pendulum's Coulomb friction [rad/s^2] (not in (9)).
    """

    p1: float
    p2: float
    p3: float
    rho: float
    sigma_a1: float = 0.0
    sigma_v1: float = 0.0
    sigma_b1: float = 0.0
    sigma_c2: float = 0.0
    drag: float = 0.0
    #: the pendulum's Coulomb friction ``sigma_c1 tanh(q3 / COULOMB_WIDTH)`` [rad/s^2] (not in (9))
    sigma_c1: float = 0.0
    #: a typical input amplitude for this rig [input units]: the wheel then turns at tens of rad/s
    amplitude: float = 1.0

    @property
    def names(self) -> tuple[str, ...]:
        return ("p1", "p2", "p3", "rho", "sigma_a1", "sigma_v1", "sigma_b1")


#: Parameter sets. ``table1``: the paper's; ``direct``: a direct-drive rig (light wheel, strong motor, input a duty
#: in [-1, 1]); ``long``: a long slow pendulum with a heavy wheel and a weak viscous joint.
TRUTHS = {
    "table1": Truth(26.095, 0.0106, 0.0286, 247.24, 0.003, 0.01, 0.0005, amplitude=50.0),
    "direct": Truth(40.0, 0.06, 12.0, 30.0, 0.02, 0.01, 0.0002, amplitude=0.6),
    "long": Truth(9.0, 0.03, 0.4, 80.0, 0.004, 0.02, 0.0, amplitude=5.0),
}


# --------------------------------------------------------------------------------------------------------- inputs
@dataclass(frozen=True)
class Chirp:
    """``u(t) = amplitude sin((w0 + rate t) t)`` [rad/s, rad/s^2]."""

    amplitude: float
    w0: float
    rate: float

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        return self.amplitude * np.sin((self.w0 + self.rate * t) * t)


@dataclass(frozen=True)
class Multisine:
    """A sum of sines at ``freqs`` [rad/s] with ``phases`` [rad], scaled so that its peak is about ``amplitude``."""

    amplitude: float
    freqs: tuple[float, ...]
    phases: tuple[float, ...]

    @classmethod
    def random(cls, amplitude: float, low: float, high: float, n: int, rng: np.random.Generator) -> "Multisine":
        """``n`` frequencies spread log-uniformly over ``[low, high]`` rad/s with random phases."""
        f = np.geomspace(low, high, n) * rng.uniform(0.9, 1.1, n)
        return cls(amplitude, tuple(float(x) for x in f), tuple(float(x) for x in rng.uniform(0, 2 * np.pi, n)))

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        s = sum(np.sin(w * t + p) for w, p in zip(self.freqs, self.phases))
        return self.amplitude * s / math.sqrt(2.0 * len(self.freqs))


@dataclass(frozen=True)
class Steps:
    """Random multilevel steps: a level from ``levels`` held for a random dwell of ``dwell`` [s] (min, max), the
    switches on the sample grid (a digital controller's steps: always held)."""

    levels: tuple[float, ...]
    dwell: tuple[float, float]
    seed: int

    def values(self, n: int, Ts: float) -> np.ndarray:
        rng = np.random.default_rng(self.seed)
        out = np.empty(n)
        k = 0
        while k < n:
            m = max(1, int(round(rng.uniform(*self.dwell) / Ts)))
            out[k:k + m] = rng.choice(self.levels)
            k += m
        return out


# ------------------------------------------------------------------------------------------------------- dynamics
def _rhs(truth: Truth, locked: bool, wheel: bool):
    """``f(t, x, u)`` of stacked states ``x = [q1..., q2..., q3..., q4...]`` (4 blocks of the runs)."""
    p1, p2, p3, rho = truth.p1, truth.p2, truth.p3, truth.rho

    def f(x, u):
        q1, q2, q3, q4 = x.reshape(4, -1)
        coul = truth.sigma_c2 * np.tanh(q4 / COULOMB_WIDTH) if truth.sigma_c2 else 0.0
        if locked:  # the paper's (14) after exact compensation: dq4/dt = (1 + rho)(-p2 q4 + p3 u - sigma_c2 sgn q4)
            z = np.zeros_like(q1)
            return np.concatenate([z, q4, z, (1.0 + rho) * (-p2 * q4 + p3 * u - coul)])
        xi = (p1 * np.sin(q1) + truth.sigma_a1 * np.abs(np.cos(q1)) * q3 + truth.sigma_v1 * q3
              + truth.sigma_b1 * q3 ** 3 + truth.drag * q3 * np.abs(q3) + truth.sigma_c1 * np.tanh(q3 / COULOMB_WIDTH))
        if not wheel:  # a pendulum without a wheel: dq3/dt = -xi
            z = np.zeros_like(q1)
            return np.concatenate([q3, z, -xi, z])
        # model (9), the wheel's Coulomb friction acting on both rows as tau_f2 does in (4)
        return np.concatenate([q3, q4, -xi + p2 * q4 - p3 * u + coul,
                               xi - (1.0 + rho) * (p2 * q4 - p3 * u + coul)])

    return f


@dataclass(frozen=True)
class Run:
    """One simulated run: sample times [s], the true states ``X`` (n, 4) [rad, rad, rad/s, rad/s] and the input
    at the samples ``u`` (what a log records)."""

    t: np.ndarray
    X: np.ndarray
    u: np.ndarray
    hold: str


def simulate(truth: Truth, inputs: Sequence, duration: float, *, Ts: float = 0.005, hold: str = "zoh",
             x0: Sequence[Sequence[float]] | None = None, locked: bool = False, wheel: bool = True) -> list[Run]:
    """Runs of one length side by side, one per input (a :class:`Chirp`, :class:`Multisine`, :class:`Steps` or
    None for no input).

    ``hold="zoh"``: each sample's input held until the next sample (the integration restarts at every sample);
    ``"continuous"``: the input evaluated at every instant (not for :class:`Steps`). ``x0``: one initial state
    per run (default: at rest, hanging). ``locked``: the pendulum clamped (model (14)); ``wheel=False``: a
    pendulum alone.
    """
    if hold not in ("zoh", "continuous"):
        raise ValueError(f"hold must be 'zoh' or 'continuous', got {hold!r}")
    n = int(round(duration / Ts)) + 1
    t = np.arange(n) * Ts
    N = len(inputs)
    U = np.zeros((N, n))
    for j, inp in enumerate(inputs):
        if inp is None:
            continue
        if isinstance(inp, Steps):
            if hold != "zoh":
                raise ValueError("steps switch on the sample grid: they are held")
            U[j] = inp.values(n, Ts)
        else:
            U[j] = inp(t)
    X0 = np.zeros((N, 4)) if x0 is None else np.asarray(x0, dtype=float).reshape(N, 4)
    y = X0.T.reshape(-1).copy()
    f = _rhs(truth, locked, wheel)
    out = np.empty((n, 4 * N))
    out[0] = y
    if hold == "zoh":
        for k in range(n - 1):
            uk = U[:, k]
            sol = solve_ivp(lambda _t, x: f(x, uk), (t[k], t[k + 1]), y, method="DOP853", rtol=TOL, atol=TOL)
            if sol.status != 0:
                raise RuntimeError(f"the integration failed at t = {t[k]:.4f} s: {sol.message}")
            y = sol.y[:, -1]
            out[k + 1] = y
    else:
        fns = [(inp if inp is not None else (lambda s: 0.0)) for inp in inputs]
        sol = solve_ivp(lambda s, x: f(x, np.array([float(g(s)) for g in fns])), (t[0], t[-1]), y,
                        method="DOP853", rtol=TOL, atol=TOL, t_eval=t)
        if sol.status != 0:
            raise RuntimeError(f"the integration failed: {sol.message}")
        out = sol.y.T
    blocks = out.reshape(n, 4, N)
    return [Run(t=t.copy(), X=np.ascontiguousarray(blocks[:, :, j]), u=U[j].copy(), hold=hold) for j in range(N)]


# -------------------------------------------------------------------------------------------------------- sensors
def encode(angle: np.ndarray, rng: np.random.Generator, *, counts: int = 2000, noise: float = 0.0,
           corr_time: float = 0.0, Ts: float = 0.005) -> np.ndarray:
    """An angle [rad] as an encoder of ``counts`` per revolution logs it, after sensor noise.

    The noise is AR(1) with standard deviation ``noise`` [rad] and correlation time ``corr_time`` [s]
    (``x[k] = a x[k-1] + e[k]``, ``a = exp(-Ts / corr_time)``; white for ``corr_time = 0``). The encoder's zero
    falls at a random phase within a count (a run zeroes its encoder wherever it rests).
    """
    angle = np.asarray(angle, dtype=float)
    e = np.zeros(angle.size)
    if noise > 0:
        w = rng.normal(0.0, 1.0, angle.size)
        if corr_time > 0:
            a = math.exp(-Ts / corr_time)
            e[0] = w[0]
            s = math.sqrt(1.0 - a * a)
            for k in range(1, angle.size):
                e[k] = a * e[k - 1] + s * w[k]
        else:
            e = w
        e = noise * e
    if counts <= 0:
        return angle + e
    step = 2.0 * math.pi / counts
    phase = rng.uniform(0.0, 1.0)
    return step * (np.floor((angle + e) / step + phase) - math.floor(phase))


def write_csv(path: str | Path, t, q1, q2, u, *, comments: Sequence[str] = (), digits: int = 9) -> Path:
    """A log as a user's CSV: ``t,q1,q2,u`` with ``# ...`` comment lines (no metadata unless given)."""
    path = Path(path)
    with path.open("w") as fh:
        for c in comments:
            fh.write(f"# {c}\n")
        fh.write("t,q1,q2,u\n")
        for row in zip(t, q1, q2, u):
            fh.write(",".join(f"{v:.{digits}g}" for v in row) + "\n")
    return path


# ------------------------------------------------------------------------------------------------------ the study
@dataclass
class Logs:
    """The training and the held-out logs of one seed (``iwp.data.ExperimentData``)."""

    train: list
    held: list


def study_logs(truth: Truth, seed: int, *, noise: float, corr: float, train_s: float = 30.0,
              held_s: float = 20.0, hold: str = "zoh") -> Logs:
    """Three training and three held-out logs of one seed (inputs and noise drawn from ``seed``), as
    :class:`iwp.data.ExperimentData` (the one import of iwp here: the container, for the tools that read it).

    Held inputs: random multilevel steps, a multisine and quicker steps at half the levels (30 s each) to train;
    a multisine, steps and a chirp (20 s each) held out, all from rest. Continuous inputs: multisines and chirps.
    """
    rng = np.random.default_rng(1000 + seed)
    A = truth.amplitude
    w = math.sqrt(truth.p1)
    levels = tuple(A * x for x in (-1.0, -0.6, -0.3, 0.3, 0.6, 1.0))
    quick = tuple(0.5 * x for x in levels)  # quick steps pump the swing: half the levels keep it below the top
    if hold == "zoh":
        tr_in = [Steps(levels, (0.3, 1.5), int(rng.integers(1 << 30))),
                 Multisine.random(A, 0.3 * w, 3 * w, 10, rng),
                 Steps(quick, (0.1, 0.8), int(rng.integers(1 << 30)))]
        ho_in = [Multisine.random(A, 0.3 * w, 3 * w, 10, rng),
                 Steps(levels, (0.2, 1.0), int(rng.integers(1 << 30))),
                 Chirp(0.8 * A, 0.3 * w, w / 20.0)]
    else:
        tr_in = [Multisine.random(A, 0.3 * w, 3 * w, 10, rng), Chirp(A, 0.3 * w, w / 30.0),
                 Multisine.random(A, 0.2 * w, 2 * w, 8, rng)]
        ho_in = [Multisine.random(A, 0.3 * w, 3 * w, 10, rng), Chirp(0.8 * A, 0.3 * w, w / 20.0),
                 Multisine.random(0.7 * A, 0.5 * w, 2 * w, 6, rng)]
    out = []
    for inputs, dur, role in ((tr_in, train_s, "train"), (ho_in, held_s, "held")):
        runs = simulate(truth, inputs, dur, hold=hold)
        logs = []
        for j, r in enumerate(runs):
            q1 = encode(r.X[:, 0], rng, noise=noise, corr_time=corr)
            q2 = encode(r.X[:, 1], rng, noise=noise, corr_time=corr)
            logs.append(_experiment(t=r.t, q1=q1, q2=q2, u=r.u, source=f"s{seed}_{role}{j}.csv"))
        out.append(logs)
    return Logs(*out)


def _experiment(**kw):
    from iwp.data import ExperimentData  # the container only: nothing of iwp's simulation or sensors

    return ExperimentData(**kw)
