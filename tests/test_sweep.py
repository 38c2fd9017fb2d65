"""Sweeps (issue 20, part 4): the lanes and their seeds, the metrics against the simulator and the physics,
resuming after an interruption, the same numbers on a real Dask LocalCluster, and bad input."""

from __future__ import annotations

import contextlib
import dataclasses
import json
import logging
import math
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from iwp.cli import main
from iwp.control import lqr_balance, simulated_amplitude
from iwp.errors import InputError, OutputExistsError
from iwp.models import BeltParameters, Plant, table1
from iwp.sim import HopfController, SimOptions, Tolerances, simulate
from iwp.sim.uncertainty import ParameterUncertainty
from iwp.sweep import Grid, Normal, SweepSpec, Uniform, lanes_of_chunk, load_spec, read_table, run_chunk, run_sweep
from iwp.sweep import chunk as chunk_module
from iwp.sweep import store as store_module


def _hopf_spec(**kw) -> SweepSpec:
    base = dict(params=table1(), vary=(Grid("k1", (-12.0, -10.0, -8.0)), Normal("x0.q1", 0.1, 0.05)), samples=4,
                t_end=40.0, window=10.0, chunk_size=5, seed=7)
    base.update(kw)
    return SweepSpec(**base)


def _same_table(a: dict, b: dict) -> None:
    assert list(a) == list(b)
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)


# --------------------------------------------------------------------- lanes and seeds
def test_lanes_are_the_grid_product_times_the_draws_seeded_per_chunk():
    spec = _hopf_spec(samples=40, chunk_size=7)
    assert spec.n_lanes == 120 and spec.n_chunks == 18
    chunks = [lanes_of_chunk(spec, c) for c in range(spec.n_chunks)]
    lanes = np.concatenate([c.lanes for c in chunks])
    np.testing.assert_array_equal(lanes, np.arange(120))
    k1 = np.concatenate([c.k1 for c in chunks])
    # the first grid dimension varies slowest; every grid point has `samples` lanes
    np.testing.assert_array_equal(k1, np.repeat([-12.0, -10.0, -8.0], 40))
    # chunk c's draws are those of SeedSequence(seed, spawn_key=(c,)), whatever else runs
    for c in (0, 5, 17):
        m = chunks[c].lanes.size
        want = np.random.default_rng(np.random.SeedSequence(7, spawn_key=(c,))).normal(0.1, 0.05, size=m)
        np.testing.assert_array_equal(chunks[c].x0[:, 0], want)
        np.testing.assert_array_equal(lanes_of_chunk(spec, c).x0, chunks[c].x0)
    q1 = np.concatenate([c.x0[:, 0] for c in chunks])
    assert abs(q1.mean() - 0.1) < 4 * 0.05 / math.sqrt(q1.size)
    assert 0.8 < q1.std() / 0.05 < 1.2
    assert np.all(np.concatenate([c.x0[:, 1:] for c in chunks]) == 0.0)
    # another seed, other draws; the grid stays
    other = lanes_of_chunk(_hopf_spec(samples=40, chunk_size=7, seed=8), 0)
    assert not np.array_equal(other.x0[:, 0], chunks[0].x0[:, 0])
    np.testing.assert_array_equal(other.k1, chunks[0].k1)


def test_uniform_and_covariance_draws_recover_their_distribution():
    p = table1()
    cov = np.array([[0.5**2, 0.6 * 0.5 * 0.002], [0.6 * 0.5 * 0.002, 0.002**2]])
    u = ParameterUncertainty(p, ("p1", "p3"), cov)
    spec = SweepSpec(params=p, uncertainty=u, vary=(Uniform("x0.q3", -1.0, 1.0),), samples=2000, chunk_size=500,
                     t_end=10.0, window=2.0)
    chunks = [lanes_of_chunk(spec, c) for c in range(spec.n_chunks)]
    z = np.column_stack([np.concatenate([c.values[n] for c in chunks]) for n in ("p1", "p3")])
    # the plant of each lane carries its draw; the draws' mean and covariance are the fit's
    assert chunks[1].params[3].p1 == chunks[1].values["p1"][3]
    assert np.all(np.abs(z.mean(axis=0) - [p.p1, p.p3]) < 4 * np.sqrt(np.diag(cov) / z.shape[0]))
    np.testing.assert_allclose(np.cov(z.T), cov, rtol=0.15)
    # a dimension of vary overrides the fit's draws of its name (a grid as well as a draw)
    over = lanes_of_chunk(SweepSpec(params=p, uncertainty=u, vary=(Grid("p1", (20.0, 30.0)),), samples=3,
                                    t_end=10.0, window=2.0, chunk_size=6), 0)
    assert [q.p1 for q in over.params] == [20.0] * 3 + [30.0] * 3
    assert len({q.p3 for q in over.params}) == 6
    q3 = np.concatenate([c.x0[:, 2] for c in chunks])
    assert q3.min() >= -1.0 and q3.max() < 1.0 and abs(q3.mean()) < 4 * (2 / math.sqrt(12)) / math.sqrt(q3.size)


