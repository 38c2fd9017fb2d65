"""What a reproduction writes: parameters.json, results.json and report.html."""

from __future__ import annotations

import json
import math
import platform
import time
from pathlib import Path
from typing import Any

from .. import __version__
from ..files import jsonable
from ..report import FigureEntry, Report, Section, Table, fmt, fmt_interval, write_html
from ..report.words import ERRATA, intervals_in_words
from ..rig import default_truth, truth_record
from .context import ReproduceResult, log_command
from .paper import PAPER
from .statements import check_statements


def step_report(ctx: ReproduceResult) -> str:
    """Check the statements; write parameters.json, results.json and report.html."""
    ctx.statements = check_statements(ctx)
    p = write_parameters(ctx)
    ctx.files.append(p)
    ctx.step("report").status = "ok"  # the page's table of steps shows this one as results.json does
    html = _write_report(ctx)
    ctx.files.append(html)
    n_pass = sum(s.passed is True for s in ctx.statements)
    n_fail = sum(s.passed is False for s in ctx.statements)
    n_nc = sum(s.passed is None for s in ctx.statements)
    return f"{n_pass} statements pass, {n_fail} fail, {n_nc} not checked"


# --------------------------------------------------------------------------
# outputs
# --------------------------------------------------------------------------
def write_parameters(ctx: ReproduceResult) -> Path:
    """Write ``DIR/parameters.json`` (the final set, readable by ``load_params``, and the rest) and results.json."""

    final_name = "refined" if "refined" in ctx.params else ("least-squares" if "least-squares" in ctx.params
                                                             else None)
    doc: dict[str, Any] = {"kind": "lumped"}
    if final_name is not None:
        doc["parameters"] = ctx.params[final_name].to_dict()
    doc["final"] = final_name
    doc["source"] = "iwp reproduce" + (" --quick" if ctx.quick else "")
    doc["seed"] = ctx.seed
    sets = {}
    for name in ("truth", "least-squares", "refined", "table1", "free", "motor-disk", "coulomb", "full-setup"):
        if name in ctx.params:
            sets[name] = ctx.params[name].to_dict()
    doc["sets"] = sets
    if ctx.truth is not None:
        doc["truth"] = ctx.truth.to_dict()
    if "belt" in ctx.extra:
        doc["belt"] = ctx.extra["belt"]
    doc["identification"] = {k: _safe_to_dict(v) for k, v in ctx.ident.items()}
    if "refine" in ctx.extra:
        doc["refinement"] = {k: _safe_to_dict(v) for k, v in ctx.extra["refine"].items()}
    path = ctx.out / "parameters.json"
    path.write_text(json.dumps(jsonable(doc), indent=2) + "\n")
    (ctx.out / "results.json").write_text(json.dumps(ctx.to_dict(), indent=2) + "\n")
    ctx.files.append(ctx.out / "results.json")
    return path


def _safe_to_dict(obj) -> Any:
    try:
        return obj.to_dict()
    except Exception as exc:  # noqa: BLE001 - an unserialisable result must not stop the report
        return {"error": f"{type(exc).__name__}: {exc}"}


_PARAM_ROWS = [("p1", "p1 [s^-2]"), ("p2", "p2 [s^-1]"), ("p3", "p3"), ("rho", "rho"),
               ("sigma_a1", "sigma~_a1 [s^-1]"), ("sigma_v1", "sigma~_v1 [s^-1]"), ("sigma_b1", "sigma~_b1"),
               ("v_dz_pos", "v+"), ("v_dz_neg", "v-"), ("sigma_c2", "sigma~_c2"),
               ("p2_1rho", "p2(1+rho) [s^-1]"), ("p3_1rho", "p3(1+rho)")]


