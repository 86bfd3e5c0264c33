"""The Python module against the frichb program: the same scene gives the same numbers and the
same files; refusals carry the file, line and key; Ctrl-C stops a call promptly."""
import _thread
import csv
import json
import os
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import frichb

SOURCE = Path(os.environ.get("FRICHB_SOURCE_DIR", Path(__file__).resolve().parents[2]))
EXE = os.environ.get("FRICHB_EXE", str(SOURCE / "build" / "bin" / "frichb"))
QUICKSTART = SOURCE / "configs" / "quickstart_friction_oscillator.yaml"
TWO_DOF = SOURCE / "configs" / "two_dof_blade_damper.yaml"


def frichb_cli(*arguments):
    """Runs the program (no shell) and returns its completed process."""
    return subprocess.run([EXE, "--log-level", "warn", *arguments], capture_output=True,
                          text=True, check=False)


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], np.array([[float(x) for x in row] for row in rows[1:]])


def test_run_gives_the_numbers_and_files_of_the_program(tmp_path):
    result = frichb.run(QUICKSTART, plots=False)
    assert result.status == 0 and result.termination == "completed", result.message
    cli = frichb_cli("run", str(QUICKSTART), "-o", str(tmp_path / "cli"), "--set",
                     "output.plots=false")
    assert cli.returncode == 0, cli.stderr
    header, rows = read_csv(tmp_path / "cli" / "response.csv")
    assert result.columns == header
    assert result.table.shape == rows.shape and rows.shape[0] > 50
    # response.csv prints 12 significant digits: the same numbers to half a unit of the 12th.
    np.testing.assert_allclose(result.table, rows, rtol=5e-12, atol=0)
    np.testing.assert_array_equal(result.frequency_hz, result.table[:, header.index("frequency_hz")])
    np.testing.assert_allclose(result.amplitude("blade"), rows[:, header.index("blade_amplitude_m")],
                               rtol=5e-12, atol=0)
    # The peak of the curve is the program's summary's.
    summary = json.loads((tmp_path / "cli" / "summary.json").read_text())
    (peak,) = result.peaks
    assert peak["node"] == "blade"
    assert peak["amplitude_m"] == summary["peak"]["blade"]["amplitude_m"]
    assert peak["frequency_hz"] == summary["peak"]["blade"]["frequency_hz"]
    assert result.points == rows.shape[0]
    # write() gives the program's files.
    result.write(tmp_path / "py")
    assert (tmp_path / "py" / "response.csv").read_bytes() == \
        (tmp_path / "cli" / "response.csv").read_bytes()
    with pytest.raises(KeyError, match="no column 'nothing'"):
        result.column("nothing")


def test_overrides_reach_the_run_as_the_programs_set(tmp_path):
    load = 3.0
    result = frichb.run(QUICKSTART, set={"contacts.root_friction.params.normal_load": load},
                        plots=False)
    cli = frichb_cli("run", str(QUICKSTART), "-o", str(tmp_path / "cli"), "--set",
                     f"contacts.root_friction.params.normal_load={load}")
    assert cli.returncode == 0, cli.stderr
    _, rows = read_csv(tmp_path / "cli" / "response.csv")
    np.testing.assert_allclose(result.table, rows, rtol=5e-12, atol=0)
    result.write(tmp_path / "py")
    assert (tmp_path / "py" / "response.csv").read_bytes() == \
        (tmp_path / "cli" / "response.csv").read_bytes()
    plain = frichb.run(QUICKSTART, plots=False)
    assert plain.peaks[0]["amplitude_m"] != result.peaks[0]["amplitude_m"]


def test_a_refused_scene_raises_scene_error_with_file_line_and_key(tmp_path):
    with pytest.raises(frichb.SceneError) as refused:
        frichb.run(QUICKSTART, set={"contacts.root_friction.params.mu": "much"})
    error = refused.value
    assert error.file == str(QUICKSTART)
    assert error.line > 0 and error.column > 0
    assert error.key == "contacts[0].params.mu"
    assert isinstance(error, ValueError) and isinstance(error, frichb.Error)
    cli = frichb_cli("validate", str(QUICKSTART), "--set", "contacts.root_friction.params.mu=much")
    assert cli.returncode == 2
    assert f"{QUICKSTART}:{error.line}:{error.column}: {error.key}" in cli.stderr
    with pytest.raises(ValueError):
        frichb.run(QUICKSTART, set={"": 1})
    missing = tmp_path / "missing.yaml"
    with pytest.raises(frichb.SceneError) as absent:
        frichb.validate(missing)
    assert absent.value.file == str(missing)


def test_validate_names_the_structure_and_contacts():
    checked = frichb.validate(TWO_DOF)
    assert checked.structure == "lumped"
    assert checked.contacts == ["platform_friction (jenkins_1d 1.0.0)"]
    assert all(Path(p).exists() for p in checked.plugin_files)


def test_ctrl_c_stops_a_run_promptly():
    # About 5 s to its end (2342 points of 16 harmonics); interrupted after 0.3 s.
    slow = {"continuation.step.initial": 0.13, "continuation.step.max": 0.13,
            "continuation.max_points": 100000, "harmonic_balance.max_harmonic": 15,
            "harmonic_balance.samples_per_period": 512}
    threading.Timer(0.3, _thread.interrupt_main).start()
    started = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        frichb.run(QUICKSTART, set=slow)
    assert time.monotonic() - started < 2.0
    # The module is usable after it.
    assert frichb.run(QUICKSTART, plots=False).status == 0


def test_two_threads_run_at_once_and_give_their_runs_in_turn():
    scenes = [QUICKSTART, TWO_DOF]
    in_turn = [frichb.run(s, plots=False, contact_threads=1).table for s in scenes]
    together = [None, None]

    def run(k):
        together[k] = frichb.run(scenes[k], plots=False, contact_threads=1).table

    threads = [threading.Thread(target=run, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for k in range(2):
        np.testing.assert_array_equal(together[k], in_turn[k])
