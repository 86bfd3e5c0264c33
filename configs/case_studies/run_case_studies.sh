#!/usr/bin/env bash
# The thesis case studies (docs/case-studies.md) from scratch: builds the FE models with Gmsh
# and CalculiX, runs the scenes of this folder with frichb, and draws the figures.
#
#   configs/case_studies/run_case_studies.sh [--large] [--contact-mesh] [OUT_DIR]
#
# OUT_DIR (default out/case_studies) receives every run; docs/figures/case_studies/ the
# figures and case_studies.json. Without options only the 8-sector test case runs (cases 1
# and 2: about 5 minutes on 2 cores); --large adds the 146-sector, 33 k-DOF case 3 and its
# nodal-diameter map (its modal solutions, about 30 s per harmonic index, are cached in
# configs/models/generated/large_case/modes_cache, 0.7 GB: about 40 minutes the first time,
# 5 once cached); --contact-mesh adds the contact-mesh convergence study (the test case with
# its shroud faces meshed as 1 to 128 contact node pairs, cases 1 and 2: about 40 minutes)
# and its figures and contact_mesh.json.
# Needs a build (scripts/build.sh) and the dependencies of scripts/setup.sh.
set -euo pipefail
cd "$(dirname "$0")/../.."
large=0
contact_mesh=0
while [ $# -gt 0 ]; do
  case "$1" in
    --large) large=1; shift ;;
    --contact-mesh) contact_mesh=1; shift ;;
    --*) echo "run_case_studies: unknown option $1" >&2; exit 1 ;;
    *) break ;;
  esac
done
out=${1:-out/case_studies}
frichb=build/bin/frichb
scenes=configs/case_studies
models=configs/models/shrouded_blade
[ -x "$frichb" ] || { echo "run_case_studies: build first (scripts/build.sh)" >&2; exit 1; }
mkdir -p "$out"
step() { echo "== $1 ($(date +%T))"; }
# frichb, where exit code 3 (a curve that ended before the end of its sweep: a reported
# result, its summary.json says why) does not stop the script.
fh() {
  local rc=0
  "$frichb" "$@" || rc=$?
  if [ "$rc" -eq 3 ]; then echo "   (a curve ended early: see the summary.json of the run)"
  elif [ "$rc" -ne 0 ]; then exit "$rc"; fi
}

step "test case model (Gmsh + CalculiX)"
python3 "$models/build_model.py" --preset test_case
step "test case nodal-diameter map"
fh modes "$scenes/test_case_1_eo3.yaml" --rpm 2300 -o "$out/test_case_modes"

step "case 1: EO3, 1, 3, 5 and 10 harmonics"
fh study "$scenes/test_case_1_eo3.yaml" -o "$out/test_case_1"
# The same blade without the contact (mu = 0, constant normal load: no contact force).
fh run "$scenes/test_case_1_eo3.yaml" --set contacts.shroud.params.mu=0 \
  --set contacts.shroud.params.kn=0 --set harmonic_balance.max_harmonic=1 \
  -o "$out/test_case_1_free"

step "case 2: EO1, gap to preload"
fh study "$scenes/test_case_2_eo1_gap_to_preload.yaml" -o "$out/test_case_2"
fh run "$scenes/test_case_2_eo1_gap_to_preload.yaml" --set contacts.shroud.params.mu=0 \
  --set contacts.shroud.params.kn=0 --set contacts.shroud.params.normal_load=0 \
  --set harmonic_balance.max_harmonic=1 -o "$out/test_case_2_free"

if [ "$large" = 1 ]; then
  step "large case model (Gmsh + CalculiX)"
  python3 "$models/build_model.py" --preset large_case
  step "large case nodal-diameter map (74 harmonic indices, about 30 s each when not cached)"
  fh modes "$scenes/large_case_3_eo10.yaml" --rpm 1590 -o "$out/large_case_modes"
  step "case 3: EO10, load cases x harmonics"
  fh study "$scenes/large_case_3_eo10.yaml" -o "$out/large_case_3"
  step "case 3: excitation levels"
  fh study "$scenes/large_case_3_excitation_levels.yaml" -o "$out/large_case_3_excitation_levels"
  step "case 3: friction coefficients"
  fh study "$scenes/large_case_3_friction.yaml" -o "$out/large_case_3_friction"
fi

if [ "$contact_mesh" = 1 ]; then
  step "contact-mesh models: the shroud faces as 1, 4, 16, 64 and 128 node pairs"
  for n in 1 4 16 64 128; do
    python3 "$models/build_model.py" --preset test_case --contact-pairs "$n"
    python3 configs/scale/make_face_preload.py "configs/models/generated/test_case_p$n" \
      --total 1.0 --tilt 0.8 --axis z --output preload_tilted_1N.csv
  done
  step "contact-mesh convergence, case 1 settings (EO3, 1D friction)"
  fh study "$scenes/contact_mesh_case1.yaml" -o "$out/contact_mesh_case1"
  step "contact-mesh convergence, case 2 settings (EO1, 3D coupled friction)"
  # The sample-only step of the coupled law, as docs/case-studies.md measured it.
  sample_only=(--set harmonic_balance.trace_along_motion=false)
  fh study "$scenes/contact_mesh_case2.yaml" "${sample_only[@]}" -o "$out/contact_mesh_case2"
  step "contact-mesh convergence, case 2 settings with the preload varying 9:1 over the face"
  fh study "$scenes/contact_mesh_case2_tilted.yaml" "${sample_only[@]}" \
    -o "$out/contact_mesh_case2_tilted"
  step "contact-mesh models without the contact (the structure's own change with the mesh)"
  free=(--set contacts.shroud.params.mu=0 --set contacts.shroud.params.kn=0
        --set harmonic_balance.max_harmonic=1 --set "output.contact_states_at=[]")
  fh study "$scenes/contact_mesh_case1.yaml" "${free[@]}" -o "$out/contact_mesh_case1_free"
  fh study "$scenes/contact_mesh_case2.yaml" "${free[@]}" \
    --set contacts.shroud.params.normal_load=0 -o "$out/contact_mesh_case2_free"
fi

step "figures"
python3 scripts/case_studies_report.py "$out" docs/figures/case_studies
if [ "$contact_mesh" = 1 ]; then
  python3 scripts/contact_mesh_report.py "$out" configs/models/generated docs/figures/case_studies
fi
