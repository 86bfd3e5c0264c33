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


def test_python_runs_while_a_call_computes():
    # The slow run of the Ctrl-C test (about 5 s) in a thread: the main thread keeps running
    # Python meanwhile, which it could not if the call held the GIL.
    slow = {"continuation.step.initial": 0.13, "continuation.step.max": 0.13,
            "continuation.max_points": 100000, "harmonic_balance.max_harmonic": 15,
            "harmonic_balance.samples_per_period": 512}
    finished = []
    worker = threading.Thread(target=lambda: finished.append(frichb.run(QUICKSTART, set=slow)))
    worker.start()
    ticks = 0
    while worker.is_alive() and ticks < 50:
        time.sleep(0.01)
        ticks += 1
    busy = worker.is_alive()
    worker.join()
    assert busy, "the run ended within 0.5 s: too short to show anything"
    assert ticks == 50
    assert finished[0].status == 0


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


def test_timesim_gives_the_programs_summary_and_files(tmp_path):
    result = frichb.timesim(QUICKSTART, 348.0)
    assert result.status == 0 and result.periodic, result.message
    cli = frichb_cli("timesim", str(QUICKSTART), "--at-hz", "348", "-o", str(tmp_path / "cli"))
    assert cli.returncode == 0, cli.stderr
    summary = json.loads((tmp_path / "cli" / "summary.json").read_text())
    assert result.periods == summary["periods"]
    blade = result.nodes["blade"]
    expected = summary["response"]["blade"]
    assert blade["amplitude_m"] == expected["amplitude_m"]
    assert blade["half_peak_to_peak_m"] == expected["half_peak_to_peak_m"]
    assert list(blade["harmonic_amplitudes_m"]) == \
        [expected["harmonic_amplitudes_m"][str(h)] for h in result.harmonics]
    assert blade["samples_m"].shape == (1, 4000) and result.time_s.shape == (4000,)
    # The amplitude is the largest sample of the period (one DOF).
    assert np.max(np.abs(blade["samples_m"])) == blade["amplitude_m"]
    result.write(tmp_path / "py")
    assert (tmp_path / "py" / "timesim.csv").read_bytes() == \
        (tmp_path / "cli" / "timesim.csv").read_bytes()
    with pytest.raises(frichb.SceneError) as cyclic:
        frichb.timesim(SOURCE / "configs" / "bladed_disk_lumped_eo3.yaml", 300.0)
    assert cyclic.value.key == "cyclic"


def test_modes_give_the_programs_tables(tmp_path):
    scene = SOURCE / "configs" / "bladed_disk_lumped_eo3.yaml"
    result = frichb.modes(scene, rpm=(4000, 8000))
    assert result.status == 0
    cli = frichb_cli("modes", str(scene), "--rpm", "4000:8000", "-o", str(tmp_path / "cli"))
    assert cli.returncode == 0, cli.stderr
    header, rows = read_csv(tmp_path / "cli" / "modes.csv")
    for k, name in enumerate(header):
        np.testing.assert_allclose(result.modes[name], rows[:, k], rtol=5e-12, atol=0)
    _, families = read_csv(tmp_path / "cli" / "families.csv")
    np.testing.assert_allclose(result.frequencies_hz, families[:, 1:], rtol=5e-12, atol=0)
    _, lines = read_csv(tmp_path / "cli" / "excitation.csv")
    assert [[e["rpm"], e["harmonic"], e["harmonic_index"], e["nodal_diameter"],
             e["frequency_hz"]] for e in result.excitation] == lines.tolist()
    assert result.sectors > 1 and result.engine_order == 3
    result.write(tmp_path / "py")
    for name in ("modes.csv", "families.csv", "excitation.csv"):
        assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes()
    with pytest.raises(ValueError):
        frichb.modes(scene, rpm=(8000, 4000))