def _parameter_table(ctx: ReproduceResult):

    cols = [("truth", "virtual-rig truth"), ("least-squares", "least squares (two-step)"),
            ("refined", "refined"), ("table1", "paper, Table 1")]
    have = [(k, title) for k, title in cols if k in ctx.params]
    se = {}
    ls = ctx.ident.get("two-step"), ctx.ident.get("free"), ctx.ident.get("dead-zone")
    for res in ls:
        if res is None:
            continue
        for name, est in getattr(res, "parameters", {}).items():
            se.setdefault(name, est.stderr)
    rows = []
    for key, label in _PARAM_ROWS:
        row = [label]
        for k, _ in have:
            row.append(fmt(getattr(ctx.params[k], key)))
        s = se.get(key)
        row.append(fmt(s, 2) if s is not None else "-")
        if "truth" in ctx.params and "least-squares" in ctx.params:
            tv = getattr(ctx.params["truth"], key)
            row.append(f"{100 * (getattr(ctx.params['least-squares'], key) / tv - 1):+.1f} %" if tv else "-")
            if "refined" in ctx.params:
                row.append(f"{100 * (getattr(ctx.params['refined'], key) / tv - 1):+.1f} %" if tv else "-")
        rows.append(row)
    columns = ["parameter"] + [t for _, t in have] + ["std. error (LS)"]
    if "truth" in ctx.params and "least-squares" in ctx.params:
        columns.append("LS vs truth")
        if "refined" in ctx.params:
            columns.append("refined vs truth")
    note = ("Least squares: v+ and v- from the static curve (figure 2a), p1 and the sigmas from the free pendulum, "
            "p2, p3 and rho from the two-step set-up on the full chirp (rho = (rho_1 + rho_2)/2). Standard errors "
            "are those of the least-squares fits. The truth's v+ and v- exclude the Coulomb friction "
            "(sigma~_c2), which the model (9) neglects; Table 1's v+ = v- = 31 are from section 5.1.")
    return Table("Parameters", columns, rows, note)


def _identification_table(ctx: ReproduceResult):

    rows = []
    paper = {"dead-zone": {"v_dz_pos": 31.0, "v_dz_neg": 31.0},
             "motor-disk": {"p2_1rho": PAPER["p2_1rho"], "p3_1rho": PAPER["p3_1rho"]},
             "motor-disk-coulomb": {"p2_1rho": PAPER["coulomb_p2_1rho"], "p3_1rho": PAPER["coulomb_p3_1rho"],
                                    "sigma_c2_1rho": PAPER["coulomb_sigma_c2_1rho"]},
             "full": PAPER["theta16"], "free": PAPER["free"], "two-step": {**PAPER["theta_d"], "rho": PAPER["rho"]}}
    for setup in ("dead-zone", "motor-disk", "motor-disk-coulomb", "full", "free", "two-step"):
        res = ctx.ident.get(setup)
        if res is None:
            continue
        for name, est in res.parameters.items():
            rows.append([setup, name, fmt(est.value), fmt(est.stderr, 2),
                         fmt_interval(est.ci95_low, est.ci95_high), fmt(paper.get(setup, {}).get(name))])
        if setup == "two-step":
            n = ctx.numbers.get("two-step", {})
            for k, pv in (("rho_1", PAPER["rho_1"]), ("rho_2", PAPER["rho_2"])):
                if k in n:
                    rows.append([setup, k, fmt(n[k]), "-", "-", fmt(pv)])
    return Table("Least-squares identifications, set-up by set-up", ["set-up", "parameter", "value", "std. error",
                                                                    "95 % interval", "paper"], rows,
                 "eq. (16) prints theta7 = 2.6060, theta8 = 7.1394 and the text 2.5194, 7.2813 (ERRATA item 3); "
                 "the paper's rho_1, rho_2 are theta3/theta1 and theta4/theta2 without the '- 1' (ERRATA item 2). "
                 "What each interval is about: v+ and v- are the apparent thresholds of the static curve (the dead "
                 "zone plus the disk's Coulomb friction over p3, which a static curve cannot separate); with the "
                 "wheel held to the arm the free set-up's p1 is p1 rho/(1 + rho) of model (9) (0.4 % lower); the "
                 "intervals cover the encoder noise through the differentiator, not the bias of a model that lacks "
                 "the rig's belt and Coulomb friction (the warnings of each set-up say where it shows).")


