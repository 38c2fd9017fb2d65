"""A corpus of broken inputs for every command (used by tests/test_hostile.py).

Run as a script to write the corpus into a folder, one sub-folder per case
with its files and ``argv.txt`` (the command line, ``{d}`` for the folder)::

    python tests/hostile_corpus.py CORPUS_DIR

Every case is bad input: the command must exit with status 2 and one line
``iwp: error: ...`` on stderr, write nothing, and leave its input files as
they were.
"""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["Case", "cases", "write_corpus", "good_log_text"]


@dataclass(frozen=True)
class Case:
    """One hostile case: files written into a fresh folder, then ``iwp *argv`` run there."""

    name: str
    argv: tuple[str, ...]
    files: dict[str, bytes] = field(default_factory=dict)
    #: words the error line must contain (the flag, file or column it names)
    names: tuple[str, ...] = ()


# --------------------------------------------------------------------------
# a good log to break
# --------------------------------------------------------------------------
def _good_columns(n: int = 3000, Ts: float = 0.005, with_input: bool = True) -> dict[str, np.ndarray]:
    t = Ts * np.arange(n)
    step = 2 * np.pi / 2000
    q1 = np.round(0.6 * np.exp(-0.03 * t) * np.cos(5.1 * t) / step) * step
    q2 = np.round((40 * np.sin(3 * t)) / step) * step
    cols = {"t": t, "q1": q1, "q2": q2}
    if with_input:
        cols["u"] = 40 * np.sin(3 * t)
    return cols


def _csv(cols: dict[str, np.ndarray], header: str | None = None) -> bytes:
    names = list(cols)
    rows = np.column_stack([cols[k] for k in names]).tolist()
    lines = [header if header is not None else ",".join(names)]
    lines += [",".join(repr(float(v)) for v in row) for row in rows]
    return ("\n".join(lines) + "\n").encode()


def good_log_text(with_input: bool = True) -> bytes:
    """A valid log (CSV bytes): a decaying swing at 5 ms, quantised like a 2000-count encoder."""
    return _csv(_good_columns(with_input=with_input))


