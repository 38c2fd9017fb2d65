"""Speed of the simulation-error refinement (issue 5), against scipy in the same run.

The problem: the paper's free-pendulum experiment (figure 8) on the virtual
rig, 60 s at Ts = 5 ms (12001 samples of the quantised q1), refined from the
least-squares result of ``iwp.identify`` (set-up "free"): 4 parameters
(p1, sigma_a1, sigma_v1, sigma_b1) and the initial state (q1, q3), output q1.

(a) iwp: ``iwp.ident.refinement.refine_identification("free", ...)``: the
    compiled adaptive DOP853 engine with forward sensitivities,
    ``scipy.optimize.least_squares`` (trf) with that exact Jacobian.
(b) scipy: the same residuals (same model right-hand side, same weights,
    same unknowns and bounds) with ``scipy.integrate.solve_ivp`` (RK45,
    rtol 1e-8, atol 1e-10, dense output at the samples) and
    ``least_squares`` with its 2-point finite differences.
(c) the anchor of issue 14: iwp's compiled adaptive DOP853 simulator
    (``iwp.sim.simulate``, rtol = atol = 1e-8) inside ``least_squares`` with
    its 2-point finite differences -- a compiled simulator without
    sensitivities. The issue measured it at 0.084 s against 0.239 s for the
    refinement of that day (compiled fixed-step RK4 with finite-difference
    sensitivities).
(d) the outside anchor of issue 50: numbalsoda's compiled DOP853 (C++,
    rtol = atol = 1e-8) on the same right-hand side written here as a numba
    ``cfunc`` (the free pendulum, wheel held: ``q3' = -xi rho / (1 + rho)``),
    inside ``least_squares`` with 2-point differences. Skipped without
    ``pip install numbalsoda`` (it builds with a Fortran compiler: Debian's
    gfortran).

Both start from the same point; the script prints the wall times, their
ratio, and how far apart the two answers are. BLAS runs on one thread (the
matrices are tall and thin, 12001 x 6; on a shared machine threads only add
contention); set IWP_BENCH_BLAS_THREADS to change it. The first call of (a)
compiles or loads the numba kernel; it is timed separately.

Run: python benchmarks/bench_refine.py [--duration 60] [--repeat 3]
"""

from __future__ import annotations

import os

from iwp.sim import SimOptions, Tolerances

os.environ.setdefault("OPENBLAS_NUM_THREADS", os.environ.get("IWP_BENCH_BLAS_THREADS", "1"))
os.environ.setdefault("OMP_NUM_THREADS", os.environ.get("IWP_BENCH_BLAS_THREADS", "1"))
os.environ.setdefault("MKL_NUM_THREADS", os.environ.get("IWP_BENCH_BLAS_THREADS", "1"))

import argparse  # noqa: E402
import math  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402
from scipy import optimize  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

import iwp.ident.refinement as R  # noqa: E402
from iwp.ident.identification import identify  # noqa: E402
from iwp.ident.output_error import OutputError, initial_state  # noqa: E402
from iwp.models import Plant, table1  # noqa: E402
from iwp.rig import VirtualRig  # noqa: E402
from iwp.sim import simulate  # noqa: E402

FREE = ("p1", "sigma_a1", "sigma_v1", "sigma_b1")


def least_squares_start(data):
    """The starting point: the least squares of iwp's free set-up (theta^c, section 5.2)."""
    return identify(data, "free").to_params(base=table1()), "iwp.ident.identification(setup='free')"


def _problem(data, start):
    """Unknowns, scaling and bounds of the free-decay fit, as iwp.ident.refinement sets them."""
    plant = R.fit_plant(start, "free")
    model = OutputError(plant, R.as_experiments(data), ("q1",))
    params = model.parameters(FREE)
    x0 = initial_state(data, 0, plant)
    pscale = np.array([params[n].optimiser_scale() for n in FREE])
    lo, hi = params.internal_bounds()
    z0 = np.concatenate([params.to_internal()[:4], [x0[0], x0[2]]])
    zlo = np.concatenate([lo[:4], [-np.inf, -np.inf]])
    zhi = np.concatenate([hi[:4], [np.inf, np.inf]])
    return x0, pscale, z0, (zlo, zhi)