def test_peaks_give_the_programs_peak_curve(tmp_path):
    scene = SOURCE / "configs" / "peaks" / "planar_tip_normal_load.yaml"
    path = "contacts.shroud.params.normal_load"
    result = frichb.peaks(scene, path, 4.0, 8.0, set={"output.plots": False})
    assert result.status == 0, result.message
    assert result.termination == "reached_end" and not result.logarithmic
    cli = frichb_cli("peaks", str(scene), "--vary", path + "=4:8", "--set", "output.plots=false",
                     "-o", str(tmp_path / "cli"))
    assert cli.returncode == 0, cli.stderr
    header, rows = read_csv(tmp_path / "cli" / "peaks.csv")
    assert header == ["point", path, "peak_frequency_hz", "peak_amplitude_m",
                      "newton_iterations", "branch"]
    np.testing.assert_allclose(result.parameter_values, rows[:, 1], rtol=5e-12, atol=0)
    np.testing.assert_allclose(result.frequency_hz, rows[:, 2], rtol=5e-12, atol=0)
    np.testing.assert_allclose(result.amplitude_m, rows[:, 3], rtol=5e-12, atol=0)
    assert result.newton_iterations.tolist() == rows[:, 4].astype(int).tolist()
    assert result.branch.tolist() == rows[:, 5].astype(int).tolist()
    assert result.jumps == json.loads((tmp_path / "cli" / "summary.json").read_text())["jumps"]
    best = result.optimum
    assert not best["at_range_end"]
    assert best["solved"] and best["amplitude_m"] <= result.amplitude_m.min()
    summary = json.loads((tmp_path / "cli" / "summary.json").read_text())
    assert summary["optimum"]["parameter"] == pytest.approx(best["parameter"], rel=1e-12)
    assert np.all(np.isfinite(result.d_frequency_hz_d_parameter))
    result.write(tmp_path / "py")
    assert ((tmp_path / "py" / "peaks.csv").read_bytes()
            == (tmp_path / "cli" / "peaks.csv").read_bytes())
    with pytest.raises(ValueError):
        frichb.peaks(scene, path, 4.0, 8.0, axis="cubic")
    with pytest.raises(frichb.SceneError):
        frichb.peaks(scene, "structure.params.masses.0", 0.1, 0.2)
    with pytest.raises(frichb.SceneError, match="normal_load"):
        frichb.peaks(scene, "contacts.shroud.params.mu", 0.3, 0.6, normalise=True)


def test_nma_gives_the_programs_backbone(tmp_path):
    scene = SOURCE / "configs" / "two_dof_blade_damper.yaml"
    result = frichb.nma(scene, mode=1, amplitude=(1e-6, 1e-4), set={"output.plots": False})
    assert result.status == 0, result.message
    assert result.termination_of_continuation == "reached_end"
    assert result.amplitude[0] == pytest.approx(1e-6, rel=1e-12)
    assert result.amplitude[-1] == pytest.approx(1e-4, rel=1e-9)
    cli = frichb_cli("nma", str(scene), "--mode", "1", "--amplitude", "1e-6:1e-4", "--set",
                     "output.plots=false", "-o", str(tmp_path / "cli"))
    assert cli.returncode == 0, cli.stderr
    header, rows = read_csv(tmp_path / "cli" / "nma.csv")
    assert header[:5] == ["point", "amplitude_m_sqrt_kg", "frequency_hz", "damping_ratio",
                          "xi_rad_s"]
    np.testing.assert_allclose(result.amplitude, rows[:, 1], rtol=5e-12, atol=0)
    np.testing.assert_allclose(result.frequency_hz, rows[:, 2], rtol=5e-12, atol=0)
    np.testing.assert_allclose(result.damping_ratio, rows[:, 3], rtol=5e-12, atol=0)
    # The damper sticks at first (the stuck structure's frequency, shifted by its 0.2 % damping
    # from the undamped one) and slips later.
    assert result.frequency_hz[0] == pytest.approx(result.start_frequency_hz, rel=1e-6)
    assert result.slipping_share[0] == 0 and result.slipping_share[-1] > 0
    summary = json.loads((tmp_path / "cli" / "summary.json").read_text())
    assert summary["most_damped"]["point"] == result.most_damped
    result.write(tmp_path / "py")
    assert ((tmp_path / "py" / "nma.csv").read_bytes()
            == (tmp_path / "cli" / "nma.csv").read_bytes())
    with pytest.raises(ValueError):
        frichb.nma(scene, amplitude=(1e-4, 1e-6))
    with pytest.raises(frichb.SceneError):
        frichb.nma(scene, mode=9)