def _broken_logs() -> dict[str, bytes]:
    """name -> CSV bytes of a log that no command may accept."""
    g = _good_columns()
    out: dict[str, bytes] = {}
    out["empty"] = b""
    out["blank"] = b"\n\n   \n"
    out["header-only"] = b"t,q1,q2,u\n"
    out["binary"] = bytes(range(256)) * 20
    out["nul-in-text"] = good_log_text()[:200] + b"\x00\x00" + good_log_text()[200:400]
    out["latin1"] = "t,q1,q2,u,\xe9\n0,0,0,0,0\n".encode("latin-1")
    out["huge-header"] = b"t,q1,q2," + b"x" * 1_000_000 + b"\n0,0,0,0\n"
    out["one-row"] = b"t,q1,q2\n0,0,0\n"
    out["three-rows"] = b"t,q1,q2\n0,0,0\n0.005,0,0\n0.01,0,0\n"
    for name, col, val in (("nan-q1", "q1", float("nan")), ("inf-t", "t", float("inf")),
                           ("huge-q1", "q1", 1e308), ("huge-u", "u", 1e300), ("huge-q2", "q2", -1e200)):
        c = {k: v.copy() for k, v in g.items()}
        c[col][57] = val
        out[name] = _csv(c)
    c = {k: v.copy() for k, v in g.items()}
    c["q1"] = c["q1"] * 0 + 1e308
    out["all-huge"] = _csv(c)
    c = {k: v.copy() for k, v in g.items()}
    c["t"] = 1e300 + c["t"]
    out["t-near-1e300"] = _csv(c)
    c = {k: v.copy() for k, v in g.items()}
    c["t"] = c["t"] * 1e-9
    out["dt-1e-12"] = _csv(c)
    c = {k: v.copy() for k, v in g.items()}
    c["t"] = c["t"] * 1000.0
    out["t-in-ms"] = _csv(c)
    c = {k: v.copy() for k, v in g.items()}
    c["t"][[100, 101]] = c["t"][[101, 100]]
    out["t-not-increasing"] = _csv(c)
    c = {k: v.copy() for k, v in g.items()}
    c["t"][101] = c["t"][100]
    out["t-repeated"] = _csv(c)
    c = {k: v.copy() for k, v in g.items()}
    c["t"][1500:] += 0.7
    out["t-gap"] = _csv(c)
    c = {k: v.copy() for k, v in g.items()}
    c["q1"] = np.rad2deg(c["q1"])
    out["degrees"] = _csv(c)
    out["no-q1"] = _csv({k: v for k, v in g.items() if k != "q1"})
    out["no-t"] = _csv({k: v for k, v in g.items() if k != "t"})
    out["only-t"] = _csv({"t": g["t"]})
    out["dup-column"] = _csv(g, header="t,q1,q1,u")
    out["both-u-v-ragged"] = b"t,q1,q2,u,v\n0,0,0,1\n"
    text = good_log_text().decode().splitlines()
    text[57] = text[57].replace(",", ",abc,", 1)
    out["text-cell"] = ("\n".join(text) + "\n").encode()
    text = good_log_text().decode().splitlines()
    text[80] = text[80].rsplit(",", 1)[0]
    out["short-row"] = ("\n".join(text) + "\n").encode()
    text = good_log_text().decode().splitlines()
    text[80] = text[80] + ",1,2"
    out["long-row"] = ("\n".join(text) + "\n").encode()
    text = good_log_text().decode().splitlines()
    text[90] = text[90].replace(",", ";")
    out["mixed-delimiters"] = ("\n".join(text) + "\n").encode()
    out["semicolon-decimal-comma"] = b"t;q1;q2\n0,0;0,1;0\n0,005;0,1;0\n"
    out["json-not-csv"] = json.dumps({"t": [0, 1], "q1": [0, 1]}).encode()
    rng = np.random.default_rng(3)
    c = {k: v.copy() for k, v in g.items()}
    step = 2 * np.pi / 2000
    c["q1"] = np.round(rng.normal(0.0, 0.05, c["t"].size) / step) * step
    del c["u"]
    out["pure-noise"] = _csv(c)
    c = {k: v.copy() for k, v in g.items()}
    c["q1"] = c["q1"] * 0.0
    c["q2"] = c["q2"] * 0.0
    del c["u"]
    out["all-zero"] = _csv(c)
    return out


def _broken_params() -> dict[str, bytes]:
    """name -> bytes of a parameter file that no command may accept."""
    good = {"p1": 26.0, "p2": 0.01, "p3": 0.03, "rho": 247.0, "sigma_a1": 0.005, "sigma_v1": 0.008,
            "sigma_b1": 0.0005}
    out: dict[str, bytes] = {}
    out["empty"] = b""
    out["not-json"] = b"p1 = 26\n"
    out["array"] = b"[1, 2, 3]"
    out["string"] = b'"table1"'
    out["nested-deep"] = b"[" * 100_000 + b"]" * 100_000
    out["nested-deep-object"] = b'{"a":' * 50_000 + b"1" + b"}" * 50_000
    out["binary"] = bytes(range(256))
    for name, key, val in (("p1-negative", "p1", -1.0), ("p1-zero", "p1", 0.0), ("rho-huge", "rho", 1e300),
                           ("rho-zero", "rho", 0.0), ("p3-huge", "p3", 1e200), ("p1-string", "p1", "abc"),
                           ("p1-null", "p1", None), ("p1-bool", "p1", True), ("p1-list", "p1", [1, 2]),
                           ("sigma-negative", "sigma_v1", -0.5)):
        d = dict(good)
        d[key] = val
        out[name] = json.dumps(d).encode()
    d = dict(good)
    d["p1"] = float("nan")
    out["p1-nan"] = json.dumps(d).encode()  # NaN literal, not JSON
    d = dict(good)
    d["p1"] = float("inf")
    out["p1-inf"] = json.dumps(d).encode()
    d = dict(good)
    del d["p1"]
    out["missing-p1"] = json.dumps(d).encode()
    d = dict(good)
    d["bogus"] = 1.0
    out["unknown-key"] = json.dumps(d).encode()
    out["unknown-kind"] = json.dumps({"kind": "quantum", "parameters": good}).encode()
    out["parameters-not-object"] = json.dumps({"kind": "lumped", "parameters": [1, 2]}).encode()
    out["huge-number-text"] = b'{"p1": 1' + b"0" * 5000 + b"}"
    return out