# --------------------------------------------------------------------- metrics
def test_metrics_are_those_of_the_simulator(tmp_path):
    spec = _hopf_spec(samples=2)
    res = run_sweep(spec, tmp_path / "s")
    tab = res.table
    assert tab["lane"].size == 6 and np.all(tab["status"] == 0)
    for i in (0, 3, 5):
        k1, q10 = tab["k1"][i], tab["x0.q1"][i]
        osc = simulated_amplitude(table1(), k1, 0.1, x0=[q10, 0, 0, 0], t_end=40.0, window=10.0, Ts=0.05,
                                  options=SimOptions(tolerances=Tolerances(rtol=1e-8, atol=1e-8)))
        np.testing.assert_allclose(tab["amplitude"][i], osc.amplitude, rtol=1e-7)
        np.testing.assert_allclose(tab["period"][i], osc.period, rtol=1e-7)
        end = osc.result.x[-1]
        np.testing.assert_allclose([tab[f"q{j}_end"][i] for j in (1, 2, 3, 4)], end, rtol=1e-6, atol=1e-8)
        # the 50 ms samples' refined maxima are those of the trajectory sampled every millisecond
        fine = simulated_amplitude(table1(), k1, 0.1, x0=[q10, 0, 0, 0], t_end=40.0, window=10.0, Ts=0.001,
                                   options=SimOptions(tolerances=Tolerances(rtol=1e-8, atol=1e-8)))
        assert abs(tab["amplitude"][i] - fine.amplitude) < 2e-4
        assert abs(tab["period"][i] - fine.period) < 1e-3
        assert abs(tab["max_abs_q1"][i] - np.max(np.abs(fine.result.q1))) < 2e-4
    # the table on disk is the one returned, to the last digit
    _same_table(read_table(res.results), tab)


def test_a_sweep_of_the_belt_runs_each_lane_as_its_plant_alone_and_draws_the_belts_uncertainty(tmp_path, capsys):
    """A sweep of the pendulum with the belt (15) (a belt fit's parameters): each lane's final state is that of a
    single run of its belt plant, to the last bit (the batch runs the belt's lanes with the single-run kernel);
    the belt's parameters are varied and drawn from the fit's covariance jointly with the lumped ones."""
    p = table1()
    belt = BeltParameters.from_rigid(p.p2 * (1 + p.rho), p.p3 * (1 + p.rho), k_over_I2=150.0, d=0.05, N=13.5,
                                     b2_over_I2=0.5)
    spec = SweepSpec(params=p, model="belt-full", belt=belt, vary=(Grid("k_over_I2", (80.0, 150.0)),
                                                                   Grid("k1", (-12.0, -8.0))),
                     t_end=20.0, window=5.0, chunk_size=3)
    tab = run_sweep(spec, tmp_path / "s").table
    assert tab["lane"].size == 4 and np.all(tab["status"] == 0)
    for i in range(4):
        plant = Plant(p, model="belt-full", belt=dataclasses.replace(belt, k_over_I2=float(tab["k_over_I2"][i])))
        alone = simulate(plant, x0=[0.1, 0, 0, 0], input=HopfController(float(tab["k1"][i]), 0.1), t_end=20.0,
                         Ts=0.05, options=SimOptions(tolerances=Tolerances(rtol=1e-8, atol=1e-8)))
        assert [tab[f"q{j}_end"][i] for j in (1, 2, 3, 4)] == alone.x[-1, :4].tolist()
    # a softer belt lets the wheel lag: the lanes differ by the belt, not only by the gain
    assert tab["q4_end"][0] != tab["q4_end"][1]
    C = np.diag([10.0, 0.01, 0.1]) ** 2
    u = ParameterUncertainty(p, ("k_over_I2", "d", "p1"), C, belt=belt)
    drawn = SweepSpec(params=p, model="belt-full", belt=belt, uncertainty=u, samples=200, t_end=20.0, window=5.0,
                      chunk_size=200)
    ls = lanes_of_chunk(drawn, 0)
    assert np.all(ls.physical)
    got = np.array([[b.k_over_I2, b.d, q.p1] for b, q in zip(ls.belts, ls.params)])
    assert np.all(np.abs(np.mean(got, axis=0) - [150.0, 0.05, p.p1]) < 3 * np.sqrt(np.diag(C) / 200))
    np.testing.assert_allclose(np.std(got, axis=0), np.sqrt(np.diag(C)), rtol=0.15)
    np.testing.assert_array_equal(ls.values["k_over_I2"], got[:, 0])
    # a rigid model has no belt to vary or draw: refused by name
    with pytest.raises(InputError, match="vary 'k_over_I2': a parameter of the belt"):
        SweepSpec(params=p, vary=(Grid("k_over_I2", (80.0,)),))
    with pytest.raises(InputError, match="model 'compensated' has none"):
        SweepSpec(params=p, uncertainty=u, samples=2)