def test_nma_synthesises_the_programs_forced_responses(tmp_path):
    scene = SOURCE / "configs" / "two_dof_blade_damper.yaml"
    result = frichb.nma(scene, synthesise=[0.001, 0.05], set={"output.plots": False})
    assert result.status == 0, result.message
    cli = frichb_cli("nma", str(scene), "--synthesise", "0.001,0.05", "--set",
                     "output.plots=false", "-o", str(tmp_path / "cli"))
    assert cli.returncode == 0, cli.stderr
    result.write(tmp_path / "py")
    assert ((tmp_path / "py" / "synthesis.csv").read_bytes()
            == (tmp_path / "cli" / "synthesis.csv").read_bytes())
    header, py_peaks = read_csv(tmp_path / "py" / "synthesis_peaks.csv")
    _, cli_peaks = read_csv(tmp_path / "cli" / "synthesis_peaks.csv")
    numbers = [i for i, name in enumerate(header) if not name.endswith("seconds")]
    np.testing.assert_array_equal(py_peaks[:, numbers], cli_peaks[:, numbers])
    levels = result.syntheses
    assert [level["excitation_scale"] for level in levels] == [0.001, 0.05]
    stuck = levels[0]
    # Stuck, the synthesised peak is the linear one: the harmonic-balance solve at its
    # frequency agrees to the damping's coupling between the modes.
    assert stuck["peak"]["found"] and stuck["check"]["converged"]
    assert abs(stuck["check"]["error"]) < 1e-7
    curve = stuck["curve"]
    assert np.all(np.diff(curve["frequency_hz"]) > 0)
    assert curve["node_amplitude_m"].max() == pytest.approx(stuck["peak"]["node_amplitude_m"],
                                                            rel=1e-3)
    header, rows = read_csv(tmp_path / "cli" / "synthesis.csv")
    assert header == ["level", "excitation_scale", "frequency_hz", "amplitude_m_sqrt_kg",
                      "node_amplitude_mode_m", "node_amplitude_m"]
    np.testing.assert_allclose(curve["frequency_hz"], rows[rows[:, 0] == 0, 2], rtol=1e-11)
    assert result.full_run_seconds == 0 and levels[0]["full_run"] is None
    with pytest.raises(ValueError):
        frichb.nma(scene, synthesise=[0.0])
    with pytest.raises(ValueError):
        frichb.nma(scene, against_run=True)


TWO_RESONANCES = """name: two_resonances
structure:
  provider: lumped
  params:
    masses: [1.0, 1.0]
    springs:
      - {between: [ground, 0], k: 1.0e6}
      - {between: [ground, 1], k: 1.44e6}
      - {between: [0, 1], k: 5.0e4}
    dampers:
      - {between: [ground, 0], c: 20.0}
      - {between: [ground, 1], c: 24.0}
  dofs: {a: 0, b: 1}
excitation:
  - {dof: a, amplitude: 1.0}
  - {dof: b, amplitude: 1.0, phase_deg: 180}
contacts: []
harmonic_balance: {max_harmonic: 1, samples_per_period: 16}
continuation:
  frequency: {from: 130, to: 230, unit: Hz}
  step: {initial: 1, min: 1.0e-6, max: 5}
output: {response: [a], plots: false, stability: true}
"""


def test_peaks_near_a_frequency_with_stability_and_exchanges(tmp_path):
    scene = tmp_path / "two_resonances.yaml"
    scene.write_text(TWO_RESONANCES)
    path = "excitation.1.amplitude"
    result = frichb.peaks(scene, path, 1.0, 7.0, near=195.0)
    assert result.status == 0, result.message
    assert abs(result.start_frequency_hz - 195.28) < 0.01
    assert result.stable.tolist() == [1] * len(result.amplitude_m)
    assert np.all(result.largest_multiplier < 1)
    assert len(result.exchanges) == 1 and result.exchanges[0]["located"]
    assert result.exchanges[0]["other_peak"] == "falls_below"
    cli = frichb_cli("peaks", str(scene), "--vary", path + "=1:7", "--near", "195",
                     "-o", str(tmp_path / "cli"))
    assert cli.returncode == 0, cli.stderr
    header, rows = read_csv(tmp_path / "cli" / "peaks.csv")
    assert header[-2:] == ["stable", "largest_multiplier"]
    np.testing.assert_allclose(result.largest_multiplier, rows[:, -1], rtol=5e-12, atol=0)
    summary = json.loads((tmp_path / "cli" / "summary.json").read_text())
    assert summary["start"]["near_hz"] == 195.0
    (cli_exchange,) = summary["exchanges"]
    assert cli_exchange["parameter"] == pytest.approx(result.exchanges[0]["parameter"], rel=1e-12)
    assert tuple(cli_exchange["bracket"]) == result.exchanges[0]["bracket"]
    result.write(tmp_path / "py")
    assert ((tmp_path / "py" / "peaks.csv").read_bytes()
            == (tmp_path / "cli" / "peaks.csv").read_bytes())


