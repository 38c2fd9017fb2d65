"""Runs side by side (iwp.sim.lanes) against the same runs alone (iwp.sim.simulate).

A lane takes the same steps as :func:`simulate` (one stepper, one controller),
so its samples equal the single run's up to rounding: here to 1e-9 relative.
"""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from iwp.errors import InputError
from iwp.models import Plant, table1
from iwp.models.layout import N_PACK
from iwp.sim import (
    BatchOptions,
    Chirp,
    HopfController,
    Sampled,
    SimOptions,
    Tolerances,
    engine,
    lanes,
    simulate,
    simulate_batch,
)
from iwp.sim.inputs import BalanceController, Constant, Sine, Step
from iwp.sim.simulate import command_of, engine_tolerances, segments_of, system_of
from iwp.sim.views import tuple_of


def _rel(a, b):
    """Largest difference relative to the largest magnitude of the reference."""
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def test_one_plant_in_a_list_equals_the_single_run():
    # a list of one plant once raised ZeroDivisionError: the idle lanes'
    # chirp had a zero sweep time
    plant = Plant(table1())
    te = np.linspace(0.0, 8.0, 161)
    br = simulate_batch([plant], input=Chirp(60.0, 3.0, 100.0), t_end=8.0, t_eval=te)
    r = simulate(plant, input=Chirp(60.0, 3.0, 100.0), t_end=8.0, t_eval=te)
    assert br.x.shape == (1, te.size, 4) and br.status.tolist() == [0]
    assert _rel(br.x[0], r.x) < 1e-9
    assert br.nfev[0] == r.nfev


@pytest.mark.parametrize("case", ["chirp", "sampled", "hopf-held"])
def test_lanes_with_their_own_plants_equal_single_runs(case):
    """Per-lane plants, inputs and initial states; more runs than lanes, so lanes are refilled."""
    rng = np.random.default_rng(3)
    n = 35
    t_end = 5.0
    te = np.linspace(0.0, t_end, 101)
    plants = [Plant(table1().replace(p1=float(p1), p3=float(p3)))
              for p1, p3 in zip(rng.uniform(22, 30, n), rng.uniform(0.03, 0.05, n))]
    x0s = [[float(rng.uniform(-0.5, 0.5)), 0.0, float(rng.uniform(-1, 1)), 0.0] for _ in range(n)]
    if case == "chirp":
        inputs = [Chirp(float(a), 3.0, 100.0) for a in rng.uniform(20, 60, n)]
    elif case == "sampled":
        # held arrays of different lengths on one grid (the shorter ones hold their last value)
        inputs = [Sampled(rng.uniform(-40, 40, int(m)), 0.02) for m in rng.integers(150, 260, n)]
    else:
        inputs = [HopfController(float(k1), 0.1, Ts=0.01) for k1 in rng.uniform(-12, -6, n)]
    br = simulate_batch(plants, x0=x0s, input=inputs, t_end=t_end, t_eval=te)
    assert np.all(br.success)
    for i in (0, 7, 16, 33, 34):
        r = simulate(plants[i], x0=x0s[i], input=inputs[i], t_end=t_end, t_eval=te)
        assert _rel(br.x[i], r.x) < 1e-9, (case, i)
        np.testing.assert_allclose(br.u[i], r.u, rtol=1e-9, atol=1e-9 * np.max(np.abs(r.u)))
        np.testing.assert_allclose(br.command[i], r.command, rtol=1e-9, atol=1e-9 * np.max(np.abs(r.u)))
        assert abs(br.nfev[i] - r.nfev) <= 0.01 * r.nfev
        np.testing.assert_allclose(br.x_final[i], r.x[-1], rtol=1e-9, atol=1e-12)


def test_lanes_that_cross_the_rolling_frictions_kink_equal_single_runs():
    """Hopf loops that swing past |q1| = pi/2, the kink of sigma_a1 |cos q1| q3 (section 3.1), many times:
    the lanes plan the steps up to it and the RK4 bridges across it side by side, the single runs one at a time
    (the bridges are computed lane by lane in both). Samples every
    millisecond, so that some fall inside a bridge (about 1 ms long) and are interpolated there."""
    n = 24
    t_end = 30.0
    te = np.arange(0.0, t_end + 1e-9, 1e-3)
    # (k1 above about -10.4 keeps this swing inside |q1| < pi/2 for 30 s)
    inputs = [HopfController(float(k1), 0.1) for k1 in np.linspace(-14.0, -10.5, n)]
    kw = dict(x0=[0.1, 0.0, 0.0, 0.0], t_end=t_end, t_eval=te)
    tol = Tolerances(rtol=1e-9, atol=1e-7)
    br = simulate_batch(table1(), input=inputs, options=BatchOptions(tolerances=tol), **kw)
    assert np.all(br.success)
    for i in (0, 5, 17, 23):
        r = simulate(table1(), input=inputs[i], options=SimOptions(tolerances=tol), **kw)
        crossings = np.count_nonzero(np.diff(np.sign(np.cos(r.x[:, 0]))) != 0)
        assert crossings >= 3, (i, crossings)
        assert _rel(br.x[i], r.x) < 1e-9, i
        assert abs(br.nfev[i] - r.nfev) <= 0.01 * r.nfev


