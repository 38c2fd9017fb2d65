import json

import numpy as np
import pytest

from iwp.cli import main
from iwp.data import read_experiment
from iwp.models import Plant, table1
from iwp.sim import SimOptions, Tolerances, simulate
from iwp.sim.inputs import Chirp


def test_simulate_hopf_writes_csv(tmp_path, capsys):
    out = tmp_path / "sim.csv"
    assert main(["simulate", "--controller", "hopf", "--k1", "-10", "--k2", "0.1", "--x0", "0.1,0,0,0",
                 "--t-end", "20", "--out", str(out)]) == 0
    lines = out.read_text().splitlines()
    header = next(line for line in lines if not line.startswith("#"))
    assert header == "t,q1,q2,q3,q4,u"
    data = np.loadtxt(out, delimiter=",", comments="#", skiprows=1 + sum(line.startswith("#") for line in lines))
    assert data.shape == (4001, 6)
    np.testing.assert_allclose(data[:, 5], -10 * data[:, 3] + 0.1 * data[:, 3] ** 3, atol=1e-9)


def test_simulate_chirp_and_params_file(tmp_path):
    pfile = tmp_path / "p.json"
    pfile.write_text(json.dumps({"kind": "lumped", "parameters": table1().replace(p1=30.0).to_dict()}))
    out = tmp_path / "chirp.csv"
    assert main(["simulate", "--input", "chirp", "--amplitude", "60", "--w0", "3", "--tau", "100", "--t-end", "3",
                 "--params", str(pfile), "--out", str(out)]) == 0
    # the run used the file's parameters (p1 = 30), not Table 1's: the same as simulate() with them
    log = read_experiment(out)
    ref = simulate(Plant(table1().replace(p1=30.0)), input=Chirp(60.0, 3.0, 100.0), t_end=3.0,
                   options=SimOptions(tolerances=Tolerances(rtol=1e-10, atol=1e-10)))
    np.testing.assert_allclose(log.q1, ref.q1, atol=1e-12)
    other = simulate(Plant(table1()), input=Chirp(60.0, 3.0, 100.0), t_end=3.0,
                     options=SimOptions(tolerances=Tolerances(rtol=1e-10, atol=1e-10)))
    assert np.max(np.abs(other.q1 - log.q1)) > 1e-3


def _one_line_error(capsys):
    err = capsys.readouterr().err.strip()
    assert err.startswith("iwp: error:") and "\n" not in err and "Traceback" not in err
    return err


@pytest.mark.parametrize(
    "args,match",
    [
        (["--input", "bogus", "--t-end", "1"], "--input 'bogus': unknown"),
        (["--controller", "pid", "--t-end", "1"], "--controller 'pid': unknown"),
        (["--input", "sine", "--t-end", "-1"], "--t-end must be > --t0"),
        (["--input", "sine", "--t-end", "1", "--ts", "0"], "--ts must be > 0"),
        (["--input", "sine", "--t-end", "1", "--params", "nope.json"], "no such parameter file"),
        (["--input", "sine", "--t-end", "1", "--draws", "50"], "--draws is for the draws of --band monte-carlo"),
        (["--input", "sine", "--t-end", "1", "--k1", "-5"], "--k1 is a setting of --controller hopf; --input sine "
                                                             "takes none"),
        (["--controller", "hopf", "--t-end", "1", "--omega", "3"], "--omega is a setting of --input sine; "
                                                                   "--controller hopf takes none"),
        (["--t-end", "1", "--amplitude", "5"], "--amplitude is a setting of --input constant or --input sine"),
        (["--input", "sine", "--t-end", "1", "--band", "linear", "--seed", "3"],
         "--seed is for the draws of --band monte-carlo"),
    ],
)
def test_simulate_bad_input_exit_2(tmp_path, capsys, args, match):
    assert main(["simulate", *args, "--out", str(tmp_path / "x.csv")]) == 2
    assert match in _one_line_error(capsys)


def test_simulate_x0_of_two_values_exit_2(tmp_path, capsys):
    # --x0 is Q1 or Q1,Q2,Q3,Q4 in every command (tests/test_cli_vocabulary.py): argparse refuses the rest
    with pytest.raises(SystemExit) as e:
        main(["simulate", "--input", "sine", "--t-end", "1", "--x0", "1,2", "--out", str(tmp_path / "x.csv")])
    assert e.value.code == 2
    assert "argument --x0: expected Q1 or Q1,Q2,Q3,Q4, got 2 numbers" in _one_line_error(capsys)
    assert not (tmp_path / "x.csv").exists()


def test_nan_parameter_file_exit_2(tmp_path, capsys):
    pfile = tmp_path / "p.json"
    pfile.write_text(json.dumps({**table1().to_dict(), "p2": -1.0}))
    assert main(["simulate", "--input", "sine", "--t-end", "1", "--params", str(pfile),
                 "--out", str(tmp_path / "x.csv")]) == 2
    assert "'p2' must be >= 0" in _one_line_error(capsys)


def test_diverging_simulation_exit_2(tmp_path, capsys):
    pfile = tmp_path / "p.json"
    pfile.write_text(json.dumps(table1().to_dict()))
    # a huge Hopf gain destabilises the loop without bound
    assert main(["simulate", "--controller", "hopf", "--k1", "-1000", "--k2", "-50", "--x0", "0.5,0,0,0",
                 "--t-end", "50", "--out", str(tmp_path / "x.csv")]) == 2
    assert "diverged" in _one_line_error(capsys)


def test_no_overwrite_without_force(tmp_path, capsys):
    out = tmp_path / "a.csv"
    out.write_text("precious")
    assert main(["simulate", "--input", "sine", "--t-end", "1", "--out", str(out)]) == 2
    assert "exists" in _one_line_error(capsys)
    assert out.read_text() == "precious"
    assert main(["simulate", "--input", "sine", "--t-end", "1", "--out", str(out), "--force"]) == 0
    assert out.read_text() != "precious"


def test_argparse_errors_exit_2(capsys):
    with pytest.raises(SystemExit) as e:
        main(["simulate", "--input", "sine"])  # missing --t-end and --out
    assert e.value.code == 2


def test_identify_out_of_a_full_fit_is_admissible_and_simulated(tmp_path, capsys):
    """iwp identify --out writes what iwp simulate --params accepts: the full set-up's friction that the paper's
    unconstrained (13) gives negative on the default truth plant (eq. (16)) is held at its prior instead."""
    log = tmp_path / "fc.csv"
    assert main(["rig", "run", "full-chirp", "--duration", "40", "--out", str(log)]) == 0
    pfile = tmp_path / "full.json"
    assert main(["identify", str(log), "--setup", "full", "--out", str(pfile)]) == 0
    doc = json.loads(pfile.read_text())
    assert "unconstrained_fit" not in doc and doc["identification"]["details"]["held"]
    assert all(doc["parameters"][n] >= 0 for n in ("sigma_a1", "sigma_v1", "sigma_b1"))
    out = tmp_path / "sim.csv"
    assert main(["simulate", "--params", str(pfile), "--input", "chirp", "--t-end", "2", "--out", str(out)]) == 0
    assert "unconstrained fit" not in capsys.readouterr().err