def _fits_table(ctx: ReproduceResult):

    rows = [[f.experiment, f.signal, f.model, f.params, fmt(f.fit, 3), fmt(f.rms, 3), f.figure or "-", f.note]
            for f in ctx.fits]
    return Table("Fits of the simulations to the rig's logs",
                 ["experiment", "signal", "model", "parameters", "fit [%]", "RMS error", "figure", "note"], rows,
                 "fit = 100 (1 - |y - y_sim| / |y - mean(y)|); velocities of the rig are obtained by differentiating "
                 "the encoder positions, as in the paper. Units of the RMS error: rad (q1, q2), rad/s (q4).")


def _steps_table(ctx: ReproduceResult):

    return Table("Steps", ["step", "paper", "status", "time [s]", "compiling [s]", "result"],
                 [[s.name, s.reference, s.status, f"{s.seconds:.2f}", f"{s.compile_seconds:.2f}" if
                   s.compile_seconds else "-", s.message] for s in ctx.steps],
                 "time: the step's own work, without compiling; compiling: the time numba spent compiling the "
                 "numerical kernels the step was the first to use. Compiling happens once per machine and version "
                 "(later runs load the kernels from numba's cache; 'iwp warmup' compiles them ahead).")


def _write_report(ctx: ReproduceResult) -> Path:

    n_pass = sum(s.passed is True for s in ctx.statements)
    n_fail = sum(s.passed is False for s in ctx.statements)
    n_nc = sum(s.passed is None for s in ctx.statements)
    failed = [s.name for s in ctx.steps if s.status == "failed"]
    elapsed = time.perf_counter() - ctx.extra.get("t_start", time.perf_counter())
    compiling = sum(s.compile_seconds for s in ctx.steps)
    summary = [
        ("paper", "Modelling an inertia wheel pendulum benchmark (the seed paper)"),
        ("run", f"iwp {__version__} reproduce{' --quick' if ctx.quick else ''} --seed {ctx.seed}, "
                f"{elapsed:.1f} s" + (f" ({compiling:.1f} s of it compiling numba kernels, once per machine)"
                                      if compiling >= 0.05 else "") + f", Python {platform.python_version()}"),
        ("statements", f"{n_pass} pass, {n_fail} fail, {n_nc} not checked (of {len(ctx.statements)})"),
        ("steps", "all completed" if not failed else "failed: " + ", ".join(failed)),
        ("final parameters", "refined" if "refined" in ctx.params else
         ("least squares" if "least-squares" in ctx.params else "none")),
    ]
    by_step: dict[str, list] = {}
    for f in ctx.figures:
        by_step.setdefault(f.step, []).append(FigureEntry(
            f.name, f.title, f.caption, f.svg, [str(p.relative_to(ctx.out)) for p in f.files]))
    sections = [_paper_numbers_section(ctx),
                Section("Parameters and fits", tables=[_parameter_table(ctx), _identification_table(ctx),
                                                       _fits_table(ctx)], anchor="parameters")]
    for rec in ctx.steps:
        if rec.name in ("report", "paper-numbers"):  # the page itself; the first section (its status in Notes)
            continue
        paras = [f"{rec.reference}. Status: {rec.status}" + (f" -- {rec.message}" if rec.message else "")]
        paras += _step_text(ctx, rec.name)
        sections.append(Section(rec.title, paragraphs=paras, figures=by_step.get(rec.name, []), anchor=rec.name))
    notes = list(ctx.notes) + [
        "The virtual rig: model (6) driven by the raw input through an asymmetric dead zone (5) with a start-up "
        "jump, a motor gain that may differ by the sign of the voltage (section 3.2), Coulomb and viscous friction "
        "at the disk, the rubber belt (15) with the play of figure 5, a winding resistance that differs between "
        "the sessions of section 5.1 and sections 5.2-5.3, 2000-count encoders sampled every 5 ms, and the rig's "
        "own feedforward with the paper's v_dz = 31 (see iwp.rig). Its values are calibrated so that the "
        "paper's procedures return the paper's numbers (iwp rig calibrate; the table 'The paper's numbers'). "
        "The identified model (9) is simpler than the rig, as the paper's model is simpler than its prototype.",
        "Where the paper disagrees with itself, this reproduction follows the derivation: ERRATA item 1 (the "
        "factor q3 of the rolling friction), ERRATA item 2 (rho_1 and rho_2 with the '- 1'), ERRATA item 4 (the "
        "free pendulum released from -1.422 rad) and ERRATA item 5 (Table 1's rounded sigma~_b1); the items are "
        "explained at the end of the page.",
    ]
    sections.append(Section("Notes", paragraphs=notes, tables=[_steps_table(ctx)], anchor="notes"))
    files = sorted({str(p.relative_to(ctx.out)) for p in ctx.files if p.exists()}
                   | {"report.html", "parameters.json", "results.json"})
    sections.append(Section("Files", paragraphs=[", ".join(files), _logs_text(ctx)], anchor="files"))
    rep = Report(
        title="Modelling an inertia wheel pendulum benchmark -- reproduced on the virtual rig",
        subtitle=("Every experiment of the paper's section 5 run on iwp's virtual rig, identified and compared the "
                  "way the paper does, with each of the paper's statements checked against the numbers found here."
                  + (" Quick mode: shortened experiments." if ctx.quick else "")),
        summary=summary, statements=ctx.statements, sections=sections, errata=dict(ERRATA))
    return write_html(rep, ctx.out / "report.html", force=True)