def test_tuple_of_reads_the_first_elements_of_a_row():
    """views.tuple_of, with which the lanes build a run's parameter record: the row's values, in order."""
    @njit
    def packed(P, r):
        return tuple_of(P[r], N_PACK)

    @njit
    def three(a):
        return tuple_of(a, 3)

    P = np.arange(3.0 * (N_PACK + 4)).reshape(3, N_PACK + 4)
    assert packed(P, 2) == tuple(P[2, :N_PACK])
    assert three(np.array([7, -2, 5, 9])) == (7, -2, 5)


def test_store_final_and_summary_agree_with_the_samples():
    ctrls = [HopfController(float(k1), 0.1) for k1 in np.linspace(-12, -6, 20)]
    kw = dict(x0=[0.1, 0.0, 0.0, 0.0], t_end=30.0, t_eval=np.arange(0.0, 30.0 + 1e-9, 0.05), input=ctrls)
    full = simulate_batch(table1(), **kw)
    final = simulate_batch(table1(), options=BatchOptions(store="final"), **kw)
    summ = simulate_batch(table1(), options=BatchOptions(store="summary"), **kw)
    assert final.x is None and final.u is None and summ.x is None
    assert final.t.tolist() == [30.0]
    # the final state is the last sample (the end time is an output time)
    np.testing.assert_allclose(final.x_final, full.x[:, -1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(full.x_final, full.x[:, -1], rtol=0, atol=1e-9)
    X = full.x
    expect = {"min": X.min(axis=1), "max": X.max(axis=1), "mean": X.mean(axis=1),
              "rms": np.sqrt((X ** 2).mean(axis=1))}
    for k, v in expect.items():
        np.testing.assert_allclose(summ.summary[k], v, rtol=1e-9, atol=1e-9, err_msg=k)


def test_summary_of_a_failed_run_is_nan():
    unstable = table1().replace(sigma_v1=-5.0, sigma_a1=0.0, sigma_b1=0.0)
    br = simulate_batch(unstable, x0=[[0.0, 0.0, 0.0, 0.0], [0.1, 0.0, 0.0, 0.0]], t_end=200.0,
                        options=BatchOptions(store="summary"))
    assert br.status.tolist() == [0, 1]
    assert np.all(br.summary["max"][0] == 0.0) and np.all(np.isnan(br.summary["max"][1]))


def test_an_unknown_store_is_refused_by_name():
    with pytest.raises(InputError, match="store must be one of samples, final, summary, got 'all'"):
        simulate_batch(table1(), t_end=1.0, options=BatchOptions(store="all"))


@pytest.mark.parametrize("case", ["coulomb-hopf", "chirp", "sampled-failing"])
def test_runs_the_lanes_do_not_vectorise_are_single_runs_to_the_last_bit(case):
    """Such batches run the single-run kernel per run on all cores (it is 4-5 times cheaper per run than a lane
    of the general path): each run's samples, input columns, summaries, final state and counts are simulate's."""
    T = 20.0
    te = np.arange(0.0, T + 1e-9, 0.25)
    if case == "coulomb-hopf":
        plants = [Plant(table1().replace(sigma_c2=0.3))] * 4
        inputs = [HopfController(k, 0.1) for k in (-12.0, -10.0, -8.0, -6.0)]
    elif case == "chirp":  # with the pendulum's Coulomb friction (an optional term)
        plants = [Plant(table1().replace(p1=v, sigma_c1=0.05)) for v in (20.0, 26.0, 30.0)]
        inputs = [Chirp(60.0, 3.0, 100.0)] * 3
    else:  # one run diverges: its samples and input columns after the failure are NaN
        T = 200.0
        te = np.arange(0.0, T + 1e-9, 0.25)
        plants = [Plant(table1()), Plant(table1().replace(sigma_v1=-5.0, sigma_a1=0.0, sigma_b1=0.0)),
                  Plant(table1())]
        inputs = [Sampled(10.0 * np.sin(np.arange(0.0, T, 0.01)), 0.01)] * 3
    kw = dict(x0=[0.1, 0.0, 0.0, 0.0], t_end=T, t_eval=te)
    tol = Tolerances(rtol=1e-9, atol=1e-9)
    assert not lanes.vectorised(plants[0].code, inputs[0].kind, segments_of(inputs[0], 0.0).mode,
                                np.array([p.packed() for p in plants]), 0, len(plants))
    b = simulate_batch(plants, input=inputs, options=BatchOptions(tolerances=tol), **kw)
    s = simulate_batch(plants, input=inputs, options=BatchOptions(tolerances=tol, store="summary"), **kw)
    for i, (p, u) in enumerate(zip(plants, inputs)):
        r = simulate(p, input=u, options=SimOptions(tolerances=tol, check=False), **kw)  # a failed run: the samples before the failure
        m = r.t.size
        np.testing.assert_array_equal(b.x[i, :m], r.x)
        np.testing.assert_array_equal(b.u[i, :m], r.u)
        assert np.all(np.isnan(b.x[i, m:])) and np.all(np.isnan(b.u[i, m:]))
        assert (b.status[i] == 0) == r.success
        if r.success:
            np.testing.assert_array_equal(b.x_final[i], r.x[-1])
            np.testing.assert_array_equal(s.summary["max"][i], r.x.max(axis=0))
            np.testing.assert_allclose(s.summary["mean"][i], r.x.mean(axis=0), rtol=1e-12, atol=1e-15)
    if case == "sampled-failing":
        assert b.status[1] != 0 and np.isnan(b.x[1, -1, 0]) and np.isnan(b.u[1, -1])


def test_the_hopf_law_on_model_9_without_optional_terms_is_vectorised():
    p = np.array([Plant(table1()).packed()] * 3)
    hopf = HopfController(-9.0, 0.1)
    assert lanes.vectorised(Plant(table1()).code, hopf.kind, segments_of(hopf, 0.0).mode, p, 0, 3)
    p[1] = Plant(table1().replace(sigma_c1=0.1)).packed()  # one run with an optional term: not all of them
    assert not lanes.vectorised(Plant(table1()).code, hopf.kind, segments_of(hopf, 0.0).mode, p, 0, 3)
    assert lanes.vectorised(Plant(table1()).code, hopf.kind, segments_of(hopf, 0.0).mode, p, 2, 3)


def test_constant_sine_and_chirp_inputs_are_vectorised_and_the_step_and_balance_are_not():
    p = np.array([Plant(table1()).packed()] * 2)
    code = Plant(table1()).code
    for u in (Constant(20.0), Sine(30.0, 2.0), Chirp(60.0, 3.0, 100.0), HopfController(-9.0, 0.1)):
        assert lanes.vectorised(code, u.kind, segments_of(u, 0.0).mode, p, 0, 2), u
    for u in (Step(1.0, 20.0), BalanceController(-50.0, -5.0, -0.1)):
        assert not lanes.vectorised(code, u.kind, segments_of(u, 0.0).mode, p, 0, 2), u


def test_a_batch_without_its_input_columns_has_the_same_states():
    plants = [Plant(table1().replace(p1=v)) for v in np.linspace(20.0, 30.0, 20)]
    kw = dict(input=Sine(40.0, 5.0), t_end=10.0, t_eval=np.linspace(0.0, 10.0, 501))
    tol = Tolerances(rtol=1e-9, atol=1e-9)
    full = simulate_batch(plants, options=BatchOptions(tolerances=tol), **kw)
    lean = simulate_batch(plants, options=BatchOptions(tolerances=tol, inputs=False), **kw)
    assert lean.u is None and lean.command is None and full.u.shape == (20, 501)
    np.testing.assert_array_equal(lean.x, full.x)
    np.testing.assert_array_equal(lean.nfev, full.nfev)
    # the input columns themselves: the sine at the samples
    np.testing.assert_allclose(full.u, 40.0 * np.sin(5.0 * full.t)[None, :].repeat(20, 0), rtol=0, atol=1e-13)


def test_a_runs_numbers_do_not_depend_on_the_runs_beside_it():
    """Dense outputs are computed for many runs' steps at once; each run's samples are its own, to the bit.

    A sweep relies on it: its chunks run in slices and on any number of threads or workers. 35 Hopf loops
    with a sample every 50 ms (nearly every step has one) in one batch, in batches of 5, 13 and 17, and
    in reverse order, on 1 thread.
    """
    import numba

    rng = np.random.default_rng(11)
    n = 35
    ctrls = [HopfController(float(k), 0.1) for k in rng.uniform(-12.0, -6.0, n)]
    x0 = [[float(q), 0.0, 0.0, 0.0] for q in rng.normal(0.1, 0.05, n)]
    kw = dict(t_end=20.0, Ts=0.05, options=BatchOptions(tolerances=Tolerances(rtol=1e-8, atol=1e-8)))
    whole = simulate_batch(table1(), x0=x0, input=ctrls, **kw)
    assert np.all(whole.success) and whole.x.shape == (n, 401, 4)
    a = 0
    for m in (5, 13, 17):
        part = simulate_batch(table1(), x0=x0[a:a + m], input=ctrls[a:a + m], **kw)
        np.testing.assert_array_equal(part.x, whole.x[a:a + m])
        np.testing.assert_array_equal(part.nfev, whole.nfev[a:a + m])
        a += m
    before = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        back = simulate_batch(table1(), x0=x0[::-1], input=ctrls[::-1], **kw)
    finally:
        numba.set_num_threads(before)
    np.testing.assert_array_equal(back.x[::-1], whole.x)


class _Alarm(Exception):
    pass


def test_a_signal_stops_the_lanes_at_their_next_step_not_at_the_end_of_the_batch():
    """Python handles a signal in the main thread between bytecodes; a batch the main thread ran itself held
    SIGTERM off for 16 s (a sweep's slice at rtol 1e-14). Its lanes now stop within steps of the signal."""
    import signal
    import threading
    import time

    plant = Plant(table1())
    opts = BatchOptions(store="final", tolerances=Tolerances(rtol=1e-14, atol=1e-14))
    x0 = [[0.1 + 1e-3 * i, 0, 0, 0] for i in range(64)]
    inputs = [HopfController(-10.0, 0.1)] * 64
    simulate_batch(plant, x0=x0[:2], input=inputs[:2], t_end=0.5, Ts=0.5, options=opts)  # compiled before
    fired = []

    def handler(signum, frame):
        fired.append(time.perf_counter())
        raise _Alarm()

    old = signal.signal(signal.SIGALRM, handler)
    try:
        signal.setitimer(signal.ITIMER_REAL, 0.5)
        with pytest.raises(_Alarm):
            simulate_batch(plant, x0=x0, input=inputs, t_end=1e6, Ts=1e4, options=opts)  # minutes of work
        stopped = time.perf_counter()
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    assert fired and stopped - fired[0] < 5.0  # loose: a step of 64 lanes takes microseconds
    assert not any(t.is_alive() for t in threading.enumerate() if t.name == "iwp-kernel")  # the kernel stopped
    # a batch from another thread runs there, as before, and gives the same numbers as from the main thread
    here = simulate_batch(plant, x0=x0[:4], input=inputs[:4], t_end=2.0, Ts=0.5, options=opts)
    there = []
    th = threading.Thread(target=lambda: there.append(
        simulate_batch(plant, x0=x0[:4], input=inputs[:4], t_end=2.0, Ts=0.5, options=opts)))
    th.start()
    th.join()
    assert np.array_equal(here.x_final, there[0].x_final) and np.all(here.status == 0)


def test_a_run_that_keeps_no_input_columns_writes_none_past_their_end():
    """A batch with ``inputs=False`` hands the engine input columns of no samples; a held input (a replayed log's,
    as a Monte Carlo band has it) was written into them all the same, past their end, into the heap: the belt fit's
    band crashed the interpreter (a segmentation fault, "malloc(): smallbin double linked list corrupted"). The
    columns here are empty views at the start of rows of 7s, where such writes would show."""
    plant = Plant(table1())
    t = np.linspace(0.0, 1.0, 21)
    u = Sampled(np.sin(np.arange(21.0)), Ts=0.05)
    guard = np.full(3 * t.size, 7.0)
    U, W = guard[:0], guard[t.size:t.size]  # no samples, their data where the 7s are
    X = np.empty((t.size, 4))
    x = np.array([0.1, 0.0, 0.0, 0.0])
    tol = engine_tolerances(4, Tolerances())
    cps = command_of(plant, None, None)
    stats = engine.kernel(4)(system_of(plant, u, cps), segments_of(u, 0.0), tol, engine.Span(x, 0.0, 1.0, -1.0),
                             engine.Output(t, X, U, W, False, engine.STORE_SAMPLES, np.zeros((engine.N_SUMMARY, 1))))
    assert stats.status == engine.ST_OK and np.all(guard == 7.0)
    # and the batch's states are the single run's to the last bit
    b = simulate_batch(plant, x0=[x, x], input=u, t_end=1.0, t_eval=t, options=BatchOptions(inputs=False))
    assert b.u is None and np.array_equal(b.x[1], simulate(plant, x0=x, input=u, t_end=1.0, t_eval=t).x)