def finite_difference_refine(data, start, simulate_q1, *, tol=1e-8):
    """``least_squares`` with 2-point differences on residuals from ``simulate_q1(params, x0, t)``."""
    t = np.asarray(data.t, dtype=float)
    y = np.asarray(data.q1, dtype=float)
    x0, pscale, z0, bounds = _problem(data, start)
    s_y = float(np.std(y))
    nsim = [0]

    def residuals(z):
        nsim[0] += 1
        p = start.replace(**{n: float(v) for n, v in zip(FREE, z[:4] * pscale)})
        xs = x0.copy()
        xs[0], xs[2] = z[4], z[5]
        q1 = simulate_q1(p, xs, t)
        if q1 is None or q1.size != t.size:
            return np.full(t.size, 1e6)
        return (q1 - y) / s_y

    sol = optimize.least_squares(residuals, z0, jac="2-point", bounds=bounds, method="trf", x_scale=1.0,
                                 ftol=tol, xtol=tol, gtol=tol)
    return dict(zip(FREE, sol.x[:4] * pscale)), sol, nsim[0]


def scipy_q1(p, x0, t, *, rtol=1e-8, atol=1e-10):
    """q1 of the free pendulum by scipy's RK45 on the model's right-hand side."""
    plant = Plant(p, model="free")
    sol = solve_ivp(lambda _t, x: plant.rhs(x), (t[0], t[-1]), x0, method="RK45", t_eval=t, rtol=rtol, atol=atol)
    return sol.y[0] if sol.status == 0 else None


def compiled_q1(p, x0, t):
    """q1 of the free pendulum by iwp's compiled DOP853 (no sensitivities), the issue's anchor."""
    r = simulate(Plant(p, model="free"), x0=x0, t0=float(t[0]), t_end=float(t[-1]), t_eval=t,
                 options=SimOptions(tolerances=Tolerances(rtol=1e-8, atol=1e-8), check=False))
    return r.x[:, 0] if r.success else None


def numbalsoda_q1_factory():
    """q1 of the free pendulum by numbalsoda's DOP853, or None when numbalsoda is not installed."""
    try:
        import numba as nb
        from numbalsoda import dop853, lsoda_sig
    except ImportError:
        return None

    @nb.cfunc(lsoda_sig)
    def rhs(t, x, dx, P):  # P = [p1, sigma_a1, sigma_v1, sigma_b1, rho]; x = [q1, q3]
        q1, q3 = x[0], x[1]
        xi = P[0] * math.sin(q1) + P[1] * abs(math.cos(q1)) * q3 + P[2] * q3 + P[3] * q3 * q3 * q3
        dx[0] = q3
        dx[1] = -xi * P[4] / (1.0 + P[4])

    address = rhs.address

    def q1(p, x0, t):
        P = np.array([p.p1, p.sigma_a1, p.sigma_v1, p.sigma_b1, p.rho])
        y, ok = dop853(address, np.array([x0[0], x0[2]]), np.asarray(t, dtype=float), data=P, rtol=1e-8, atol=1e-8)
        return y[:, 0] if ok else None

    return q1