def _logs_text(ctx: ReproduceResult) -> str:
    """Where the experiments' logs are: in data/, or the commands that write each again."""
    names = list(ctx.data)
    if ctx.keep_logs:
        return "The experiment logs are in data/ (iwp's CSV format, docs/data-format.md)."
    truth = ("" if _is_default_truth(ctx) else " This run used a rig truth other than the default (parameters.json, "
             "'truth'): the commands give the default rig's logs unless given that truth too (--truth).")
    return ("The experiment logs are not kept here (a full run's logs are about 20 MB as CSV). Each one is "
            "written again, bit for bit, by the command beside its name: "
            + "; ".join(f"{n}: {log_command(n, quick=ctx.quick, seed=ctx.seed)}" for n in names)
            + "." + truth + " From Python, reproduce(..., keep_logs=True) keeps them in data/.")


def _sample_time(ctx: ReproduceResult) -> float | None:
    """The sample time of the full chirp [s], if it ran."""
    d = ctx.data.get("full-chirp")
    return float(d.Ts) if d is not None and getattr(d, "Ts", None) else None


def _step_text(ctx: ReproduceResult, name: str) -> list[str]:
    """Paragraphs under a step's heading: what was done and what the numbers say (from this run only)."""
    n = ctx.numbers
    out: list[str] = []
    if name == "dead-zone" and "dead-zone" in n:
        d = n["dead-zone"]
        out.append(f"Set-up 'dead-zone' (iwp.identify): a straight line through the moving part of each side of "
                   f"figure 2(a), extrapolated to q4 = 0, gives v+ = {d['v_dz_pos']:.2f} and v- = {d['v_dz_neg']:.2f}. "
                   f"The rig compensates with the paper's v_dz = 31 on both sides (figure 2b).")
    if name == "sines" and "sines-belt" in n:
        b = n["sines-belt"]
        rows = "; ".join(f"k/I2 = {v['k_over_I2']:g}: " + ", ".join(f"A = {A} {v[str(A)]['fit']:.1f} %"
                                                                     for A in (60, 40, 20)) for v in b.values())
        out.append(f"Flexible belt (15), fits of q4: {rows}. See the note on the paper's belt values below.")
    if name == "coulomb" and "coulomb" in n and "by_window" in n["coulomb"]:
        bw = n["coulomb"]["by_window"]
        out.append("The Coulomb estimate depends on how much of the chirp is used (first T seconds): "
                   + "; ".join(f"T = {k} s: p2(1+rho) = {v['p2_1rho']:.3g}, sigma_c2(1+rho) = "
                               f"{v['sigma_c2_1rho']:.3g}" for k, v in bw.items())
                   + f". The rig's truth: sigma_c2(1+rho) = {ctx.truth.lumped.sigma_c2_1rho:.3g}. As the chirp's "
                     "frequency rises the belt's dynamics, absent from the model (14), dominate the disk velocity.")
    if name == "full-setup" and "full-setup" in n:
        fs = n["full-setup"]
        rs = fs["relative_stderr"]
        th = fs["theta"]
        neg = [k for k in ("sigma_a1", "sigma_v1", "sigma_b1") if th[k] < 0]
        out.append(
            "The paper finds the eight parameters of (10)-(12) identified at once far from the free pendulum's and "
            "the prediction poor; its explanation is that the pendulum's small friction terms are not separated "
            "from the disk's in this set-up. Here: condition number of the scaled regressor (how far from "
            "independent the columns of the regression are once scaled alike: the larger, the more an error in the "
            "data moves the estimates, and the more the parameters trade off against each other) "
            f"{fs['condition_number']:.3g}; relative standard errors of the pendulum terms "
            + ", ".join(f"{k} {100 * v:.0f} %" for k, v in rs.items())
            + (f"; {', '.join(neg)} negative (unphysical)" if neg else "")
            + (f"; q1 fit of the simulation {fs['fit_q1']:.1f} %." if math.isfinite(fs.get("fit_q1", float("nan")))
               else "."))
        if fs.get("simulation_error"):
            out.append(f"The simulation with these parameters fails: {fs['simulation_error']}")
    if name == "free-pendulum" and "free" in n:
        out.append("Figure 8 uses the paper's free-pendulum model q3' = -xi (iwp model 'free-nowheel'), the model "
                   "that set-up theta^c identifies. On the rig the wheel does not turn while the pendulum swings "
                   "(its drive's friction holds it), so the arm carries the wheel's inertia and theta^c identifies "
                   "p1 rho/(1 + rho) and the sigmas scaled alike; the refinement (model 'free', wheel held) removes "
                   "this.")
    if name == "two-step" and "two-step" in n:
        t = n["two-step"]
        out.append(f"theta^d = [{t['p2']:.4g}, {t['p3']:.4g}, {t['p2_1rho']:.4g}, {t['p3_1rho']:.4g}] (paper "
                   f"[0.0106, 0.0286, 2.6111, 7.1395]); rho_1 = {t['rho_1']:.2f}, rho_2 = {t['rho_2']:.2f}, "
                   f"rho = {t['rho']:.2f} (rho_1 = theta3/theta1 - 1, rho_2 = theta4/theta2 - 1, ERRATA item 2).")
    if name == "full-chirp" and "full-chirp" in n:
        f = n["full-chirp"]
        txt = (f"Least-squares model: q1 fit {f['fit_q1']:.1f} %, q4 fit {f['fit_q4']:.1f} %; restarted at "
               f"{f['restart_time']:g} s the RMS error of q1 after the restart falls from "
               f"{f['rms_q1_after_restart_without']:.3g} to {f['rms_q1_after_restart_with']:.3g} rad.")
        r = n.get("refine", {})
        if "fit_ls_with_refined_p1" in r:
            c = r["changes"]["p1"]
            txt += (f" The error grows over the experiment mostly through p1: the least-squares p1 = "
                    f"{c['least-squares']:.4g} is {100 * abs(c['relative']):.2f} % off the refined {c['refined']:.4g}, "
                    f"a small frequency error whose phase accumulates over {ctx.data['full-chirp'].duration:g} s; with "
                    f"only p1 replaced the q1 fit is {r['fit_ls_with_refined_p1']:.1f} %.")
        out.append(txt)
    if name == "closed-loop" and "closed-loop" in n:
        c = n["closed-loop"]
        txt = (f"Amplitude max |q1| over the last {c['window']:g} s: rig {c['amplitude_rig']:.3f} rad, model (9) with "
               f"the least-squares parameters {c['amplitude_model']:.3f} rad (the paper: 2.58 rad measured).")
        if "amplitude_model_truth" in c:
            a = c["amplitude_model_truth"]
            txt += (f" Diagnostic with the rig's own lumped parameters: model (9) gives {a['truth']:.3f} rad with the "
                    f"rig's Coulomb friction of the disk and {a['truth_without_coulomb']:.3f} rad without it: the "
                    "amplitude is sensitive to the disk friction that model (9) represents by viscous damping only.")
        if "refine" in n and "amplitude_model" in n["refine"]:
            txt += f" With the refined parameters: {n['refine']['amplitude_model']:.3f} rad."
        out.append(txt)
    if name == "refine" and "refine" in n:
        r = n["refine"]
        st = r["stages"]
        out.append("The refinement starts from the least-squares parameters and minimises the simulation error "
                   "(iwp.refine_identification) in the paper's two steps: "
                   + ", ".join(st["free"]["free"]) + " on the free pendulum (output q1, wheel held), then "
                   + ", ".join(st["two-step"]["free"]) + " on the full chirp (outputs q1, q4), the initial states "
                   "estimated with them.")
        explained = False
        for key, label in (("free", "free pendulum"), ("two-step", "full chirp")):
            if st.get(key, {}).get("intervals"):
                out.append(f"Uncertainty of the refinement on the {label}: "
                           + ", ".join(f"{k} +- {fmt(v, 2)}" for k, v in st[key].get("stderr", {}).items())
                           + f"; {st[key]['intervals']}.")
                words = intervals_in_words(st[key]["intervals"], _sample_time(ctx), brief=explained)
                if words:  # in full where first named, then only what differs
                    out.append(words)
                    explained = True
        if "changes" in r:
            out.append("What it changes (refined / least squares - 1): " + ", ".join(
                f"{k} {100 * v['relative']:+.1f} %" for k, v in r["changes"].items() if v["relative"] is not None)
                + f". Full-chirp q1 fit {n.get('full-chirp', {}).get('fit_q1', float('nan')):.1f} -> "
                  f"{r['fit_full_chirp_q1']:.1f} %; free pendulum {r.get('fit_free_q1_before', float('nan')):.1f} -> "
                  f"{r.get('fit_free_q1', float('nan')):.1f} %.")
        if r.get("warnings"):
            out.append("Warnings of the refinement: " + "; ".join(r["warnings"]))
    return out