def test_loop_gives_the_programs_energy_and_files(tmp_path):
    loop_input = SOURCE / "configs" / "friction_loops" / "fig3_4_2d_variable_normal_load.yaml"
    result = frichb.loop(loop_input)
    cli = frichb_cli("loop", str(loop_input), "-o", str(tmp_path / "cli"))
    assert cli.returncode == 0, cli.stderr
    summary = json.loads((tmp_path / "cli" / "summary.json").read_text())
    assert result.energy_per_cycle_J == summary["dissipated_energy_per_cycle_J"]
    assert result.fraction_slipping == summary["fraction_slipping"]
    assert result.law == summary["law"]["name"]
    assert result.law_params == summary["law"]["params"]
    assert result.components == ["t1", "t2", "n"]
    header, rows = read_csv(tmp_path / "cli" / "loop.csv")
    # loop.csv closes the loop: its last row repeats the first sample.
    np.testing.assert_array_equal(rows[-1, 1:7], rows[0, 1:7])
    np.testing.assert_allclose(result.force_N, rows[:-1, 4:7], rtol=5e-12, atol=1e-15)
    np.testing.assert_allclose(result.displacement_m, rows[:-1, 1:4], rtol=5e-12, atol=1e-15)
    np.testing.assert_array_equal(result.stick_slip_status, rows[:-1, 7])
    # The energy is the closed integral of f . du, which the core takes over the force's and
    # motion's harmonics; the trapezoid rule over the 2048 samples of this loop (its force has
    # corners at stick-slip changes) agrees to 5e-6.
    du = np.roll(result.displacement_m, -1, axis=0) - result.displacement_m
    f_mid = 0.5 * (np.roll(result.force_N, -1, axis=0) + result.force_N)
    assert np.sum(f_mid * du) == pytest.approx(result.energy_per_cycle_J, rel=2e-5)
    result.write(tmp_path / "py")
    assert (tmp_path / "py" / "loop.csv").read_bytes() == \
        (tmp_path / "cli" / "loop.csv").read_bytes()