def test_hopf_captured_means_a_steady_orbit_and_the_rest_is_not():
    # k1 = -10 (the paper's): after 300 s the orbit is steady; k1 = +2 damps the pendulum: the hanging rest attracts
    spec = SweepSpec(params=table1(), vary=(Grid("k1", (-10.0, 2.0)),), t_end=300.0, window=20.0, chunk_size=2)
    cols = run_chunk(spec, 0).columns
    assert list(cols["captured"]) == [1, 0]
    assert cols["amplitude_change"][0] < 1e-3 and 2.0 < cols["amplitude"][0] < 3.0
    # the damped lane decays to the hanging rest: no orbit
    assert cols["amplitude"][1] < 1e-3 and cols["max_abs_q1"][1] == pytest.approx(0.1, rel=1e-6)


def test_lqr_captures_inside_its_bound_and_not_far_outside(tmp_path):
    law = lqr_balance(table1(), Ts=0.005)
    b = law.capture_bound
    spec = SweepSpec(params=table1(), law="lqr", vary=(Grid("x0.q1", (math.pi - 0.2 * b, math.pi + 0.2 * b,
                                                                       math.pi + 3.0 * b)),),
                     t_end=4.0, window=1.0, chunk_size=3)
    res = run_sweep(spec, tmp_path / "lqr")
    tab = res.table
    assert list(tab["captured"]) == [1, 1, 0]
    assert np.all(tab["amplitude"][:2] < 1e-3)
    assert tab["rotating"][2] == 1  # it fell
    # three lanes hold no 2.5 % tail: their range, not a "95 %" claim
    amp = np.sort(tab["amplitude"])
    assert f"all 3 lanes in [{amp[0]:.4g}, {amp[-1]:.4g}] rad" in res.summary() and "95 %" not in res.summary()


def test_an_unreliable_fit_is_said_so(tmp_path):
    u = ParameterUncertainty(table1(), ("p1",), np.array([[0.1**2]]), reliable=False,
                             notes=("the experiments disagree beyond their noise",))
    spec = SweepSpec(params=table1(), uncertainty=u, samples=2, t_end=10.0, window=2.0, chunk_size=2)
    with pytest.warns(UserWarning, match="marked unreliable .the experiments disagree"):
        res = run_sweep(spec, tmp_path / "u")
    assert "UNRELIABLE" in res.summary()


