#!/usr/bin/env python3
"""Contact patches on the FE test-case blade (configs/models/shrouded_blade).

Builds test_case with --contact-pairs 1 and 4 into WORK, then:
  - one pair: the patch {faces: [shroud_right sector 0, shroud_left sector 1]} over the single
    contact node of each face (the whole face area) is the hand-written contact between the
    same two nodes (`between`, frame tangent1 z and normal -theta in the nodes' cylindrical
    components, the totals as params): the pairing across the cyclic boundary, the frame
    from the face normal and the shares must reproduce it, so the refined peaks agree to
    1e-9 in amplitude and 1e-10 in frequency. A static force on the blade presses the shrouds
    together: without it the motion has odd harmonics only, under which a flipped normal
    gives the same response (N0 + kn u_n(t + T/2) with u_t(t + T/2) = -u_t(t) and an odd law),
    and the test could not see the normal's sign;
  - four pairs: the patch runs through the resonance to the sweep's end, summary.json
    records 4 pairs whose areas sum to the face area (shroud_thickness * shroud_width), and
    contact_states/ holds each pair's shares of the period stuck, slipping and open;
  - the shipped contact-mesh studies (configs/case_studies/contact_mesh_case*.yaml, one scene
    for every mesh through the variable `pairs`) validate on these two models.

Usage: check_fe_patch.py SOURCE_DIR FRICHB WORK_DIR      (exit code 1 on a failed check)
"""
import json
import pathlib
import shutil
import subprocess
import sys

SCENE = """name: {name}
cyclic: {{sectors: 8, engine_order: 3}}
structure:
  provider: fe_sector
  params:
    mass: {model}/sector_mass.mtx
    stiffness: {model}/sector_stiffness.mtx
    cyclic_pairs: {model}/cyclic_pairs.txt
    sectors: 8
    modes: 10
    modal_damping: [0.002]
  dofs: {model}/dofs.yaml
  mesh: {model}/mesh.yaml
excitation:
  - {{dof: excitation, amplitude: 2.0, direction: [1.0, 1.0, 1.0]}}
  - {{dof: excitation, amplitude: 100.0, harmonic: 0, direction: [0.0, 1.0, 0.0]}}
contacts:
  - name: shroud
    law: jenkins_1d
{contact}
    params: {{kt: 2.0e5, kn: 1.0e5, mu: 0.5, normal_load: 5.0}}
harmonic_balance: {{max_harmonic: 3, samples_per_period: 128}}
continuation:
  frequency: {{from: 105, to: 130, unit: Hz}}
  step: {{initial: 0.5, min: 1.0e-6, max: 1.0}}
  displacement_scale: 2.0e-5
output: {{response: [response], contact_states_at: [119.3], plots: false}}
"""
PATCH = """    patch:
      faces: [{face: shroud_right, sector: 0}, {face: shroud_left, sector: 1}]
    frame: {tangent1: [0.0, 0.0, 1.0]}"""
BETWEEN = """    between: [{node: shroud_right, sector: 0}, {node: shroud_left, sector: 1}]
    frame: {tangent1: [0.0, 0.0, 1.0], normal: [0.0, -1.0, 0.0]}"""


def fail(message):
    sys.exit(f"check_fe_patch: {message}")


def run(command):
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        fail(f"{' '.join(map(str, command))} exited {result.returncode}:\n{result.stdout}{result.stderr}")


def main():
    source, frichb, work = (pathlib.Path(a).resolve() for a in sys.argv[1:4])
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    builder = source / "configs/models/shrouded_blade/build_model.py"
    summaries = {}
    for pairs in (1, 4):
        model = work / f"p{pairs}"
        run([sys.executable, str(builder), "--preset", "test_case", "--contact-pairs", str(pairs),
             "--out", str(model)])
        cases = {"patch": PATCH} if pairs == 4 else {"patch": PATCH, "between": BETWEEN}
        for kind, contact in cases.items():
            name = f"p{pairs}_{kind}"
            scene = work / f"{name}.yaml"
            scene.write_text(SCENE.format(name=name, model=model, contact=contact))
            run([str(frichb), "--log-level", "warn", "run", str(scene), "-o", str(work / name)])
            summaries[name] = json.loads((work / name / "summary.json").read_text())
    for name, s in summaries.items():
        if s["termination"]["reason"] != "reached_end":
            fail(f"{name}: the sweep ended with {s['termination']['reason']}")
    a = summaries["p1_patch"]["peak"]["response"]
    b = summaries["p1_between"]["peak"]["response"]
    if abs(a["amplitude_m"] / b["amplitude_m"] - 1) > 1e-9 or \
            abs(a["omega_rad_s"] / b["omega_rad_s"] - 1) > 1e-10:
        fail(f"one-pair patch peak {a} differs from the hand-written contact's {b}")
    patch = summaries["p4_patch"]["validated_scene"]["contacts"][0]["patch"]
    model = json.loads((work / "p4" / "model.json").read_text())
    face_area = model["parameters"]["shroud_thickness"] * model["parameters"]["shroud_width"]
    area = sum(p["area_m2"] for p in patch["pairs"])
    if patch["pair_count"] != 4 or abs(area / face_area - 1) > 1e-12:
        fail(f"four-pair patch: {patch['pair_count']} pairs, area {area} of {face_area} m^2")
    states = work / "p4_patch" / "contact_states" / "119.3Hz_1.csv"
    rows = [line.split(",") for line in states.read_text().splitlines()[1:]]
    if len(rows) != 4 or any(abs(sum(float(x) for x in r[7:10]) - 1) > 1e-12 for r in rows):
        fail(f"{states}: expected 4 pairs whose shares stuck + slipping + open sum to 1")
    # The shipped contact-mesh studies, their sweep cut to the two models built here.
    scenes = work / "configs" / "case_studies"
    scenes.mkdir(parents=True)
    generated = work / "configs" / "models" / "generated"
    generated.mkdir(parents=True)
    for pairs in (1, 4):
        (generated / f"test_case_p{pairs}").symlink_to(work / f"p{pairs}")
        run([sys.executable, str(source / "configs/scale/make_face_preload.py"),
             str(work / f"p{pairs}"), "--total", "1.0", "--tilt", "0.8", "--axis", "z",
             "--output", "preload_tilted_1N.csv"])
    for case in ("1", "2", "2_tilted"):
        shipped = source / "configs" / "case_studies" / f"contact_mesh_case{case}.yaml"
        scene = scenes / shipped.name
        shutil.copy(shipped, scene)
        run([str(frichb), "--log-level", "warn", "validate", str(scene),
             "--set", "variables.pairs=4", "--set", "study.sweep.0.values=[1, 4]"])
    print(f"check_fe_patch: one-pair patch = hand-written contact (peak {a['amplitude_m']:.9g} m "
          f"at {a['frequency_hz']:.9g} Hz); four pairs: peak "
          f"{summaries['p4_patch']['peak']['response']['amplitude_m']:.6g} m")


if __name__ == "__main__":
    main()
