"""``iwp reproduce`` and ``iwp report``: a reduced run of the whole paper, its outputs, figures and bad input."""

from __future__ import annotations

import base64
import dataclasses
import json
import re

import numpy as np
import pytest

from iwp import reproduce as R
from iwp.cli import main
from iwp.models import load_params
from iwp.report import fmt_interval, prepare_output_dir
from iwp.rig import default_truth
from tests.helpers import EXPECTED_FIGURES


# --------------------------------------------------------------------------
# the reduced run
# --------------------------------------------------------------------------
def test_every_step_completes(quick_run):
    res = quick_run["result"]
    bad = [(s.name, s.message, s.detail) for s in res.steps if s.status != "ok"]
    assert not bad, bad
    assert [s.name for s in res.steps] == [s.name for s in R.STEPS]
    assert res.ok


def test_progress_reports_each_step_in_order(quick_run):
    ev = quick_run["events"]
    starts = [e.step for e in ev if e.kind == "start"]
    dones = [e.step for e in ev if e.kind == "done"]
    assert starts == dones == [s.name for s in R.STEPS]
    assert all(e.total == len(R.STEPS) for e in ev if e.kind in ("start", "done"))


def test_outputs_written(quick_run):
    out = quick_run["out"]
    assert (out / "report.html").is_file()
    assert (out / "parameters.json").is_file()
    assert (out / "results.json").is_file()
    for name in EXPECTED_FIGURES:  # the vector files; the page embeds the PNGs, no file duplicates them
        p = out / "figures" / f"{name}.svg"
        assert p.is_file() and p.stat().st_size > 1000, p
        assert not (out / "figures" / f"{name}.png").exists()
    assert not (out / "data").exists()  # the logs are not kept by default: the page names their commands


def test_report_folder_is_small(quick_run):
    """The whole folder stays well under 5 MB (a full run's is about 3 MB; the logs, 20 MB, are not kept)."""
    out = quick_run["out"]
    total = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    assert total < 4_000_000, total
    assert (out / "report.html").stat().st_size < 2_500_000

def test_svg_files_stay_small(quick_run):
    svgs = sorted((quick_run["out"] / "figures").glob("*.svg"))
    assert {p.stem for p in svgs} == EXPECTED_FIGURES
    for p in svgs:
        assert p.stat().st_size < 1_000_000, (p.name, p.stat().st_size)


@pytest.mark.parametrize("name", ["static-curve", "full-chirp"])
def test_the_pages_commands_write_the_runs_logs_bit_for_bit(quick_run, tmp_path, name):
    """The page says how to get each log back; the command gives the very log the run used."""
    import shlex

    from iwp.rig import write_result

    html = (quick_run["out"] / "report.html").read_text()
    cmd = R.log_command(name, quick=True, seed=0)
    assert f"{name}: {cmd}" in html
    argv = shlex.split(cmd)[1:]
    argv[argv.index("--out") + 1] = str(tmp_path / f"{name}.csv")
    assert main(argv) == 0
    write_result(quick_run["result"].data[name], tmp_path / "run.csv")
    assert (tmp_path / f"{name}.csv").read_bytes() == (tmp_path / "run.csv").read_bytes()


def test_parameters_json_loads_and_refinement_moves_towards_the_truth(quick_run):
    path = quick_run["out"] / "parameters.json"
    p = load_params(path)  # the final set, readable by every --params option
    doc = json.loads(path.read_text())
    assert doc["final"] == "refined"
    assert set(doc["sets"]) >= {"truth", "least-squares", "refined", "table1"}
    # the twin's truth in the session of the full chirp; the free decay holds the wheel, so the least squares
    # return p1 rho/(1 + rho); the simulation-error refinement on the full chirp removes that bias
    truth = default_truth().for_session("5.2").lumped
    ls = doc["sets"]["least-squares"]
    assert ls["p1"] == pytest.approx(truth.p1 * truth.rho / (1 + truth.rho), rel=2e-3)
    assert abs(p.p1 / truth.p1 - 1) < abs(ls["p1"] / truth.p1 - 1)
    # the identification results are all there, JSON-clean
    assert set(doc["identification"]) == {"dead-zone", "motor-disk", "motor-disk-coulomb", "full", "free",
                                          "two-step"}
    assert "NaN" not in path.read_text()