# --------------------------------------------------------------------------
# the paper's numbers, published against reproduced
# --------------------------------------------------------------------------
def _is_default_truth(ctx: ReproduceResult) -> bool:
    return ctx.truth is not None and ctx.truth == default_truth()


def _paper_numbers_section(ctx: ReproduceResult) -> Section:
    """Every published number against this run's, the misses explained with numbers, and the twin's provenance."""
    rows = ctx.extra.get("paper-rows")
    if not rows:
        return Section("The paper's numbers, published against reproduced",
                       paragraphs=["Not available: step 'paper-numbers' did not complete."], anchor="paper-numbers")
    graded = [r for r in rows if r.target.graded]
    within = sum(r.within for r in graded)
    table_rows = []
    for r in rows:
        t = r.target
        kind = "graded" if t.graded else "extra"
        table_rows.append([t.key + ("" if t.graded else " *"), t.quantity, t.reference, t.printed, fmt(r.reproduced),
                           f"{100 * r.deviation:+.2f} %" if math.isfinite(r.deviation) else "-",
                           f"{100 * t.tolerance:.0f} %", "yes" if r.within else "NO", kind])
    paras = [
        f"{within} of the {len(graded)} graded numbers are reproduced within their tolerance"
        + (" (quick mode: shortened experiments, so the numbers are not comparable)" if ctx.quick else "")
        + ". Each number is reproduced the way a reader would check it: the experiment run on this rig "
          "('iwp rig run NAME') and the paper's procedure applied with the command line's defaults ('iwp identify "
          "FILE --setup SETUP'); the statistics are those of iwp.calibration.statistics, which the calibration of "
          "the twin (iwp rig calibrate) uses too. Rows marked * are not graded: the same logs through the paper's "
          "least-squares criterion (13) as it is printed (below: '(13) as printed'), which adds up the squared "
          "errors of both rows of the regression without the weight iwp gives each row; numbers the paper prints "
          "twice; and the paper's words read as numbers."]
    extra = ctx.numbers.get("paper-numbers", {})
    record = None
    if _is_default_truth(ctx):
        record = truth_record().get("calibration")
    for r in rows:
        if r.within or not r.target.graded:
            continue
        t = r.target
        txt = (f"Not reproduced: {t.key} ({t.reference}): {fmt(r.reproduced)} against {t.published_text}. "
               f"{t.note}.")
        if t.key == "full_friction_far" and "friction_ratio_unweighted" in extra:
            txt += (f" On this run's full chirp the CLI's default set-up gives a ratio of "
                    f"{extra['friction_ratio_default']:.3g}; the paper's (13) as printed, the plain sum over both "
                    "rows, "
                    f"gives {extra['friction_ratio_unweighted']:.3g} (p1 = {extra['unweighted_p1']:.4g}) on the same "
                    "log: the published 76-930 is a property of the unweighted estimator, which lets the misfit of "
                    "the dq4/dt row (about 250 times the dq3/dt row's, the factor 1 + rho) move the pendulum terms "
                    "shared by both rows. No twin moves the weighted estimate there")
            reach = (record or {}).get("reach", {}).get(t.key)
            if reach:
                txt += (f": at the calibrated twin its residual is {reach['residual']:.3g} tolerances and its "
                        f"sensitivity to all {len(record.get('free', []))} calibrated parameters together is "
                        f"{reach['gradient_norm']:.3g} tolerances per unit change of their logarithms, so reaching "
                        f"it would need them changed by a factor of about {reach['factor']:.3g}")
            txt += "."
        paras.append(txt)
    tables = [Table("The paper's numbers: published against reproduced",
                    ["key", "quantity", "paper", "printed", "reproduced", "deviation", "tolerance", "within", ""],
                    table_rows, "deviation = reproduced / published - 1 (0 inside a published range). The targets, "
                                "their precision and tolerances are listed in the file paper_targets.json installed "
                                "with iwp (its path in Python: iwp.rig.TARGETS_FILE).")]
    tables.append(_truth_table(ctx))
    if record is not None:
        prov = truth_record().get("provenance", {})
        truth_doc = ctx.truth.to_dict()
        prow = []
        for key, src in prov.items():
            sec, _, f = key.partition(".")
            v = truth_doc.get(sec, {}).get(f) if f else truth_doc.get(sec)
            prow.append([key, fmt(v) if isinstance(v, (int, float)) else str(v), src])
        tables.append(Table("The twin's truth: where each value came from", ["field", "value", "source"], prow,
                            f"Calibration: {record.get('within', '')} within tolerance, cost "
                            f"{record.get('cost_start', float('nan')):.4g} -> {record.get('cost', float('nan')):.4g}, "
                            f"{record.get('nfev', 0)} twin evaluations; {record.get('message', '')}"))
    return Section("The paper's numbers, published against reproduced", paragraphs=paras, tables=tables,
                   anchor="paper-numbers")


def _truth_table(ctx: ReproduceResult) -> Table:
    """What the paper's procedures return against the twin's truth: the bias of a Table 1."""
    rows = []
    if ctx.truth is not None and "least-squares" in ctx.params:
        ls = ctx.params["least-squares"]
        tr = ctx.truth.for_session("5.2").lumped
        for key in ("p1", "p2", "p3", "rho", "sigma_a1", "sigma_v1", "sigma_b1", "p2_1rho", "p3_1rho"):
            a, b = getattr(ls, key), getattr(tr, key)
            rows.append([key, fmt(a), fmt(b), f"{100 * (a / b - 1):+.1f} %" if b else "-"])
    return Table("What the paper's procedures return against the twin's truth", ["parameter", "least squares",
                 "truth (session 5.2)", "difference"], rows,
                 "The least-squares model (free pendulum, then two-step; the analogue of Table 1) is not the rig's "
                 "truth: the procedures are biased by what model (9) leaves out (the disk held by its friction in "
                 "the free decay, Coulomb friction and the residual dead zone taken as viscous damping and gain, the "
                 "belt). On a twin that returns the paper's numbers, these differences are the paper's too.")