# --------------------------------------------------------------------------
# the cases
# --------------------------------------------------------------------------
def cases() -> list[Case]:
    """Every hostile case (about 300)."""
    out: list[Case] = []
    logs = _broken_logs()
    good = good_log_text()
    good_free = good_log_text(with_input=False)
    # broken logs through every command that reads a log
    for name, data in logs.items():
        f = {"log.csv": data}
        setup = "free" if name in ("pure-noise", "all-zero") else "full"
        out.append(Case(f"identify/{name}", ("identify", "{d}/log.csv", "--setup", setup, "--out", "{d}/P.json"), f,
                        ("log.csv",)))
        if name in ("pure-noise", "all-zero"):
            continue  # a log the model does not fit is a valid input of validate (a low fit), and of convert
        out.append(Case(f"validate/{name}", ("validate", "{d}/log.csv", "--params", "table1", "--plot",
                                             "{d}/fig.png"), f, ("log.csv",)))
        out.append(Case(f"convert/{name}", ("convert", "{d}/log.csv", "--out", "{d}/out.parquet"), f, ("log.csv",)))
        out.append(Case(f"report/{name}", ("report", "{d}/log.csv", "--out", "{d}/rep"), f, ("log.csv",)))
    # broken parameter files through every command that reads one
    for name, data in _broken_params().items():
        f = {"P.json": data, "log.csv": good}
        out.append(Case(f"simulate-params/{name}", ("simulate", "--params", "{d}/P.json", "--t-end", "1", "--out",
                                                    "{d}/s.csv"), f, ("P.json",)))
        out.append(Case(f"design-params/{name}", ("design", "hopf", "--params", "{d}/P.json", "--amplitude",
                                                  "0.5"), f, ("P.json",)))
        out.append(Case(f"validate-params/{name}", ("validate", "{d}/log.csv", "--params", "{d}/P.json"), f,
                        ("P.json",)))
        out.append(Case(f"identify-pendulum/{name}", ("identify", "{d}/log.csv", "--setup", "two-step",
                                                      "--pendulum", "{d}/P.json", "--out", "{d}/out.json"), f,
                        ("P.json",)))
    # arguments of simulate
    sim = ("simulate", "--out", "{d}/s.csv")
    for name, args, flag in (
        ("t-end-1e12", ("--t-end", "1e12"), "--t-end"),
        ("ts-1e-9", ("--t-end", "5", "--ts", "1e-9"), "--ts"),
        ("ts-longer-than-run", ("--t-end", "5", "--ts", "100"), "--ts"),
        ("ts-zero", ("--t-end", "5", "--ts", "0"), "--ts"),
        ("ts-nan", ("--t-end", "5", "--ts", "nan"), "--ts"),
        ("t-end-nan", ("--t-end", "nan"), "--t-end"),
        ("t-end-inf", ("--t-end", "inf"), "--t-end"),
        ("t-end-negative", ("--t-end", "-5"), "--t-end"),
        ("t-end-text", ("--t-end", "five"), "--t-end"),
        ("x0-1e200", ("--t-end", "5", "--x0", "0,0,0,1e200"), "--x0"),
        ("x0-1e300", ("--t-end", "5", "--x0", "1e300,0,0,0"), "--x0"),
        ("x0-nan", ("--t-end", "5", "--x0", "nan,0,0,0"), "--x0"),
        ("x0-short", ("--t-end", "5", "--x0", "0.1,0"), "--x0"),
        ("x0-text", ("--t-end", "5", "--x0", "a,b,c,d"), "--x0"),
        ("x0-empty", ("--t-end", "5", "--x0", ""), "--x0"),
        ("rtol-zero", ("--t-end", "5", "--rtol", "0"), "--rtol"),
        ("atol-negative", ("--t-end", "5", "--atol", "-1"), "--atol"),
        ("amplitude-inf", ("--t-end", "5", "--input", "sine", "--amplitude", "inf"), "--amplitude"),
        ("omega-nan", ("--t-end", "5", "--input", "sine", "--omega", "nan"), "--omega"),
        ("k1-nan", ("--t-end", "5", "--controller", "hopf", "--k1", "nan"), "--k1"),
        ("saturation-negative", ("--t-end", "5", "--saturation", "-1"), "--saturation"),
        ("saturation-nan", ("--t-end", "5", "--saturation", "nan"), "--saturation"),
        ("model-bogus", ("--t-end", "5", "--model", "bogus"), "--model"),
        ("input-bogus", ("--t-end", "5", "--input", "bogus"), "--input"),
        ("controller-bogus", ("--t-end", "5", "--controller", "pid"), "--controller"),
        ("params-missing", ("--t-end", "5", "--params", "{d}/nope.json"), "nope.json"),
        ("params-folder", ("--t-end", "5", "--params", "{d}"), "--params"),
        ("plot-bad-extension", ("--t-end", "5", "--plot", "{d}/fig.xyz"), "--plot"),
        ("plot-no-extension", ("--t-end", "5", "--plot", "{d}/fig"), "--plot"),
        ("plot-is-out", ("--t-end", "5", "--plot", "{d}/s.csv"), "--plot"),
        ("t0-nan", ("--t-end", "5", "--t0", "nan"), "--t0"),
    ):
        out.append(Case(f"simulate/{name}", sim + args, {}, (flag,)))
    out.append(Case("simulate/out-bad-extension", ("simulate", "--t-end", "1", "--out", "{d}/s.xyz"), {}, ("--out",)))
    out.append(Case("simulate/out-is-folder", ("simulate", "--t-end", "1", "--out", "{d}/sub"), {"sub/keep.txt": b"x"},
                    ("--out",)))
    out.append(Case("simulate/out-parent-is-file", ("simulate", "--t-end", "1", "--out", "{d}/f.txt/s.csv"),
                    {"f.txt": b"x"}, ("--out",)))
    out.append(Case("simulate/out-exists", ("simulate", "--t-end", "1", "--out", "{d}/s.csv"), {"s.csv": b"old"},
                    ("--force",)))
    # arguments of identify
    ident = ("identify", "{d}/log.csv", "--setup", "full", "--out", "{d}/P.json")
    for name, args, flag in (
        ("t-start-after-end", ("--t-start", "10", "--t-end", "5"), "--t-start"),
        ("t-start-nan", ("--t-start", "nan"), "--t-start"),
        ("t-start-beyond", ("--t-start", "1e6"), "--t-start"),
        ("window-zero", ("--window", "0"), "--window"),
        ("window-huge", ("--window", "1000000"), "--window"),
        ("polyorder-huge", ("--polyorder", "60"), "--polyorder"),
        ("cutoff-negative", ("--method", "butter", "--cutoff", "-1"), "--cutoff"),
        ("cutoff-beyond-nyquist", ("--method", "butter", "--cutoff", "1000"), "--cutoff"),
        ("order-zero", ("--method", "butter", "--order", "0"), "--order"),
        ("setup-bogus", ("--setup", "bogus"), "--setup"),
        ("base-missing", ("--base", "{d}/nope.json"), "nope.json"),
        ("p2-wrong-setup", ("--p2", "0.01"), "--p2"),
        ("out-bad-extension", ("--out", "{d}/P.csv"), "--out"),
    ):
        out.append(Case(f"identify-args/{name}", ident + args, {"log.csv": good}, (flag,)))
    out.append(Case("identify-args/same-file-twice", ("identify", "{d}/log.csv", "{d}/log.csv", "--setup", "full"),
                    {"log.csv": good}, ("log.csv",)))
    out.append(Case("identify-args/copy-given-twice", ("identify", "{d}/log.csv", "{d}/copy.csv", "--setup", "full"),
                    {"log.csv": good, "copy.csv": good}, ("copy.csv",)))
    out.append(Case("identify-args/missing-file", ("identify", "{d}/nope.csv", "--setup", "full"), {}, ("nope.csv",)))
    out.append(Case("identify-args/folder-as-file", ("identify", "{d}", "--setup", "full"), {}, ()))
    out.append(Case("identify-args/free-with-input", ("identify", "{d}/log.csv", "--setup", "free"), {"log.csv": good},
                    ("log.csv",)))
    # arguments of validate
    val = ("validate", "{d}/log.csv", "--params", "table1")
    for name, args, flag in (
        ("restart-nan", ("--restart", "nan"), "--restart"),
        ("restart-beyond", ("--restart", "1e6"), "--restart"),
        ("t-start-beyond", ("--t-start", "1e6"), "--t-start"),
        ("plot-bad-extension", ("--plot", "{d}/fig.xyz"), "--plot"),
        ("model-bogus", ("--model", "bogus"), "--model"),
    ):
        out.append(Case(f"validate-args/{name}", val + args, {"log.csv": good}, (flag,)))
    # arguments of convert
    conv = ("convert", "{d}/log.csv")
    for name, args, flag in (
        ("out-bad-extension", ("--out", "{d}/x.xyz"), "--out"),
        ("out-exists", ("--out", "{d}/x.csv"), "--force"),
        ("out-is-input", ("--out", "{d}/log.csv", "--force"), "--out"),
        ("from-bogus", ("--out", "{d}/y.csv", "--from", "bogus"), "--from"),
        ("out-missing", (), "--out"),
    ):
        out.append(Case(f"convert-args/{name}", conv + args, {"log.csv": good, "x.csv": b"old"}, (flag,)))
    out.append(Case("convert-args/missing-input", ("convert", "{d}/nope.csv", "--out", "{d}/y.csv"), {}, ("nope.csv",)))
    # arguments of design
    for name, args, flag in (
        ("amplitude-nan", ("hopf", "--amplitude", "nan"), "--amplitude"),
        ("amplitude-beyond-pi", ("hopf", "--amplitude", "4"), "--amplitude"),
        ("amplitude-negative", ("hopf", "--amplitude", "-1"), "--amplitude"),
        ("amplitude-huge", ("hopf", "--amplitude", "1e300"), "--amplitude"),
        ("k1-nan", ("hopf", "--amplitude", "0.5", "--k1", "nan"), "--k1"),
        ("plot-bad-extension", ("hopf", "--amplitude", "0.5", "--plot", "{d}/f.xyz"), "--plot"),
        ("no-subcommand", (), ""),
    ):
        out.append(Case(f"design-args/{name}", ("design",) + args, {}, (flag,)))
    # the virtual rig
    for name, args, flag in (
        ("duration-1e9", ("run", "full-chirp", "--duration", "1e9", "--out", "{d}/r.csv"), "--duration"),
        ("duration-negative", ("run", "full-chirp", "--duration", "-1", "--out", "{d}/r.csv"), "--duration"),
        ("duration-nan", ("run", "full-chirp", "--duration", "nan", "--out", "{d}/r.csv"), "--duration"),
        ("name-bogus", ("run", "bogus", "--out", "{d}/r.csv"), "bogus"),
        ("noise-negative", ("run", "free-pendulum", "--noise", "-1", "--out", "{d}/r.csv"), "--noise"),
        ("x0-huge", ("run", "free-pendulum", "--x0", "1e300", "--out", "{d}/r.csv"), "--x0"),
        ("out-bad-extension", ("run", "free-pendulum", "--out", "{d}/r.xyz"), "--out"),
        ("truth-missing", ("run", "free-pendulum", "--truth", "{d}/nope.json", "--out", "{d}/r.csv"), "nope.json"),
    ):
        out.append(Case(f"rig/{name}", ("rig",) + args, {}, (flag,)))
    # reports and their folder policy
    out.append(Case("report/out-not-empty", ("report", "{d}/log.csv", "--out", "{d}/rep"),
                    {"log.csv": good, "rep/old.txt": b"x"}, ("--force",)))
    out.append(Case("report/out-is-file", ("report", "{d}/log.csv", "--out", "{d}/rep"),
                    {"log.csv": good, "rep": b"x"}, ("--out",)))
    out.append(Case("report/one-good-one-huge", ("report", "{d}/log.csv", "{d}/bad.csv", "--out", "{d}/rep"),
                    {"log.csv": good, "bad.csv": logs["all-huge"]}, ("bad.csv",)))
    out.append(Case("reproduce/out-not-empty", ("reproduce", "--out", "{d}/rep"), {"rep/old.txt": b"x"}, ("--force",)))
    out.append(Case("control/swingup-out-not-empty", ("control", "swingup", "--out", "{d}/sw"), {"sw/old.txt": b"x"},
                    ("--force",)))
    out.append(Case("free/wrong-setup-on-free-log", ("identify", "{d}/log.csv", "--setup", "full"),
                    {"log.csv": good_free}, ("log.csv",)))
    out += _issue23_cases(good)
    return out