def test_statements_all_checked_with_numbers(quick_run):
    res = quick_run["result"]
    st = res.statements
    assert len(st) == len(R.STATEMENTS)
    assert all(s.passed is not None for s in st), [(s.key, s.found) for s in st if s.passed is None]
    assert all(re.search(r"\d", s.found) for s in st)
    by = {s.key: s for s in st}
    # statements that hold on the virtual rig whatever the run length
    for key in ("rho-close", "restart", "free-pendulum", "rigid-error-grows"):
        assert by[key].passed, (key, by[key].found)
    # the refinement lowers the simulation error only if no simulated fit gets worse (the closed loop's may)
    r, n = res.numbers["refine"], res.numbers
    pairs = [(n["full-chirp"]["fit_q1"], r["fit_full_chirp_q1"]), (r["fit_free_q1_before"], r["fit_free_q1"]),
             (n["closed-loop"]["fit_q1"], r["fit_closed_loop_q1"])]
    assert r["cost"] < r["cost_start"]
    assert by["refinement"].passed is all(b >= a for a, b in pairs), (pairs, by["refinement"].found)


def test_numbers_consistent_with_the_rig(quick_run):
    n = quick_run["result"].numbers
    truth = default_truth().lumped
    assert n["coulomb"]["p2_1rho"] < n["motor-disk"]["p2_1rho"]
    assert n["two-step"]["rho_1"] == pytest.approx(truth.rho, rel=0.05)
    assert n["full-chirp"]["rms_q1_after_restart_with"] < n["full-chirp"]["rms_q1_after_restart_without"]
    assert 2.0 < n["closed-loop"]["amplitude_rig"] < 3.0


def test_report_page_self_contained(quick_run):
    text = (quick_run["out"] / "report.html").read_text()
    assert text.startswith("<!DOCTYPE html>")
    imgs = re.findall(r"<img [^>]*src=\"([^\"]+)\"", text)
    assert len(imgs) == len(EXPECTED_FIGURES)
    embedded = re.findall(r'<figure id="fig-([^"]+)">.*?<img [^>]*src="data:image/svg\+xml;base64,([^"]+)"', text)
    assert len(embedded) == len(imgs)  # every image is an SVG, the very file written beside the page
    for name, data in embedded:
        assert base64.b64decode(data) == (quick_run["out"] / "figures" / f"{name}.svg").read_bytes(), name
    # nothing fetched from elsewhere
    assert not re.search(r"(src|href)=\"(https?:)?//", text)
    assert "<link" not in text
    for title in ("virtual-rig truth", "least squares", "refined", "Table 1", "The paper&#x27;s numbers: published"):
        assert title in text
    assert text.count('class="pass"') + text.count('class="fail"') == len(R.STATEMENTS)


# --------------------------------------------------------------------------
# figures, through their artists
# --------------------------------------------------------------------------
def _labelled(ax):
    """Data lines (the zero axes drawn by axhline/axvline carry no label)."""
    return [ln for ln in ax.get_lines() if not ln.get_label().startswith("_")]


def test_figure_dead_zone_artists(quick_run):
    fig = quick_run["figures"]["fig02_dead_zone"]
    a, b = fig.axes
    assert a.get_xlabel() == "$v$ [-]" and b.get_xlabel() == "$u$ [-]"
    assert "q_4" in a.get_ylabel()
    # points + two extrapolation lines (a); points + one fitted line (b)
    assert len(_labelled(a)) == 1 + 2 and len(_labelled(b)) == 1 + 1
    assert _labelled(a)[0].get_linestyle() == "None"  # the rig's points as markers