def _best_of(repeat: int, run):
    """``run()`` once to compile or load its kernels, then ``repeat`` times: the best time [s] and the last result."""
    run()
    best, out = math.inf, None
    for _ in range(max(repeat, 1)):
        t0 = time.perf_counter()
        out = run()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--duration", type=float, default=60.0, help="length of the free-decay log [s] (default 60)")
    ap.add_argument("--repeat", type=int, default=3, help="repetitions of (a), best time kept (default 3)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    rig = VirtualRig(seed=args.seed)
    data = rig.run("free-pendulum", duration=args.duration)
    truth = rig.truth.lumped
    start, how = least_squares_start(data)
    print(f"machine: {os.cpu_count()} cores, BLAS threads {os.environ['OPENBLAS_NUM_THREADS']}")
    print(f"data: virtual rig free-pendulum, {args.duration:g} s, Ts = {data.Ts:.3g} s, {data.n_samples} samples; "
          f"start: {how}")
    t0 = time.perf_counter()
    R.refine_identification("free", data, start)
    t_first = time.perf_counter() - t0
    times = []
    r = None
    for _ in range(max(args.repeat, 1)):
        t0 = time.perf_counter()
        r = R.refine_identification("free", data, start)
        times.append(time.perf_counter() - t0)
    t_iwp = min(times)
    print(f"(a) iwp refine:      {t_iwp:8.3f} s (best of {len(times)}; first call incl. numba load/compile "
          f"{t_first:.2f} s), {r.nfev} simulations + {r.njev} with sensitivities, cost {r.cost:.6g}, "
          f"fit q1 {r.fit[0]['q1']:.3f} %")
    t0 = time.perf_counter()
    theta_s, sol, nsim = finite_difference_refine(data, start, scipy_q1)
    t_sp = time.perf_counter() - t0
    print(f"(b) scipy reference: {t_sp:8.3f} s, {nsim} solve_ivp simulations ({sol.nfev} residual evaluations "
          f"+ finite differences), cost {sol.cost:.6g}")
    t_c, (theta_c, sol_c, nsim_c) = _best_of(args.repeat, lambda: finite_difference_refine(data, start, compiled_q1))
    print(f"(c) anchor, compiled DOP853 + 2-point differences: {t_c:8.3f} s (best of {max(args.repeat, 1)}), "
          f"{nsim_c} simulations, cost {sol_c.cost:.6g}")
    nbs = numbalsoda_q1_factory()
    t_d = math.nan
    if nbs is None:
        print("(d) numbalsoda: not installed (pip install numbalsoda), skipped")
    else:
        t_d, (_theta_d, sol_d, nsim_d) = _best_of(args.repeat, lambda: finite_difference_refine(data, start, nbs))
        print(f"(d) numbalsoda DOP853 + 2-point differences:      {t_d:8.3f} s (best of {max(args.repeat, 1)}), "
              f"{nsim_d} simulations, cost {sol_d.cost:.6g}")
    print(f"speed-up (b)/(a): {t_sp / t_iwp:.1f}x; target for (a): <= 1 s -> {'met' if t_iwp <= 1.0 else 'NOT met'}")
    print(f"(c)/(a): {t_c / t_iwp:.2f}; issue 14's target (a) <= (c) -> {'met' if t_iwp <= t_c else 'NOT met'}")
    if math.isfinite(t_d):
        print(f"(d)/(a): {t_d / t_iwp:.2f}; issue 50's target (a) <= (d) -> {'met' if t_iwp <= t_d else 'NOT met'}")
    print(f"{'parameter':<10} {'truth':>12} {'start (LS)':>12} {'iwp':>12} {'scipy':>12} {'anchor':>12}")
    for n in FREE:
        print(f"{n:<10} {getattr(truth, n):>12.6g} {getattr(start, n):>12.6g} {getattr(r.params, n):>12.6g} "
              f"{theta_s[n]:>12.6g} {theta_c[n]:>12.6g}")
    s_iwp = r.params.sigma_a1 + r.params.sigma_v1
    s_sp = theta_s["sigma_a1"] + theta_s["sigma_v1"]
    s_tr = truth.sigma_a1 + truth.sigma_v1
    print(f"{'a1 + v1':<10} {s_tr:>12.6g} {start.sigma_a1 + start.sigma_v1:>12.6g} {s_iwp:>12.6g} {s_sp:>12.6g}")
    print(f"p1 error vs truth: iwp {100 * (r.params.p1 / truth.p1 - 1):+.4f} %, scipy "
          f"{100 * (theta_s['p1'] / truth.p1 - 1):+.4f} %; damping sum error: iwp {100 * (s_iwp / s_tr - 1):+.2f} %, "
          f"scipy {100 * (s_sp / s_tr - 1):+.2f} %")
    if not math.isfinite(t_iwp):  # pragma: no cover
        raise SystemExit(1)


if __name__ == "__main__":
    main()
