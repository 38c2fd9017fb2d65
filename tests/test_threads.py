"""iwp's threads: simulations side by side give the numbers of one after another; failures and interrupts stop
the map; every kernel releases the GIL."""

from __future__ import annotations

import os
import signal
import threading
import time
import warnings

import numba
import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from iwp import threads
from iwp.ident.logfit import LogFitOptions, fit_logs, load_logs
from iwp.models import equations, table1
from iwp.models.plant import Plant
from iwp.rig.described import DescribedRig, write_rig_csv
from iwp.sim import SimOptions, engine
from iwp.sim.inputs import Chirp
from iwp.sim.sensitivity import simulate_sensitivities

from .test_rig_fit import TRUTH, rig_of


def test_the_map_keeps_the_order_and_raises_the_first_failure_after_cancelling_the_rest():
    assert threads.thread_map(lambda x: x * x, range(7)) == [x * x for x in range(7)]
    started = []

    def work(x):
        started.append(x)
        if x == 0:
            raise ValueError("first")
        time.sleep(0.05)
        return x

    with pytest.raises(ValueError, match="first"):
        threads.thread_map(work, range(40))
    time.sleep(0.2)
    assert len(started) < 40  # the calls not started when the failure arrived were cancelled


def test_a_call_on_the_pool_maps_inline_instead_of_waiting_on_the_pool():
    # as many outer calls as threads, each mapping again: would deadlock if the inner maps queued on the pool
    n = threads.fit_threads() + 1
    out = threads.thread_map(lambda i: (threading.current_thread().name,
                                        threads.thread_map(lambda j: threading.current_thread().name, range(3))),
                             range(n))
    for outer, inner in out:
        assert set(inner) == {outer}


def test_every_kernel_releases_the_gil():
    for dispatcher in (engine.kernel(4), engine.integrate, equations.rhs):
        assert dispatcher.targetoptions.get("nogil") is True


def test_simulations_side_by_side_give_the_numbers_of_one_after_another():
    plant = Plant(table1())
    t = np.linspace(0.0, 30.0, 3001)

    def run(x0):
        return simulate_sensitivities(plant, t_eval=t, x0=np.array([x0, 0.0, 0.0, 0.0]), input=Chirp(40, 0.5, 5),
                                      wrt=("p1", "p2", "p3", "rho", "sigma_v1"), options=SimOptions(check=False))

    starts = [0.1 * k for k in range(6)]
    together = threads.thread_map(run, starts)
    for x0, sim in zip(starts, together):
        alone = run(x0)
        np.testing.assert_array_equal(sim.x, alone.x)
        np.testing.assert_array_equal(sim.S, alone.S)


def _blas_threads() -> list[int]:
    return [m["num_threads"] for m in threadpool_info() if m["user_api"] == "blas"]


def test_blas_stays_on_one_thread_until_the_last_fit_beside_it_leaves():
    """Fits side by side each enter one_blas_thread and leave in any order: the first to leave must not give the
    library its threads back while the other still runs (its linear algebra would then depend on the timing)."""
    if not _blas_threads():
        pytest.skip("no BLAS library found by threadpoolctl")
    if threads.fit_threads() < 2:
        pytest.skip("one thread: thread_map runs its calls one after another")
    entered, left = threading.Event(), threading.Event()

    def fit(i):
        with threads.one_blas_thread():
            if i == 0:  # enters first, leaves while the other is still inside
                assert entered.wait(10)
            else:
                entered.set()
                assert left.wait(10)
                return _blas_threads()
        left.set()

    with threadpool_limits(limits=2, user_api="blas"):  # so that one thread differs from the library's own
        before = _blas_threads()
        seen = threads.thread_map(fit, range(2))
        assert seen[1] == [1] * len(before)
        assert _blas_threads() == before == [2] * len(before)


@pytest.mark.no_deadline  # numbers compared, not times
def test_the_ladder_side_by_side_is_the_ladder_one_after_another(tmp_path, monkeypatch):
    """The same costs and held-out scores to the last bit, cross-validation folds included."""
    rig = DescribedRig(rig_of(), TRUTH, noise_std=0.002, seed=4)
    logs = [write_rig_csv(rig.run(Chirp(0.3, 1.0 + i, 6.0), duration=6.0), tmp_path / f"chirp{i}.csv")
            for i in range(2)]

    def ladder():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = fit_logs(load_logs(logs, rig.rig), warn=False, options=LogFitOptions(select=True))
        assert r.structures.scored_on == "leave-one-log-out cross-validation"
        return [(o.rung.name, str(o.scores.tolist()), o.result.fit_result.cost) for o in r.structures.outcomes]  # nan == nan

    together = ladder()
    monkeypatch.setattr(threads, "fit_threads", lambda: 1)
    assert ladder() == together
    # one held-out log (fewer than the signed-rank test needs): the folds join it, the same folds to the bit
    held = write_rig_csv(rig.run(Chirp(0.3, 2.5, 6.0), duration=6.0), tmp_path / "held.csv")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = fit_logs(load_logs(logs, rig.rig), validate=load_logs([held], rig.rig), warn=False,
                     options=LogFitOptions(select=True))
    lad = r.structures
    assert lad.scored_on == "held-out logs and leave-one-log-out cross-validation" and lad.n_scored == 3
    assert [(o.rung.name, str(o.scores[1:].tolist()), o.result.fit_result.cost) for o in lad.outcomes] == together
    assert all(0 < o.scores[0] < 1 for o in lad.outcomes if o.success)  # the held-out log's score, first


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_ctrl_c_while_waiting_cancels_what_has_not_started_and_lets_the_running_calls_finish(signum):
    finished, started = [], []

    def work(i):
        started.append(i)
        if i == 0:
            os.kill(os.getpid(), signum)
        time.sleep(0.1)
        finished.append(i)

    def terminated(s, frame):  # the CLI's SIGTERM: an interrupt (iwp.interruption.Terminated)
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGTERM, terminated)
    try:
        with pytest.raises(KeyboardInterrupt):
            threads.thread_map(work, range(30))
    finally:
        signal.signal(signal.SIGTERM, old)
    assert sorted(finished) == sorted(started) and len(started) < 30


def test_the_map_follows_numbas_thread_count_of_the_caller():
    """A sweep's --threads, or a Dask worker's one engine thread (numba.set_num_threads), bounds the calls."""
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        assert set(threads.thread_map(lambda _: threading.current_thread().name, range(5))) == \
            {threading.current_thread().name}
    finally:
        numba.set_num_threads(before)
    if before > 1:  # on the pool, at most `before` calls at once
        running, most = [], []
        lock = threading.Lock()

        def work(_):
            with lock:
                running.append(1)
                most.append(len(running))
            time.sleep(0.02)
            with lock:
                running.pop()

        threads.thread_map(work, range(12))
        assert 1 < max(most) <= before


def test_a_kernel_asked_for_by_threads_at_once_is_made_once():
    made = []

    @threads.once_per_argument
    def make(n):
        made.append(n)
        time.sleep(0.05)  # a dispatcher's making, long enough for the other threads to ask meanwhile
        return object()

    got = []
    callers = [threading.Thread(target=lambda: got.append(make(4))) for _ in range(6)]
    for c in callers:
        c.start()
    for c in callers:
        c.join()
    assert made == [4] and len({id(g) for g in got}) == 1
    assert make(6) is not got[0] and made == [4, 6]
    assert engine.kernel(4) is engine.kernel(4) and engine.sensitivity_kernel() is not engine.kernel(4)