@pytest.mark.parametrize("name,panels,signal", [
    ("fig03_sines", 2, "$q_4$ [rad/s]"),
    ("fig04_sine20", 2, "$q_4$ [rad/s]"),
    ("fig06_coulomb", 2, "$q_4$ [rad/s]"),
    ("fig07_coulomb20", 1, "$q_4$ [rad/s]"),
    ("fig08_free_pendulum", 1, "$q_1$ [rad]"),
    ("fig09_full_chirp", 2, "$q_1$ [rad]"),
    ("fig10_closed_loop", 1, "$q_1$ [rad]"),
    ("fig_full_setup", 1, "$q_1$ [rad]"),
])
def test_comparison_figures_artists(quick_run, name, panels, signal):
    fig = quick_run["figures"][name]
    axes = fig.axes
    per = len(axes) // panels  # signal and error, and with a long record their zooms
    long = name in ("fig09_full_chirp", "fig_full_setup")  # the 90 s chirp
    assert len(axes) == per * panels and per == (4 if long else 2)
    for i in range(panels):
        ax, eax = axes[per * i], axes[per * i + 1]
        if per == 4:
            zax, zeax = axes[per * i + 2], axes[per * i + 3]
            assert zax.get_title() == "zoom: 86 to 90 s"
            for a in (zax, zeax):  # a few seconds at full resolution: every 5 ms sample
                for ln in a.get_lines():
                    x = ln.get_xdata()
                    assert 86 - 1e-9 <= x.min() and x.max() <= 90 + 1e-9 and x.size >= 790
                    np.testing.assert_allclose(np.diff(x), 0.005, atol=1e-9)
        assert ax.get_ylabel() == signal
        drawn = _data_artists(ax)
        assert len(drawn) == 2  # measured and simulated (lines, or envelopes of long records)
        assert len(_data_artists(eax)) == 1  # the error
        assert eax.get_xlabel() == "t [s]"
        assert eax.get_ylabel().startswith("error e")
        assert drawn[0].get_label().startswith("experimental data")
        for a in drawn:  # decimated for display: about two vertices per pixel column at most
            assert _vertices(a) <= 4 * fig.get_figwidth() * fig.dpi + 10, (name, _vertices(a))


def _data_artists(ax):
    """The lines and filled envelopes of ``ax`` drawn in data coordinates, in the order drawn."""
    out = [a for a in ax.get_children() if a in ax.lines or a in ax.collections]
    return [a for a in out if a.get_transform() is ax.transData or a in ax.collections]


def _vertices(artist) -> int:
    if hasattr(artist, "get_xdata"):
        return len(artist.get_xdata())
    return sum(len(p.vertices) for p in artist.get_paths())


def test_refine_figure_artists(quick_run):
    fig = quick_run["figures"]["fig_refine"]
    ax, zax = fig.axes  # the errors over the chirp, and the last seconds in full
    assert zax.get_title().startswith("zoom:") and len(zax.get_lines()) == 2
    labels = [a.get_label() for a in _data_artists(ax)]
    assert len(labels) == 2 and labels[0].startswith("least squares") and labels[1].startswith("refined")
    assert ax.get_xlabel() == "t [s]"


def test_plot_functions_compute_nothing():
    from iwp.plotting.report import plot_comparison_panel, plot_comparisons, plot_errors, plot_static_curve

    t = np.linspace(0, 1, 11)
    r = plot_comparison_panel((t, t), [(t, t + 1, "a"), (t, t + 2, "b")], [(t, -np.ones(11), "ea")],
                              signal="q1")
    assert len(r["lines"]) == 4
    np.testing.assert_array_equal(r["lines"][3].get_ydata(), -np.ones(11))  # drawn as given
    r = plot_comparisons([{"measured": (t, t), "simulated": (t, t, "s"), "error": (t, t, "e")}] * 3)
    assert len(r["axes"]) == 6 and len(r["lines"]) == 9
    r = plot_static_curve(t, t, input_name="u", lines=[(t, t, "l")])
    assert r["axes"][0].get_xlabel() == "$u$ [-]" and len(r["lines"]) == 1
    r = plot_errors([(t, t, "x")], signal="q4")
    assert "q_4" in r["axes"][0].get_ylabel()
    import matplotlib.pyplot as plt

    plt.close("all")


def test_envelope_and_trace_keep_every_columns_extremes():
    from iwp.plotting.records import envelope, is_dense, trace

    t = np.linspace(0, 300, 60001)
    y = np.sin(7 * t) * (1 + t / 100)
    tc, lo, hi = envelope(t, y, 600)
    assert tc.size == 600 and tc[0] == t[0] and tc[-1] == t[-1]
    assert hi.max() == y.max() and lo.min() == y.min()
    col = np.minimum((t / 0.5).astype(int), 599)  # 0.5 s a column
    np.testing.assert_array_equal(hi, [y[col == k].max() for k in range(600)])
    assert is_dense(lo, hi)  # 7 rad/s swings within 0.5 s columns: drawn as an envelope
    td, yd = trace(t, y, 600)
    assert td.size <= 1202 and np.all(np.diff(td) > 0) and yd.max() == y.max() and yd.min() == y.min()
    assert td[0] == t[0] and td[-1] == t[-1]
    slow = np.sin(0.05 * t)  # one swing in 125 s: resolved by the columns, drawn as a line
    assert not is_dense(*envelope(t, slow, 600)[1:])
    t2, y2 = trace(t[:100], y[:100], 600)
    np.testing.assert_array_equal(y2, y[:100])