#: a rig description of the good log (columns t, q1, q2, u)
_RIG = {"kind": "iwp-rig", "name": "test rig", "sample_period": 0.005, "time": {"column": "t", "unit": "s"},
        "pendulum": {"column": "q1", "unit": "rad"}, "wheel": {"column": "q2", "quantity": "angle", "unit": "rad"},
        "input": {"column": "u", "kind": "duty"}}


def _rig(**changes) -> bytes:
    doc = json.loads(json.dumps(_RIG))
    for key, val in changes.items():
        part, _, sub = key.partition("__")
        if sub:
            doc[part][sub] = val
        else:
            doc[part] = val
    return json.dumps(doc).encode()


def _issue23_cases(good: bytes) -> list[Case]:
    """The hostile findings of issue 23, each a case that failed before."""
    params = {"p1": 26.0, "p2": 0.01, "p3": 0.03, "rho": 247.0, "sigma_a1": 0.005, "sigma_v1": 0.008,
              "sigma_b1": 0.0005}
    out = [
        # output folders named like files
        Case("issue23/reproduce-out-html", ("reproduce", "--out", "{d}/report.html"), {}, ("--out", "report.html")),
        Case("issue23/report-out-html", ("report", "{d}/log.csv", "--out", "{d}/rep.html"), {"log.csv": good},
             ("--out", "rep.html")),
        Case("issue23/swingup-out-json", ("control", "swingup", "--out", "{d}/s.json"), {}, ("--out", "s.json")),
        # control lqr --ts
        *[Case(f"issue23/lqr-ts-{name}", ("control", "lqr", "--ts", ts), {}, ("--ts",))
          for name, ts in (("nan", "nan"), ("negative", "-0.01"), ("inf", "inf"), ("1e308", "1e308"), ("10", "10"))],
        # the virtual rig's options beyond any rig
        Case("issue23/rig-noise-1e300", ("rig", "run", "free-pendulum", "--noise", "1e300", "--out", "{d}/r.csv"), {},
             ("--noise",)),
        Case("issue23/rig-amplitude-1e308", ("rig", "run", "sine-40", "--amplitude", "1e308", "--out", "{d}/r.csv"),
             {}, ("--amplitude",)),
        # convert: the extension contradicts --to
        Case("issue23/convert-parquet-into-mat", ("convert", "{d}/log.csv", "--to", "parquet", "--out", "{d}/o.mat"),
             {"log.csv": good}, ("--out", "--to", "o.parquet")),
        # parameter files
        Case("issue23/params-fit-json", ("validate", "{d}/log.csv", "--params", "{d}/fit.json"),
             {"log.csv": good, "fit.json": json.dumps({"kind": "iwp-fit", "train": []}).encode()},
             ("--params", "fit.json", "parameters.json")),
        Case("issue23/params-unknown-model", ("validate", "{d}/log.csv", "--params", "{d}/P.json"),
             {"log.csv": good, "P.json": json.dumps({"kind": "lumped", "model": "nonsense",
                                                     "parameters": params}).encode()},
             ("--params", "P.json", "nonsense")),
        Case("issue23/params-401-digits", ("simulate", "--params", "{d}/P.json", "--t-end", "1", "--out", "{d}/s.csv"),
             {"P.json": json.dumps(params).replace("247.0", "1" + "0" * 400).encode()}, ("P.json", "401 digits")),
        # a log without a header row
        Case("issue23/log-without-header", ("validate", "{d}/log.csv", "--params", "table1"),
             {"log.csv": good.split(b"\n", 1)[1]}, ("log.csv", "no header")),
        # rig descriptions
        Case("issue23/rig-absurd-zero", ("fit", "{d}/log.csv", "--rig", "{d}/rig.json", "--out", "{d}/F"),
             {"log.csv": good, "rig.json": _rig(pendulum__zero=1e6)}, ("rig.json", "pendulum.zero")),
        Case("issue23/rig-absurd-offset", ("fit", "{d}/log.csv", "--rig", "{d}/rig.json", "--out", "{d}/F"),
             {"log.csv": good, "rig.json": _rig(pendulum__offset=1e6)}, ("rig.json", "pendulum.offset")),
        Case("issue23/rig-sample-period-contradicts-time", ("fit", "{d}/log.csv", "--rig", "{d}/rig.json", "--out",
                                                            "{d}/F"),
             {"log.csv": good, "rig.json": _rig(sample_period=0.01)}, ("sample_period",)),
        Case("issue23/rig-sample-period-contradicts-t-without-time-column",
             ("fit", "{d}/log.csv", "--rig", "{d}/rig.json", "--out", "{d}/F"),
             {"log.csv": good, "rig.json": _rig(sample_period=0.01, time={"column": None})}, ("sample_period",)),
        Case("issue23/rig-401-digits", ("fit", "{d}/log.csv", "--rig", "{d}/rig.json", "--out", "{d}/F"),
             {"log.csv": good, "rig.json": _rig(pendulum__unit="counts").replace(
                 b'"unit": "counts"', b'"unit": "counts", "counts_per_rev": 1' + b"0" * 400)},
             ("rig.json", "401 digits")),
    ]
    return out


def write_corpus(folder: str | Path) -> list[Path]:
    """Write every case into ``folder/<case name>/`` with its files and ``argv.txt``."""
    root = Path(folder)
    made = []
    for case in cases():
        d = root / case.name.replace("/", "__")
        d.mkdir(parents=True, exist_ok=False)
        for rel, data in case.files.items():
            p = d / rel
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_bytes(data)
        (d / "argv.txt").write_text("\n".join(case.argv) + "\n")
        made.append(d)
    return made


if __name__ == "__main__":  # pragma: no cover - a tool
    if len(sys.argv) != 2:
        sys.exit("usage: python tests/hostile_corpus.py CORPUS_DIR")
    print(f"wrote {len(write_corpus(sys.argv[1]))} cases into {sys.argv[1]}")