def test_unphysical_lanes_are_flagged_not_simulated(tmp_path):
    spec = SweepSpec(params=table1(), vary=(Grid("p1", (26.0, -1.0)),), t_end=20.0, window=5.0, chunk_size=2)
    tab = run_sweep(spec, tmp_path / "u").table
    assert list(tab["status"]) == [0, -1]
    assert np.isfinite(tab["amplitude"][0]) and np.isnan(tab["amplitude"][1]) and tab["nfev"][1] == 0
    # a parameter grid runs one plant per lane: its lane equals simulate() with that plant
    ref = simulate(table1().replace(p1=26.0), x0=[0.1, 0, 0, 0], t_end=20.0, Ts=0.05, input=HopfController(-10.0, 0.1),
                   options=SimOptions(tolerances=Tolerances(rtol=1e-8, atol=1e-8)))
    np.testing.assert_allclose(tab["q1_end"][0], ref.q1[-1], rtol=1e-6)


def test_a_chunk_in_slices_gives_the_numbers_of_one_batch(monkeypatch):
    """Lanes run in slices of SLICE_BYTES (memory); each lane's numbers do not depend on its slice-mates."""
    spec = SweepSpec(params=table1(), vary=(Grid("p1", (26.0, -1.0, 24.0)), Normal("k1", -10.0, 1.0)), samples=3,
                     t_end=20.0, window=5.0, chunk_size=9, seed=3)
    per_lane = (20.0 / 0.05 + 1) * 6 * 8
    assert [p.size for p in chunk_module.slices(spec, np.arange(9))] == [9]  # 154 kB, far below 64 MB
    whole = run_chunk(spec, 0).columns
    assert list(whole["status"]).count(-1) == 3  # p1 = -1: not simulated, in the middle of the chunk
    monkeypatch.setattr(chunk_module, "SLICE_BYTES", 2 * per_lane)
    assert [p.tolist() for p in chunk_module.slices(spec, np.arange(5))] == [[0, 1], [2, 3], [4]]
    _same_table(run_chunk(spec, 0).columns, whole)


# --------------------------------------------------------------------- folder, resume
class _Interrupt:
    def __init__(self, after):
        self.after = after

    def __call__(self, pr):
        if pr.computed >= self.after:
            raise KeyboardInterrupt


def test_an_interrupted_sweep_resumes_with_only_the_missing_chunks(tmp_path, monkeypatch):
    spec = _hopf_spec()
    whole = run_sweep(spec, tmp_path / "whole")
    out = tmp_path / "cut"
    with pytest.raises(KeyboardInterrupt):
        run_sweep(spec, out, progress=_Interrupt(2))
    man = json.loads((out / "manifest.json").read_text())
    assert man["done"] == [0, 1] and not man["complete"] and man["results"] is None
    assert not (out / "results.csv").exists()
    kept = {p.name: p.stat().st_mtime_ns for p in (out / "chunks").iterdir()}
    res = run_sweep(spec, out)
    assert res.computed == [2] and res.resumed == [0, 1]
    assert {p.name: p.stat().st_mtime_ns for p in (out / "chunks").iterdir() if p.name in kept} == kept
    _same_table(res.table, whole.table)
    man = json.loads((out / "manifest.json").read_text())
    assert man["complete"] and man["done"] == [0, 1, 2] and len(man["runs"]) == 2
    assert man["seeds"]["seed"] == 7 and man["spec"]["vary"]["x0.q1"] == {"normal": [0.1, 0.05]}
    # a finished sweep run again computes nothing, leaves its table alone and reads it once (checked, returned)
    before = res.results.stat().st_mtime_ns
    reads = []

    def counted(path, *args, **kwargs):
        reads.append(Path(path).name)
        return read_table(path, *args, **kwargs)

    monkeypatch.setattr(store_module, "read_table", counted)
    again = run_sweep(spec, out)
    assert again.computed == [] and res.results.stat().st_mtime_ns == before
    assert reads.count("results.csv") == 1
    _same_table(again.table, whole.table)