# --------------------------------------------------------------------------
# bad input
# --------------------------------------------------------------------------
def test_non_empty_folder_refused_without_force(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    assert main(["reproduce", "--out", str(out), "--quick"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("iwp: error:") and "not empty" in err and "--force" in err and "\n" not in err
    assert (out / "keep.txt").read_text() == "mine"
    assert sorted(p.name for p in out.iterdir()) == ["keep.txt"]


def test_output_dir_rules(tmp_path):
    from iwp.errors import InputError, OutputExistsError

    empty = tmp_path / "empty"
    empty.mkdir()
    assert prepare_output_dir(empty) == empty
    full = tmp_path / "full"
    full.mkdir()
    (full / "x").write_text("x")
    with pytest.raises(OutputExistsError):
        prepare_output_dir(full)
    assert prepare_output_dir(full, force=True) == full
    f = tmp_path / "file"
    f.write_text("x")
    with pytest.raises(InputError):
        prepare_output_dir(f, force=True)


def test_bad_seed_exit_2(tmp_path, capsys):
    assert main(["reproduce", "--out", str(tmp_path / "o"), "--seed", "-1"]) == 2
    assert "seed" in capsys.readouterr().err


def _boom(ctx):
    raise RuntimeError("simulated failure")


def _patch_step(monkeypatch, name, run):
    """Replace what step ``name`` runs (for the duration of a test)."""
    import iwp.reproduce.pipeline as pipeline

    steps = [dataclasses.replace(s, run=run) if s.name == name else s for s in pipeline.STEPS]
    monkeypatch.setattr(pipeline, "STEPS", steps)


def test_failed_step_named_and_completed_parts_kept(tmp_path, monkeypatch, capsys, quick_run):
    """A failure in one step: named on stderr, exit 1, what was done is kept, the others run."""
    _patch_step(monkeypatch, "free-pendulum", _boom)
    # keep the run short: these steps are exercised by the full reduced run above
    for name in ("sines", "coulomb", "full-setup"):
        _patch_step(monkeypatch, name, lambda ctx: "skipped in this test")
    out = tmp_path / "out"
    status = main(["reproduce", "--out", str(out), "--quick"])
    captured = capsys.readouterr()
    assert status == 1
    err_lines = [ln for ln in captured.err.splitlines() if ln.startswith("iwp: error:")]
    assert err_lines == ["iwp: error: step 'free-pendulum' failed: RuntimeError: simulated failure"]
    assert "FAILED" in captured.out and "free-pendulum" in captured.out
    # completed parts in place
    assert (out / "figures" / "fig02_dead_zone.svg").is_file()
    # the steps that need it are skipped, the report is still written and says so
    results = json.loads((out / "results.json").read_text())
    status_of = {s["name"]: s["status"] for s in results["steps"]}
    assert status_of["free-pendulum"] == "failed"
    assert status_of["two-step"] == status_of["full-chirp"] == status_of["refine"] == "skipped"
    assert status_of["report"] == "ok" and status_of["dead-zone"] == "ok"
    html = (out / "report.html").read_text()
    assert "simulated failure" in html and "failed: free-pendulum" in html
    verdicts = {s["key"]: s["verdict"] for s in results["statements"]}
    assert verdicts["rho-close"] == "not checked"
    # a statement whose steps completed is judged as in the complete run: another step's failure does not touch it
    complete = json.loads((quick_run["out"] / "results.json").read_text())
    assert verdicts["dead-zone"] == {s["key"]: s["verdict"] for s in complete["statements"]}["dead-zone"] == "pass"


def test_logs_kept_when_asked(tmp_path, monkeypatch):
    """reproduce(keep_logs=True) writes each log it ran to data/, readable, and the page says where they are."""
    from iwp.data import read_static_curve

    for step in R.STEPS:  # the static curves alone: a short run
        if step.name not in ("dead-zone", "report"):
            _patch_step(monkeypatch, step.name, lambda ctx: "skipped in this test")
    res = R.reproduce(tmp_path / "out", quick=True, keep_logs=True)
    data = tmp_path / "out" / "data"
    assert sorted(p.name for p in data.iterdir()) == ["static-curve-compensated.csv", "static-curve.csv"]
    curve = read_static_curve(data / "static-curve.csv")
    assert curve.input_name == "v" and curve.n_points == res.data["static-curve"].n_points > 10
    assert "The experiment logs are in data/" in (tmp_path / "out" / "report.html").read_text()


def test_step_times_leave_compiling_apart(tmp_path, monkeypatch):
    """A step that compiles a kernel: its compile time in its own column, not in the step's time."""
    import numba

    def compiles(ctx):
        @numba.njit(cache=False)
        def fresh(n):  # a new function: numba compiles it on this first call (a few branches and arrays, so that
            s = 0.0    # compiling it takes well over the page's 0.05 s threshold even on a fast machine)
            a = np.zeros(n)
            for i in range(n):
                a[i] = i ** 0.5 if i % 3 else np.sin(i) * np.cos(i)
                s += a[i] if a[i] > 0.1 else -a[i]
            return s + a[n // 2]

        return f"sum {fresh(1000):.1f}"

    for step in R.STEPS:
        if step.name != "report":
            _patch_step(monkeypatch, step.name, compiles if step.name == "motor-disk" else lambda ctx: "nothing")
    res = R.reproduce(tmp_path / "out", quick=True)
    rec = {s.name: s for s in res.steps}
    assert rec["motor-disk"].compile_seconds > 0.0
    assert all(s.compile_seconds == 0.0 for n, s in rec.items() if n != "motor-disk")
    assert rec["motor-disk"].seconds < rec["motor-disk"].compile_seconds  # the step's own work: one call
    doc = json.loads((tmp_path / "out" / "results.json").read_text())
    assert {s["name"]: s["compile_seconds"] for s in doc["steps"]}["motor-disk"] > 0.0
    html = (tmp_path / "out" / "report.html").read_text()
    assert "<th>compiling [s]</th>" in html and "s of it compiling numba kernels" in html


def test_stop_on_error(tmp_path, monkeypatch, capsys):
    _patch_step(monkeypatch, "motor-disk", _boom)
    out = tmp_path / "out"
    assert main(["reproduce", "--out", str(out), "--quick", "--stop-on-error"]) == 1
    assert "step 'motor-disk' failed" in capsys.readouterr().err
    res = json.loads((out / "results.json").read_text())
    status_of = {s["name"]: s["status"] for s in res["steps"]}
    assert status_of["dead-zone"] == "ok" and status_of["motor-disk"] == "failed"
    assert all(status_of[n] == "skipped" for n in ("sines", "coulomb", "free-pendulum", "refine"))
    assert status_of["report"] == "ok"
    assert (out / "report.html").is_file() and (out / "figures" / "fig02_dead_zone.svg").is_file()


# --------------------------------------------------------------------------
# iwp report on a user's own logs
# --------------------------------------------------------------------------
def test_report_command_on_logs(quick_run, tmp_path, capsys):
    from iwp.rig import write_result

    data = tmp_path / "data"
    data.mkdir()
    for name, log in quick_run["result"].data.items():
        write_result(log, data / f"{name}.csv")
    params = quick_run["out"] / "parameters.json"
    files = [data / "free-pendulum.csv", data / "full-chirp.csv", data / "closed-loop.csv", data / "sine-40.csv",
             data / "static-curve-compensated.csv"]
    out = tmp_path / "rep"
    assert main(["report", *map(str, files), "--params", str(params), "--out", str(out)]) == 0
    text = (out / "report.html").read_text()
    assert len(re.findall(r"<img ", text)) == len(files)
    assert not re.search(r"(src|href)=\"(https?:)?//", text)
    doc = json.loads((out / "comparison.json").read_text())
    kinds = [c["kind"] for c in doc["logs"]]
    assert kinds[0].startswith("free pendulum") and kinds[2].startswith("closed loop")
    assert kinds[3] == "pendulum locked" and kinds[4] == "static curve"
    fits = {c["file"].split("/")[-1]: c["fit"] for c in doc["logs"]}
    assert fits["full-chirp.csv"]["q1"] > 80
    assert fits["free-pendulum.csv"]["q1"] > 80
    for name in ("free-pendulum", "full-chirp", "closed-loop", "sine-40", "static-curve-compensated"):
        assert (out / "figures" / f"{name}.svg").is_file()
    # the same folder again is refused without --force
    assert main(["report", str(files[0]), "--params", str(params), "--out", str(out)]) == 2
    assert "not empty" in capsys.readouterr().err
    assert main(["report", str(files[0]), "--params", str(params), "--out", str(out), "--force"]) == 0


def test_report_command_bad_file(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,q1,q2\n0,0,0\n0.005,abc,0\n")
    out = tmp_path / "rep"
    assert main(["report", str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("iwp: error:") and "bad.csv" in err and "\n" not in err
    assert not out.exists()
    assert main(["report", str(tmp_path / "missing.csv"), "--out", str(out)]) == 2
    assert "no such file" in capsys.readouterr().err


# --------------------------------------------------------------------------
# two defects of review: a failed simulation, a failed write
# --------------------------------------------------------------------------
def _ctx(tmp_path):
    ctx = R.ReproduceResult(out=tmp_path, truth=default_truth())
    ctx.steps = [R.StepRecord(s.name, s.title, s.reference, status="ok") for s in R.STEPS]
    return ctx


def test_a_failed_simulation_makes_its_statement_fail(tmp_path):
    from iwp.report import Statement
    from iwp.reproduce.statements import st_belt_reduces_error, st_full_setup_far

    ctx = _ctx(tmp_path)
    theta = {"p1": 27.0, "sigma_a1": -2.0, "sigma_v1": 0.7, "sigma_b1": 0.05, "p2": 0.005, "p3": 0.028,
             "p2_1rho": 2.5, "p3_1rho": 7.2}
    ctx.numbers["free"] = {"p1": 26.1, "sigma_a1": 0.003, "sigma_v1": 0.01, "sigma_b1": 0.00047}
    ctx.numbers["full-chirp"] = {"fit_q1": 80.0}
    ctx.numbers["full-setup"] = {"theta": theta, "condition_number": 30.0, "fit_q1": 60.0,
                                 "unweighted": {"theta": theta, "fit_q1": float("nan"),
                                                "simulation_error": "step size underflow at t = 3 s"}}
    st = Statement("full-setup-far", "", "")
    st_full_setup_far(ctx, st)
    assert st.passed is False and [p.passed for p in st.parts] == [True, False]  # far (ratio 170), no prediction
    assert "simulation with these parameters failed" in st.parts[1].what
    # the same numbers with a simulation that ran and predicts worse: the statement holds
    ctx.numbers["full-setup"]["unweighted"] = {"theta": theta, "fit_q1": 20.0}
    st = Statement("full-setup-far", "", "")
    st_full_setup_far(ctx, st)
    assert st.passed is True
    # the belt: a simulation that stopped has no fit, and fails the statement
    ctx.numbers["sines-rigid"] = {"20": {"fit": 60.0}}
    ctx.numbers["sines-belt"] = {"identified": {"k_over_I2": 100.0, "d": 1.0, "20": {
        "fit": float("nan"), "simulation_error": "simulation stopped: step size underflow"}}}
    st = Statement("belt-reduces-error", "", "")
    st_belt_reduces_error(ctx, st)
    assert st.passed is False and "stopped" in st.found


def test_a_failed_write_of_results_json_is_reported(tmp_path):
    from iwp.reproduce.pipeline import write_results

    ctx = _ctx(tmp_path)
    (tmp_path / "results.json").mkdir()  # a folder in the way: the write fails
    events = []
    assert write_results(ctx, events.append) is False
    rec = ctx.step("report")
    assert rec.status == "failed" and "results.json" in rec.message
    assert not ctx.ok and [s.name for s in ctx.failed_steps] == ["report"]
    assert [(e.kind, e.step) for e in events] == [("failed", "report")]
    # and where it can be written, it is
    ctx2 = _ctx(tmp_path / "ok")
    (tmp_path / "ok").mkdir()
    assert write_results(ctx2) is True and json.loads((tmp_path / "ok" / "results.json").read_text())["steps"]


# --------------------------------------------------------------------------
# verdicts that hold up against the report's own numbers (issue 23)
# --------------------------------------------------------------------------
def test_a_closed_loop_that_drifts_does_not_match_closely(tmp_path):
    from iwp.report import Statement
    from iwp.reproduce.statements import st_amplitude

    ctx = _ctx(tmp_path)
    ctx.numbers["closed-loop"] = {"amplitude_rig": 2.58, "amplitude_model": 2.60, "fit_q1": 49.3}
    st = Statement("amplitude", "", "")
    st_amplitude(ctx, st)
    assert st.passed is False and "49.3 %" in st.found and "phase" in st.found
    assert [p.passed for p in st.parts] == [True, True, False]  # the two rows hold; the fit does not
    ctx.numbers["closed-loop"]["fit_q1"] = 85.0
    st = Statement("amplitude", "", "")
    st_amplitude(ctx, st)
    assert st.passed is True


def test_a_refinement_that_worsens_a_fit_does_not_lower_the_error(tmp_path):
    from iwp.report import Statement
    from iwp.reproduce.statements import st_refinement

    ctx = _ctx(tmp_path)
    ctx.numbers["full-chirp"] = {"fit_q1": 53.8}
    ctx.numbers["closed-loop"] = {"fit_q1": 49.3, "amplitude_model": 2.6}
    ctx.numbers["refine"] = {"cost_start": 900.8, "cost": 185.1, "fit_full_chirp_q1": 96.8,
                             "fit_closed_loop_q1": 46.6, "amplitude_model": 2.55}
    st = Statement("refinement", "", "")
    st_refinement(ctx, st)
    assert st.passed is False and "falls from 49.3 to 46.6 %" in st.found
    ctx.numbers["refine"]["fit_closed_loop_q1"] = 60.0
    st_refinement(ctx, st)
    assert st.passed is True


def test_the_compensated_error_at_u15_is_part_of_its_statement(tmp_path):
    from iwp.report import Statement
    from iwp.reproduce.statements import st_linear_after_compensation

    ctx = _ctx(tmp_path)
    ctx.numbers["dead-zone"] = {"line": [2.5, -10.0], "linearity": 0.01, "error_at_u15": 2.3}
    st = Statement("linear-after-compensation", "", "")
    st_linear_after_compensation(ctx, st)
    part = {p.row: p for p in st.parts}["compensated_error_u15"]
    assert st.passed is False and part.passed is False and "2.3" in part.what  # the paper: 25 rad/s
    assert [p.passed for p in st.parts if not p.row] == [True, True]  # linear, and below the line at u = 15
    ctx.numbers["dead-zone"]["error_at_u15"] = 25.5
    st = Statement("linear-after-compensation", "", "")
    st_linear_after_compensation(ctx, st)
    assert st.passed is True


def test_statements_take_their_verdicts_from_the_rows_of_the_numbers_table(quick_run):
    """A statement's part graded on a row of the paper's numbers has that row's verdict, and the statement's
    verdict is its parts': the page cannot say PASS beside a row that says NO (issue 39)."""
    res = quick_run["result"]
    rows = {r.target.key: r.within for r in res.extra["paper-rows"]}
    by = {s.key: s for s in res.statements}
    graded = {p.row for s in res.statements for p in s.parts if p.row}
    assert {"v_dz_pos", "a_p2_1rho", "b_sigma_c2_1rho", "full13_friction_far", "rho", "full_chirp_fit",
            "cl_amplitude_rig", "cl_model_over_rig"} <= graded
    for s in res.statements:
        for p in s.parts:
            if p.row:
                assert p.passed is rows[p.row], (s.key, p.row, p.what)
        if s.parts:
            verdicts = [p.passed for p in s.parts]
            assert s.passed is (False if False in verdicts else (None if None in verdicts else True)), s.key
    # the closed loop's three parts: two rows and the fit, which the paper prints no number for
    assert [bool(p.row) for p in by["amplitude"].parts] == [True, True, False]
    doc = json.loads((quick_run["out"] / "results.json").read_text())
    saved = {s["key"]: s for s in doc["statements"]}
    assert [p["row"] for p in saved["amplitude"]["parts"]] == ["cl_amplitude_rig", "cl_model_over_rig", None]


def test_the_report_fills_every_row_it_has_a_value_for(quick_run):
    """The rows of the paper's (13) as printed carry the values the text beside them quotes; one heading each."""
    res = quick_run["result"]
    rows = {r.target.key: r for r in res.extra["paper-rows"]}
    extra = res.numbers["paper-numbers"]
    assert rows["full13_p1"].reproduced == pytest.approx(extra["unweighted_p1"], rel=1e-12)
    assert rows["full13_friction_far"].reproduced == pytest.approx(extra["friction_ratio_unweighted"], rel=1e-12)
    text = (quick_run["out"] / "report.html").read_text()
    assert text.count("The paper&#x27;s numbers, published against reproduced</h2>") == 1
    assert "issue 12" not in text and "graded by issue" not in text
    steps = json.loads((quick_run["out"] / "results.json").read_text())["steps"]
    assert {s["name"]: s["status"] for s in steps}["report"] == "ok"
    assert re.search(r"<td>report</td><td[^>]*></td><td>ok</td>", text)


def test_an_interval_is_printed_with_the_digits_that_tell_its_ends_apart():
    # the free pendulum's p1: 26.36 +- 0.00022 once read [26.36, 26.36]
    lo, hi = 26.3600 - 0.00043, 26.3600 + 0.00043
    text = fmt_interval(lo, hi)
    a, b = (float(x) for x in text.strip("[]").split(", "))
    assert a < b and abs((b - a) - (hi - lo)) < 0.05 * (hi - lo)  # the width to two digits
    assert fmt_interval(250.0, 253.4) == "[250, 253.4]"  # a wide one keeps four digits
    assert fmt_interval(None, 1.0) == "[-, 1]"


# --------------------------------------------------------------------------
# the page in plain words
# --------------------------------------------------------------------------
def _page_text(out) -> tuple[str, str]:
    """The page's HTML without the embedded images, and its visible text."""
    import html as _html

    page = re.sub(r'src="data:image/svg\+xml;base64,[^"]*"', 'src=""', (out / "report.html").read_text())
    return page, _html.unescape(re.sub(r"<[^>]+>", " ", page))


def test_errata_are_explained_and_every_citation_links_to_its_item(quick_run):
    from iwp.report.words import ERRATA

    page, text = _page_text(quick_run["out"])
    assert "ERRATA" not in text  # every citation became a link "errata item N"
    cited = set(re.findall(r'<a href="#errata-(\d)">errata item \1</a>', page))
    assert {"2", "4"} <= cited
    for n in cited:  # each link lands on its item, which says what the paper prints
        item = re.search(rf'<li id="errata-{n}" value="{n}">([^<]+)</li>', page)
        assert item and item.group(1).startswith(ERRATA[int(n)][:40].replace("'", "&#x27;"))
    assert len(re.findall(r'<li id="errata-\d"', page)) == 6 and "docs/errata.md" in text


def test_statistics_are_said_in_words_where_first_named(quick_run):
    _page, text = _page_text(quick_run["out"])
    first = text.index("(13) as printed")
    assert "least-squares criterion (13) as printed (the squared errors of both rows" in text[first - 60:first + 80]
    assert "file paper_targets.json installed with iwp (its path in Python: iwp.rig.TARGETS_FILE)" in text
    if "HAC sandwich" in text:  # the refinement's intervals: explained in the paragraph after their first naming
        hac = text.index("HAC sandwich")
        words = text.index("How the 95 % intervals are computed")
        assert 0 < words - hac < 600 and text.count("How the 95 % intervals are computed") == 1
        assert text.count("samples apart") == text.count("HAC sandwich (Bartlett")  # each one's lags in seconds


def test_intervals_in_words():
    from iwp.report.words import intervals_in_words

    s = intervals_in_words("HAC sandwich (Bartlett, 919 lags)", 0.005)
    assert "up to 919 samples apart (4.59 s)" in s and "Bartlett" in s and "HAC" in s
    assert "between the experiments" in intervals_in_words("the spread across 3 experiments (bias-reduced)")
    assert intervals_in_words("HAC sandwich (Bartlett, 604 lags)", 0.005, brief=True) == (
        "Here the residuals' correlation is taken up to 604 samples apart (3.02 s).")
    assert intervals_in_words("something else") == ""
