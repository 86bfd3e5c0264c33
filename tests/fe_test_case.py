"""The FE test-case blade for the check scripts: the model built into a work folder and a
shipped scene copied beside it, so that the scene's relative model paths find it."""
import pathlib
import shutil
import subprocess
import sys


def run_or_fail(command, fail):
    """Runs `command` (no shell); calls fail(message) with its output when it exits non-zero."""
    result = subprocess.run([str(c) for c in command], capture_output=True, text=True)
    if result.returncode != 0:
        fail(f"{' '.join(map(str, command))} exited {result.returncode}:\n"
             f"{result.stdout}{result.stderr}")


def prepare(source: pathlib.Path, work: pathlib.Path, scene_name: str, fail) -> pathlib.Path:
    """Builds the test_case model (configs/models/shrouded_blade) into a fresh `work` and copies
    configs/case_studies/`scene_name` there; returns the copied scene's path."""
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    model = work / "test_case"
    run_or_fail([sys.executable, source / "configs/models/shrouded_blade/build_model.py",
                 "--preset", "test_case", "--out", model], fail)
    generated = work / "configs" / "models" / "generated"
    generated.mkdir(parents=True)
    (generated / "test_case").symlink_to(model)
    scenes = work / "configs" / "case_studies"
    scenes.mkdir(parents=True)
    scene = scenes / scene_name
    shutil.copy(source / "configs/case_studies" / scene_name, scene)
    return scene