def test_damaged_chunk_files_are_set_aside_and_computed_again(tmp_path):
    spec = _hopf_spec()
    whole = run_sweep(spec, tmp_path / "whole")
    out = tmp_path / "hurt"
    shutil.copytree(tmp_path / "whole", out)
    (out / "results.csv").unlink()
    chunks = out / "chunks"
    (chunks / "chunk-000000.csv").write_text("")  # emptied
    text = (chunks / "chunk-000001.csv").read_text()
    (chunks / "chunk-000001.csv").write_text(text[:len(text) // 2])  # cut in the middle of a line
    lines = (chunks / "chunk-000002.csv").read_text().splitlines(keepends=True)
    (chunks / "chunk-000002.csv").write_text("".join(lines[:2]))  # a row lost at a line's end
    with pytest.warns(UserWarning, match="is not the table of its chunk") as caught:
        res = run_sweep(spec, out)
    assert sorted(str(w.message).split("chunks/")[1].split(" ")[0] for w in caught
                  if "is not the table" in str(w.message)) == [f"chunk-00000{i}.csv" for i in range(3)]
    assert res.computed == [0, 1, 2]
    _same_table(res.table, whole.table)
    assert (out / "results.csv").read_bytes() == (tmp_path / "whole" / "results.csv").read_bytes()
    assert sorted(p.name for p in chunks.iterdir() if p.name.endswith(".damaged")) == [
        f"chunk-00000{i}.csv.damaged" for i in range(3)]
    assert (chunks / "chunk-000002.csv.damaged").read_text() == "".join(lines[:2])  # kept, not lost
    # a finished sweep whose results table was cut: written again from its chunks
    (out / "results.csv").write_text((out / "results.csv").read_text()[:200])
    with pytest.warns(UserWarning, match="results.csv is not the sweep's table"):
        again = run_sweep(spec, out)
    assert again.computed == [] and (out / "results.csv").read_bytes() == (tmp_path / "whole" / "results.csv").read_bytes()


@pytest.mark.parametrize("failure", [InputError("only 0.0 % of the parameter draws are physical"), KeyboardInterrupt()],
                         ids=["error", "interrupt"])
def test_a_fresh_sweep_stopped_before_its_first_chunk_leaves_nothing(tmp_path, monkeypatch, failure):
    import iwp.sweep.executors as executors

    def fail(*args, **kwargs):
        raise failure

    monkeypatch.setattr(executors, "run_chunk", fail)
    with pytest.raises(type(failure)):
        run_sweep(_hopf_spec(samples=1, t_end=20.0), tmp_path / "new")
    assert not (tmp_path / "new").exists()
    mine = tmp_path / "mine"  # a folder the user made stays, empty
    mine.mkdir()
    with pytest.raises(type(failure)):
        run_sweep(_hopf_spec(samples=1, t_end=20.0), mine)
    assert mine.is_dir() and list(mine.iterdir()) == []
    monkeypatch.undo()
    assert run_sweep(_hopf_spec(samples=1, t_end=20.0), tmp_path / "new").computed == [0]  # nothing in the way


def test_a_service_that_is_not_a_dask_scheduler_is_an_error_not_a_hang(tmp_path, monkeypatch):
    pytest.importorskip("distributed")
    import iwp.sweep.executors as executors

    monkeypatch.setattr(executors, "CONNECT_SECONDS", 2.0)
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    held = []
    threading.Thread(target=lambda: held.append(server.accept()), daemon=True).start()  # accepts, never answers
    try:
        with pytest.raises(InputError, match="no Dask scheduler answered within 2 s"):
            run_sweep(_hopf_spec(samples=1, t_end=20.0), tmp_path / "o",
                      scheduler=f"tcp://127.0.0.1:{server.getsockname()[1]}")
    finally:
        server.close()
    assert not (tmp_path / "o").exists()


def test_the_folder_of_another_sweep_is_refused_without_force(tmp_path):
    out = tmp_path / "s"
    run_sweep(_hopf_spec(samples=1, t_end=20.0), out)
    with pytest.raises(OutputExistsError, match="another spec"):
        run_sweep(_hopf_spec(samples=1, t_end=20.0, seed=8), out)
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    with pytest.raises(OutputExistsError, match="not empty"):
        run_sweep(_hopf_spec(samples=1, t_end=20.0), other)
    res = run_sweep(_hopf_spec(samples=1, t_end=20.0, seed=8), out, force=True)
    assert res.computed == [0] and json.loads((out / "manifest.json").read_text())["spec"]["seed"] == 8
    # --force on the same sweep starts afresh (the same numbers again); without it, it resumes (nothing to do)
    assert run_sweep(_hopf_spec(samples=1, t_end=20.0, seed=8), out).computed == []
    again = run_sweep(_hopf_spec(samples=1, t_end=20.0, seed=8), out, force=True)
    assert again.computed == [0]
    _same_table(again.table, res.table)
    assert len(json.loads((out / "manifest.json").read_text())["runs"]) == 1


# --------------------------------------------------------------------- Dask
@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    c = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                 scheduler_kwargs={"dashboard": False, "dashboard_address": "127.0.0.1:0"})
    yield c
    c.close()


def test_a_local_cluster_gives_the_same_numbers_as_the_local_run(tmp_path, cluster):
    p = table1()
    u = ParameterUncertainty(p, ("p1",), np.array([[0.3**2]]))
    specs = [_hopf_spec(samples=3),  # shared plant: side-by-side lanes
             _hopf_spec(samples=3, uncertainty=u, vary=(Grid("k1", (-10.0, -9.0)), Uniform("x0.q1", 0.05, 0.2)))]
    for j, spec in enumerate(specs):
        local = run_sweep(spec, tmp_path / f"local{j}")
        dask = run_sweep(spec, tmp_path / f"dask{j}", scheduler=cluster.scheduler_address)
        assert dask.executor.startswith("dask") and dask.cores == 2
        _same_table(dask.table, local.table)
        assert (tmp_path / f"dask{j}" / "results.csv").read_bytes() == (tmp_path / f"local{j}" / "results.csv"
                                                                         ).read_bytes()


def test_a_local_run_interrupted_resumes_on_the_cluster(tmp_path, cluster):
    spec = _hopf_spec(chunk_size=3)
    whole = run_sweep(spec, tmp_path / "whole")
    out = tmp_path / "cut"
    with pytest.raises(KeyboardInterrupt):
        run_sweep(spec, out, progress=_Interrupt(1))
    res = run_sweep(spec, out, scheduler=cluster.scheduler_address)
    assert sorted(res.computed) == list(range(1, spec.n_chunks))
    _same_table(res.table, whole.table)


def test_cli_sweep_on_the_cluster_and_locally(tmp_path, capsys, cluster):
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({"law": "hopf", "t_end": 30, "window": 10, "seed": 3, "chunk_size": 4, "samples": 3,
                                "vary": {"k1": {"linspace": [-12, -8, 3]}, "x0.q1": {"normal": [0.1, 0.02]}}}))
    assert main(["sweep", str(spec), "--out", str(tmp_path / "a"), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "9 closed loops (hopf, 30 s each) in 3 chunks" in out and "captured" in out
    assert main(["sweep", str(spec), "--out", str(tmp_path / "b"), "--scheduler", cluster.scheduler_address,
                 "--format", "parquet"]) == 0
    import pyarrow.parquet as pq

    b = pq.read_table(tmp_path / "b" / "results.parquet").to_pydict()
    a = read_table(tmp_path / "a" / "results.csv")
    assert list(b) == list(a)
    for k in a:
        np.testing.assert_array_equal(np.asarray(b[k]), a[k], err_msg=k)
    assert "iwp: sweep: 3/3 chunks (9 lanes)" in capsys.readouterr().err


def _name_error_in(filename, name):
    ns: dict = {}
    exec(compile(f"def {name}():\n    future.cancel()\n", filename, "exec"), ns)
    try:
        ns[name]()
    except NameError:
        return sys.exc_info()
    raise AssertionError("no NameError")


def test_only_dasks_interrupt_race_is_kept_from_the_log(cluster, caplog):
    # distributed.utils.sync's cancel reads a future not yet bound when Ctrl-C came first: a NameError that
    # tornado logs with its traceback; while a DaskExecutor is open that one record is dropped, nothing else
    from iwp.sweep.executors import DaskExecutor

    log = logging.getLogger("tornado.application")
    race = _name_error_in("/site-packages/distributed/utils.py", "cancel")
    others = [_name_error_in("/site-packages/distributed/utils.py", "wait"),
              _name_error_in("/site-packages/iwp/sweep/run.py", "cancel")]
    with caplog.at_level(logging.ERROR, logger="tornado.application"):
        with DaskExecutor(scheduler=cluster.scheduler_address):
            for exc_info in [race, *others]:
                log.error("Exception in callback", exc_info=exc_info)
        assert [r.exc_info[2].tb_next.tb_frame.f_code.co_name for r in caplog.records] == ["wait", "cancel"]
        log.error("Exception in callback", exc_info=race)  # the executor closed: logged as tornado would
        assert len(caplog.records) == 3


# --------------------------------------------------------------------- bad input
def _one_line_error(capsys):
    err = capsys.readouterr().err.strip()
    assert err.startswith("iwp: error:") and "\n" not in err and "Traceback" not in err
    return err


@pytest.mark.parametrize("doc,flags,match", [
    (None, [], "no such file"),
    ({"vary": {"k3": [1, 2]}}, [], "'k3': unknown name"),
    ({"vary": {"k1": {"normal": [1]}}}, [], "'vary.k1.normal' needs 2 numbers"),
    ({"vary": {"p1": {"uniform": [3, 2]}}}, [], "uniform needs low < high"),
    ({"vary": {"k1": [-10, -9]}, "samples": 3}, [], "nothing is random"),
    ({"law": "pid"}, [], "law must be one of hopf, lqr"),
    ({"law": "lqr", "k1": -3}, [], "are the Hopf law's"),
    ({"tend": 3}, [], "unknown key 'tend'"),
    ({"params": "nope.json"}, [], "no such parameter file"),
    ({"uncertainty": "table1"}, [], "holds no covariance"),
    ({}, ["--workers", "0"], "--workers must be an integer >= 1"),
    ({}, ["--chunk-size", "0"], "--chunk-size must be an integer >= 1"),
    ({}, ["--scheduler", "nonsense"], "--scheduler nonsense: cannot connect"),
])
def test_bad_input_is_one_line_exit_2_and_nothing_written(tmp_path, capsys, doc, flags, match):
    spec = tmp_path / "spec.json"
    if doc is not None:
        spec.write_text(json.dumps({"t_end": 10, "window": 2, **doc}))
    out = tmp_path / "out"
    assert main(["sweep", str(spec), "--out", str(out), *flags]) == 2
    assert match in _one_line_error(capsys)
    assert not out.exists()


def test_the_spec_file_names_its_paths_relative_to_itself(tmp_path):
    d = tmp_path / "study"
    d.mkdir()
    (d / "p.json").write_text(json.dumps({"kind": "lumped", "parameters": table1().replace(p1=30.0).to_dict()}))
    (d / "spec.json").write_text(json.dumps({"params": "p.json", "t_end": 10, "window": 2}))
    spec = load_spec(d / "spec.json")
    assert spec.params.p1 == 30.0 and spec.source == {"params": "p.json"}
    # a fit's parameters.json (its covariance) as the uncertainty: draws around its estimates
    (d / "fit.json").write_text(json.dumps({"kind": "lumped", "parameters": table1().replace(p1=27.0).to_dict(),
                                            "covariance": {"free": ["p1"], "matrix": [[0.04]], "reliable": True}}))
    (d / "mc.json").write_text(json.dumps({"uncertainty": "fit.json", "samples": 400, "chunk_size": 200,
                                           "t_end": 10, "window": 2}))
    spec = load_spec(d / "mc.json")
    assert spec.params.p1 == 27.0 and spec.uncertainty.free == ("p1",)
    p1 = np.concatenate([lanes_of_chunk(spec, c).values["p1"] for c in range(2)])
    assert abs(p1.mean() - 27.0) < 4 * 0.2 / 20 and 0.85 < p1.std() / 0.2 < 1.15
    with pytest.raises(InputError, match="window must be <= t_end"):
        SweepSpec(params=table1(), t_end=10.0)


@pytest.mark.no_deadline  # numbers compared, not times: passing beside two busy processes
@pytest.mark.parametrize("sampled", [None, 0.005])
def test_the_numbers_do_not_depend_on_the_engine_threads(tmp_path, sampled):
    import numba

    spec = _hopf_spec(samples=3, chunk_size=9, controller_Ts=sampled)
    before = numba.get_num_threads()
    one = run_sweep(spec, tmp_path / "one", threads=1)
    assert numba.get_num_threads() == before and one.cores == 1
    _same_table(one.table, run_sweep(spec, tmp_path / "all").table)
    if sampled:  # the law held over 5 ms, as on the rig: its lanes are those of simulate() with it
        ref = simulate(table1(), x0=[one.table["x0.q1"][4], 0, 0, 0], t_end=40.0, Ts=0.05,
                       input=HopfController(one.table["k1"][4], 0.1, Ts=0.005),
                       options=SimOptions(tolerances=Tolerances(rtol=1e-8, atol=1e-8)))
        np.testing.assert_allclose(one.table["q1_end"][4], ref.q1[-1], rtol=1e-6, atol=1e-9)


def _sweep_with_chunks_on_disk(spec, out, flags, n, **popen) -> subprocess.Popen:
    """``iwp sweep spec --out out *flags`` in a new process, returned once ``n`` chunk files are on disk (running)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.Popen([sys.executable, "-m", "iwp", "sweep", str(spec), "--out", str(out), *flags], env=env,
                            **popen)
    chunks = out / "chunks"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if chunks.is_dir() and len([p for p in chunks.iterdir() if p.name.startswith("chunk-")]) >= n:
            break
        time.sleep(0.005)
    assert proc.poll() is None, "the sweep ended before it could be stopped"
    return proc


def test_a_sweep_killed_with_sigkill_resumes(tmp_path):
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({"t_end": 120, "window": 10, "seed": 5, "chunk_size": 2, "samples": 60,
                                "vary": {"k1": {"uniform": [-12, -8]}}}))
    out = tmp_path / "killed"
    proc = _sweep_with_chunks_on_disk(spec, out, ("--quiet", "--threads", "1"), 3, stdout=subprocess.DEVNULL,
                                      stderr=subprocess.DEVNULL)
    chunks = out / "chunks"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    done = sorted(p.name for p in chunks.iterdir() if p.name.startswith("chunk-"))
    assert 3 <= len(done) < 30 and not (out / "results.csv").exists()
    res = run_sweep(load_spec(spec), out)
    assert len(res.computed) == 30 - len(done)
    _same_table(res.table, run_sweep(load_spec(spec), tmp_path / "whole").table)


def test_ctrl_c_on_a_local_cluster_run_is_one_line_and_resumes(tmp_path):
    # Ctrl-C reaches the whole process group: the cluster's workers too, which leave it to the command
    pytest.importorskip("distributed")
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({"t_end": 300, "window": 10, "seed": 5, "chunk_size": 2, "samples": 100,
                                "vary": {"k1": {"uniform": [-12, -8]}}}))
    out = tmp_path / "cut"
    with socket.socket() as held:  # Dask's default HTTP port taken: the command takes none of its own
        with contextlib.suppress(OSError):  # already taken by another process: the same condition
            held.bind(("127.0.0.1", 8787))
            held.listen()
        proc = _sweep_with_chunks_on_disk(spec, out, ("--workers", "2"), 2, stdout=subprocess.DEVNULL,
                                          stderr=subprocess.PIPE, text=True, start_new_session=True)
        chunks = out / "chunks"
        os.killpg(proc.pid, signal.SIGINT)  # as a terminal's Ctrl-C: the command and its cluster's workers
        _out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "WARNING" not in err, err
    assert err.strip().splitlines()[-1] == "iwp: interrupted"
    done = len([p for p in chunks.iterdir() if p.name.startswith("chunk-")])
    assert 2 <= done < 50
    res = run_sweep(load_spec(spec), out)
    assert len(res.computed) == 50 - done


def test_a_spec_error_names_the_spec_once_and_a_folder_is_not_called_bad_json(tmp_path, capsys):
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({"t_end": 10, "window": 2, "vary": {"k1": {"linspace": [-12, -8, 0]}}}))
    assert main(["sweep", str(spec), "--out", str(tmp_path / "o")]) == 2
    err = _one_line_error(capsys)
    assert err.count(str(spec)) == 1 and "'vary.k1.linspace' count must be a positive integer" in err
    assert main(["sweep", str(tmp_path), "--out", str(tmp_path / "o")]) == 2
    assert _one_line_error(capsys) == f"iwp: error: spec {tmp_path}: is a folder, expected a JSON file"


def test_a_key_given_twice_in_a_json_file_is_refused(tmp_path, capsys):
    spec = tmp_path / "spec.json"
    spec.write_text('{"t_end": 10, "window": 2, "vary": {"k1": [-10, -9], "k1": [-8]}}')  # json keeps the last
    assert main(["sweep", str(spec), "--out", str(tmp_path / "o")]) == 2
    assert "key 'k1' is given twice in one object" in _one_line_error(capsys)
    assert not (tmp_path / "o").exists()