def test_response_harmonics_rebuild_the_time_signal(tmp_path):
    result = frichb.run(QUICKSTART, plots=False)
    cli = frichb_cli("run", str(QUICKSTART), "-o", str(tmp_path / "cli"), "--set",
                     "output.plots=false")
    assert cli.returncode == 0, cli.stderr
    x = result.response_harmonics("blade")
    assert x.shape == (result.points, 1, len(result.harmonics))
    # response_harmonics.csv holds the same coefficients (cos_m = Re X, sin_m = -Im X), each
    # number written to read back as the same double.
    with open(tmp_path / "cli" / "response_harmonics.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == x.size
    for row in rows:
        point, component = int(row["point"]), int(row["component"])
        k = result.harmonics.index(int(row["harmonic"]))
        assert row["node"] == "blade" and row["dof"] == "0"
        assert float(row["cos_m"]) == x[point, component, k].real
        assert float(row["sin_m"]) == (0.0 if result.harmonics[k] == 0 else
                                       -x[point, component, k].imag)
        assert float(row["frequency_hz"]) == result.frequency_hz[point]
    # Each harmonic's amplitude is response.csv's <node>_h<n>_m.
    for k, n in enumerate(result.harmonics):
        np.testing.assert_allclose(np.sqrt(np.sum(np.abs(x[:, :, k]) ** 2, axis=1)),
                                   result.column(f"blade_h{n}_m"), rtol=1e-14, atol=1e-30)
    # The amplitude is the series' maximum in continuous time: the signal rebuilt on 2^16
    # samples per period peaks below it by at most (pi / 2^16)^2 / 2 = 1.1e-9 of it (harmonic
    # 1 dominating), at every point.
    grid = 2**16
    amplitude = result.amplitude("blade")
    for point in range(result.points):
        t, signal = result.time_signal("blade", point, samples=grid)
        assert signal.shape == (1, grid)
        assert 0 <= amplitude[point] - np.max(np.abs(signal)) <= 5e-9 * amplitude[point]
    assert t[1] - t[0] == pytest.approx(1 / (grid * result.frequency_hz[-1]), rel=1e-12)
    with pytest.raises(KeyError, match="not a response node"):
        result.response_harmonics("ground")
    with pytest.raises(IndexError):
        result.time_signal("blade", result.points)


def test_rebuilt_signal_follows_time_integration():
    # At three points of the quick start's curve (below, at and above the peak), the signal
    # rebuilt from the run's 8 harmonics against the last period of time integration at the
    # point's frequency: measured 1.9e-4 to 2.6e-4 of the amplitude (the harmonics above 7 that
    # the balance leaves out and the integration's time step).
    result = frichb.run(QUICKSTART, plots=False)
    top = int(np.argmax(result.amplitude("blade")))
    for point in (top - 40, top, top + 40):
        f = result.frequency_hz[point]
        reference = frichb.timesim(QUICKSTART, f)
        assert reference.periodic
        t = reference.time_s
        samples = reference.nodes["blade"]["samples_m"][0]
        x = result.response_harmonics("blade")[point, 0]
        rebuilt = sum((x[k] * np.exp(1j * n * 2 * np.pi * f * t)).real
                      for k, n in enumerate(result.harmonics))
        assert np.max(np.abs(rebuilt - samples)) < 1e-3 * np.max(np.abs(samples))


def test_study_gives_the_programs_rows_and_folder(tmp_path):
    scene = SOURCE / "configs" / "studies" / "damper_normal_load_sweep.yaml"
    result = frichb.study(scene, tmp_path / "py", threads=2)
    assert result.status == 0, result.message
    cli = frichb_cli("study", str(scene), "-o", str(tmp_path / "cli"), "--threads", "2")
    assert cli.returncode == 0, cli.stderr
    def study_rows(folder):
        with open(folder / "study.csv", newline="") as f:
            return list(csv.DictReader(f))

    rows = study_rows(tmp_path / "cli")
    sweep = "contacts.platform_friction.params.normal_load"
    assert result.sweeps == [sweep]
    assert len(result.runs) == len(rows) == 13
    for run, row in zip(result.runs, rows):
        assert run["id"] == row["run"]
        assert run["values"][0] == pytest.approx(float(row[sweep]), rel=5e-12)
        assert run["termination"] == row["termination"]
        assert run["points"] == int(row["points"])
        blade = next(p for p in run["peaks"] if p["node"] == "blade")
        assert blade["amplitude_m"] == pytest.approx(float(row["blade_peak_amplitude_m"]),
                                                     rel=5e-12)
    # The folder is the program's, but for the wall times.
    for py_row, row in zip(study_rows(tmp_path / "py"), rows):
        del py_row["wall_s"], row["wall_s"]
        assert py_row == row
    assert sorted(p.name for p in (tmp_path / "py" / "runs").iterdir()) == \
        [run["id"] for run in result.runs]
    amplitudes = [next(p for p in run["peaks"] if p["node"] == result.node)["amplitude_m"]
                  for run in result.runs]
    assert result.optimum == int(np.argmin(amplitudes))
    assert result.optimum_amplitude_m == min(amplitudes)


def test_convergence_gives_the_programs_table(tmp_path):
    settings = {"harmonics": [1, 3], "samples": [64, 128], "oversampling": [1]}
    result = frichb.convergence(QUICKSTART, tmp_path / "py", time_integration=False, **settings)
    assert result.status == 0, result.message
    cli = frichb_cli("convergence", str(QUICKSTART), "-o", str(tmp_path / "cli"),
                     "--harmonics", "1,3", "--samples", "64,128", "--oversampling", "1",
                     "--no-timesim")
    assert cli.returncode == 0, cli.stderr
    expected = json.loads((tmp_path / "cli" / "convergence.json").read_text())
    assert result.timesim is None
    assert [r["setting"] for r in result.rows] == ["H1_N64_o1", "H1_N128_o1", "H3_N64_o1",
                                                    "H3_N128_o1"]
    assert result.rows[-1]["amplitude_error"] == 0.0
    assert [s["setting"] for s in expected["settings"]] == [r["setting"] for r in result.rows]
    for row, setting in zip(result.rows, expected["settings"]):
        assert row["amplitude_m"] == setting["peak_amplitude_m"]
        assert row["frequency_hz"] == setting["peak_frequency_hz"]
        assert row["amplitude_error"] == setting["amplitude_error"]
        assert row["unknowns"] == setting["unknowns"]
    assert (tmp_path / "py" / "convergence.csv").exists()
    assert (tmp_path / "py" / "runs" / "H3_N128_o1" / "response.csv").exists()
    with pytest.raises(frichb.SceneError):
        frichb.convergence(tmp_path / "missing.yaml", tmp_path / "never")
    assert not (tmp_path / "never").exists()


def test_progress_is_called_at_every_point_and_can_stop_the_run():
    seen = []
    result = frichb.run(QUICKSTART, plots=False, progress=lambda i, f: seen.append((i, f)))
    assert [i for i, _ in seen] == list(range(result.points))
    np.testing.assert_array_equal([f for _, f in seen], result.frequency_hz)

    class Enough(Exception):
        pass

    def stop_at_five(point, _frequency):
        if point == 5:
            raise Enough(point)

    with pytest.raises(Enough):
        frichb.run(QUICKSTART, plots=False, progress=stop_at_five)


def test_contact_harmonics_rebuild_the_runs_own_trace_samples(tmp_path):
    result = frichb.run(TWO_DOF, set={"output.contact_forces": True}, plots=False)
    assert result.status == 0, result.message
    (contact,) = result.contacts
    assert result.contact_components(contact) == ["t1"]
    u_h, f_h = result.contact_harmonics(contact)
    harmonics = result.harmonics
    assert u_h.shape == f_h.shape == (result.points, 1, len(harmonics))
    for point in (0, result.points // 3, result.points // 2, result.points - 1):
        trace = result.contact_trace(contact, point)
        samples = trace["displacement"].shape[1]
        # The displacement's series at the run's own samples is what the law was traced on.
        _, u, f = result.contact_signal(contact, point, samples)
        scale = np.abs(trace["displacement"]).max()
        assert np.abs(u - trace["displacement"]).max() <= 1e-12 * scale
        # jenkins_1d steps on the samples alone: the force harmonics are the discrete Fourier
        # transform of its force samples (cos - i sin: twice the DFT's coefficient for n > 0).
        dft = np.fft.rfft(trace["force"][0]) / samples
        expected = np.array([dft[n].real if n == 0 else 2 * dft[n] for n in harmonics])
        assert np.abs(f_h[point, 0] - expected).max() <= 1e-12 * np.abs(trace["force"]).max()
        assert f.shape == u.shape
    # The program writes the same numbers (shortest round-trip text) into contact_harmonics.csv.
    cli = frichb_cli("run", str(TWO_DOF), "-o", str(tmp_path / "cli"), "--set",
                     "output.plots=false", "--set", "output.contact_forces=true")
    assert cli.returncode == 0, cli.stderr
    with open(tmp_path / "cli" / "contact_harmonics.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == result.points * len(harmonics)
    for row in rows:
        point, k = int(row["point"]), harmonics.index(int(row["harmonic"]))
        assert row["contact"] == contact and row["component"] == "t1" and row["periodic"] == "1"
        assert float(row["displacement_cos_m"]) == u_h[point, 0, k].real
        assert float(row["displacement_sin_m"]) == -u_h[point, 0, k].imag + 0.0
        assert float(row["force_cos_n"]) == f_h[point, 0, k].real
        assert float(row["force_sin_n"]) == -f_h[point, 0, k].imag + 0.0
    # Without the switch the run keeps none and says how to get them.
    with pytest.raises(ValueError, match="output.contact_forces"):
        frichb.run(TWO_DOF, plots=False).contact_harmonics(contact)
    with pytest.raises(KeyError, match="not a contact"):
        result.contact_harmonics("nothing")


def test_summary_is_the_programs_summary_json(tmp_path):
    result = frichb.run(QUICKSTART, set={"output.plots": False})
    cli = frichb_cli("run", str(QUICKSTART), "-o", str(tmp_path / "cli"), "--set",
                     "output.plots=false")
    assert cli.returncode == 0, cli.stderr
    written = json.loads((tmp_path / "cli" / "summary.json").read_text())
    summary = result.summary
    for key in ("termination", "points", "peak", "turning_point_frequencies",
                "harmonic_truncation", "unknowns", "validated_scene", "resonance_bands",
                "command_line_overrides", "plugins"):
        assert summary[key] == written[key], key
    assert set(written) - set(summary) == {"contact_states"}
    files = {"file", "harmonics_file"}
    assert summary["friction_loops"] == \
        [{k: v for k, v in e.items() if k not in files} for e in written["friction_loops"]]
    assert len(summary["friction_loops"]) == 2


# The quick start written as a dict (configs/quickstart_friction_oscillator.yaml).
def quickstart_dict():
    return {
        "name": "friction_oscillator",
        "structure": {"provider": "lumped",
                      "params": {"masses": [0.1], "springs": [{"between": ["ground", 0],
                                                               "k": 4.0e5}],
                                 "modal_damping": [0.005]},
                      "dofs": {"blade": 0}},
        "excitation": [{"dof": "blade", "amplitude": 2.0, "harmonic": 1}],
        "contacts": [{"name": "root_friction", "law": "jenkins_1d",
                      "between": ["ground", "blade"], "frame": {"tangent1": [1.0]},
                      "params": {"kt": 2.0e5, "mu": 0.5, "normal_load": 5.0}}],
        "harmonic_balance": {"max_harmonic": 7, "samples_per_period": 128,
                             "jacobian": "analytic"},
        "continuation": {"frequency": {"from": 250, "to": 450, "unit": "Hz"},
                         "step": {"initial": 1.0, "min": 1.0e-5, "max": 2.0},
                         "target_newton_iterations": 4, "max_points": 2000},
        "output": {"response": ["blade"], "friction_loops_at": [330.0, 400.0]},
    }


def test_a_scene_as_a_dict_gives_the_files_run(tmp_path):
    from_file = frichb.run(QUICKSTART, plots=False)
    from_dict = frichb.run(quickstart_dict(), plots=False)
    np.testing.assert_array_equal(from_dict.table, from_file.table)
    assert from_dict.peaks == from_file.peaks
    assert from_dict.summary["scene"]["file"] == str(Path.cwd() / "<dict>")
    # Overrides apply to it as to a file; errors name "<dict>", the line and the key.
    scene = quickstart_dict()
    scene["contacts"][0]["params"]["mu"] = "much"
    with pytest.raises(frichb.SceneError) as refused:
        frichb.validate(scene)
    assert refused.value.file.endswith("<dict>") and refused.value.line > 0
    assert refused.value.key == "contacts[0].params.mu"
    with pytest.raises(TypeError, match="a path .* or a dict, not int"):
        frichb.validate(123)
    scene = quickstart_dict()
    scene["contacts"][0]["params"]["mu"] = float("nan")
    with pytest.raises(ValueError):
        frichb.validate(scene)
    # A study re-reads its scene for every run: from the dict's text, not from a file.
    scene = quickstart_dict()
    scene["study"] = {"sweep": [{"path": "contacts.root_friction.params.normal_load",
                                 "values": [2.0, 8.0]}], "parallel": 1}
    study = frichb.study(scene, tmp_path / "study", set={"output.plots": False})
    assert study.status == 0, study.message
    for run, load in zip(study.runs, (2.0, 8.0)):
        alone = frichb.run(QUICKSTART, set={"contacts.root_friction.params.normal_load": load},
                           plots=False)
        assert run["peaks"][0]["amplitude_m"] == alone.peaks[0]["amplitude_m"]


def test_all_response_harmonics_stack_every_nodes_harmonics():
    result = frichb.run(TWO_DOF, plots=False)
    assert result.response_dofs == [("blade", 0), ("damper", 0)]
    every = result.all_response_harmonics()
    assert every.shape == (result.points, 2, len(result.harmonics))
    np.testing.assert_array_equal(every[:, 0:1, :], result.response_harmonics("blade"))
    np.testing.assert_array_equal(every[:, 1:2, :], result.response_harmonics("damper"))


def test_contact_harmonics_of_a_stuck_3d_contact_carry_its_preload_and_stiffnesses():
    # The bladed disk's shroud (coupled_3d: kt = 2e5 N/m, kn = 1e5 N/m, N0 = 5 N) sticks far
    # below resonance: its force is linear in the motion, T = kt u_t and N = N0 + kn u_n
    # (the slider at its initial place), harmonic by harmonic, the preload in the static term.
    scene = SOURCE / "configs" / "bladed_disk_lumped_eo3.yaml"
    result = frichb.run(scene, set={"continuation.frequency.to": 250.0,
                                    "output.contact_forces": True}, plots=False)
    assert result.status == 0, result.message
    assert result.contact_components("shroud") == ["t1", "t2", "n"]
    assert all(result.contact_periodic("shroud"))
    u_h, f_h = result.contact_harmonics("shroud")
    stiffness = np.array([2e5, 2e5, 1e5])[:, None]
    preload = np.zeros((3, len(result.harmonics)), dtype=complex)
    preload[2, result.harmonics.index(0)] = 5.0
    for point in (0, result.points - 1):
        expected = stiffness * u_h[point] + preload
        assert np.abs(f_h[point] - expected).max() <= 1e-9 * np.abs(f_h[point]).max()
        # The static term is the mean of the force the law computes on the run's samples.
        trace = result.contact_trace("shroud", point)
        np.testing.assert_allclose(f_h[point, :, 0].real, trace["force"].mean(axis=1),
                                   rtol=0, atol=1e-12 * np.abs(trace["force"]).max())


def test_stability_columns_and_bifurcations_are_the_programs(tmp_path):
    scene = SOURCE / "configs" / "stress" / "hertz_gap_folds.yaml"
    result = frichb.run(scene, set={"output.stability": True}, plots=False)
    assert result.status == 0, result.message
    cli = frichb_cli("run", str(scene), "-o", str(tmp_path / "cli"), "--set",
                     "output.stability=true")
    assert cli.returncode == 0, cli.stderr
    header, rows = read_csv(tmp_path / "cli" / "response.csv")
    assert result.columns[-3:] == ["stable", "largest_multiplier", "unstable_multipliers"]
    np.testing.assert_array_equal(result.column("stable"), rows[:, header.index("stable")])
    np.testing.assert_allclose(result.column("largest_multiplier"),
                               rows[:, header.index("largest_multiplier")], rtol=5e-12, atol=0)
    summary = json.loads((tmp_path / "cli" / "summary.json").read_text())
    assert result.summary["stability"]["changes"] == summary["stability"]["changes"]
    assert [c["kind"] for c in summary["stability"]["changes"]].count("fold") == 2


def test_cyclic_stability_names_the_nodal_diameters_as_the_program(tmp_path):
    # A lumped disk of 6 sectors under engine order 2 with friction shrouds: the whole disk's
    # multipliers, each point's largest named by its nodal diameter (0 to 3).
    scene = tmp_path / "disk.yaml"
    scene.write_text("""
cyclic: {sectors: 6, engine_order: 2}
structure:
  provider: lumped_cyclic
  params:
    sectors: 6
    masses: [0.5, 0.1]
    springs: [{between: [ground, 0], k: 2.0e6}, {between: [0, 1], k: 4.0e5}]
    coupling: [{between: [0, 0], k: 1.0e5}]
    modal_damping: [0.01]
  dofs: {disk: 0, blade: 1}
excitation: [{dof: blade, amplitude: 2.0}]
contacts:
  - name: shroud
    law: jenkins_1d
    between: [{node: blade, sector: 0}, {node: blade, sector: 1}]
    params: {kt: 1.0e5, mu: 0.5, normal_load: 5.0}
harmonic_balance: {harmonics: [0, 1, 2, 3], samples_per_period: 96}
continuation: {frequency: {from: 200, to: 400}}
output: {response: [blade], stability: true}
""")
    result = frichb.run(scene, plots=False)
    assert result.status == 0, result.message
    cli = frichb_cli("run", str(scene), "-o", str(tmp_path / "cli"))
    assert cli.returncode == 0, cli.stderr
    header, rows = read_csv(tmp_path / "cli" / "response.csv")
    assert result.columns[-1] == "largest_multiplier_nodal_diameter"
    diameters = result.column("largest_multiplier_nodal_diameter")
    np.testing.assert_array_equal(diameters,
                                  rows[:, header.index("largest_multiplier_nodal_diameter")])
    assert set(np.unique(diameters)) <= {0.0, 1.0, 2.0, 3.0}
    np.testing.assert_allclose(result.column("largest_multiplier"),
                               rows[:, header.index("largest_multiplier")], rtol=5e-12, atol=0)
    summary = json.loads((tmp_path / "cli" / "summary.json").read_text())
    assert result.summary["stability"] == summary["stability"]


def mistuned_disk_dict(deviations):
    """The 6-blade lumped disk of tests/cyclic_disk.hpp with a shroud between neighbours."""
    return {
        "name": "mistuned_six",
        "cyclic": {"sectors": 6, "engine_order": 2},
        "structure": {
            "provider": "lumped_cyclic",
            "params": {"sectors": 6, "masses": [0.5, 0.1],
                       "springs": [{"between": ["ground", 0], "k": 2.0e6},
                                   {"between": [0, 1], "k": 4.0e5}],
                       "coupling": [{"between": [0, 0], "k": 1.0e5}],
                       "modal_damping": [0.01], "blade_dofs": [1]},
            "dofs": {"disk": 0, "blade": 1}},
        "excitation": [{"dof": "blade", "amplitude": 2.0}],
        "contacts": [{"name": "shroud", "law": "jenkins_1d",
                      "between": [{"node": "blade", "sector": 0}, {"node": "blade", "sector": 1}],
                      "params": {"kt": 1.0e5, "mu": 0.5, "normal_load": 5.0}}],
        "harmonic_balance": {"harmonics": [0, 1, 2, 3], "samples_per_period": 96},
        "continuation": {"frequency": {"from": 200, "to": 400}},
        "output": {"response": ["blade"], "plots": False},
        "mistuning": {"deviations": deviations},
    }


def test_mistuned_disk_gives_the_programs_blade_peaks(tmp_path):
    deviations = [0.03, -0.02, 0.05, 0.0, -0.04, 0.01]
    result = frichb.run(mistuned_disk_dict(deviations), plots=False)
    assert result.status == 0, result.message
    m = result.mistuning
    assert m["deviations"] == deviations
    (node,) = m["nodes"]
    assert node["node"] == "blade" and len(node["blade_peak_m"]) == 6
    assert node["amplification"] == max(node["blade_peak_m"]) / node["tuned_peak_m"]
    assert node["amplification"] > 1.0
    assert [f"blade@{j}_amplitude_m" in result.columns for j in range(6)] == [True] * 6
    assert result.summary["mistuning"] == m
    # The program writes the same numbers: summary.json and blade_peaks.csv.
    scene = tmp_path / "mistuned.yaml"
    scene.write_text(json.dumps(mistuned_disk_dict(deviations)))
    cli = frichb_cli("run", str(scene), "-o", str(tmp_path / "cli"))
    assert cli.returncode == 0, cli.stderr
    summary = json.loads((tmp_path / "cli" / "summary.json").read_text())
    assert summary["mistuning"]["nodes"][0]["blade_peak_m"] == node["blade_peak_m"]
    assert summary["mistuning"]["nodes"][0]["amplification"] == node["amplification"]
    header, rows = read_csv(tmp_path / "cli" / "blade_peaks.csv")
    assert header[:4] == ["blade", "deviation", "blade_peak_m", "blade_peak_hz"]
    np.testing.assert_allclose(rows[:, 2], node["blade_peak_m"], rtol=5e-12, atol=0)
    np.testing.assert_array_equal(rows[:, 1], deviations)
    # A plain scene has no comparison.
    assert frichb.run(QUICKSTART, plots=False).mistuning is None
