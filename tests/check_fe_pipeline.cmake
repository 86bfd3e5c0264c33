# The FE model pipeline against an independent oracle: builds the shrouded blade test case
# (Gmsh + CalculiX, configs/models/shrouded_blade/build_model.py), computes its nodal-diameter
# map with `frichb modes` (fe_sector: FricHB's own cyclic reduction of the exported matrices in
# the nodes' cylindrical frames) and with CalculiX's own cyclic-symmetry solver on the same mesh
# (ccx_cyclic_frequencies.py: *TIE CYCLIC SYMMETRY, the bore clamped by *BOUNDARY), and requires
# the first 6 families to agree for every nodal diameter. Then runs a short friction sweep on
# the generated files, and the shipped test-case scenes of configs/case_studies. Everything is
# written under ${WORK}; the source tree stays clean.
#
# Tolerance: CalculiX prints eigenvalues with 7 significant digits, i.e. the oracle's
# frequencies are exact to at most 2.5e-7 relative; both sides solve the same discretisation
# (FricHB's matrices are CalculiX's, written with 14 digits), so they agree to that print
# precision (measured worst: 1.8e-7). 1e-6 leaves a margin of 4 over the print precision.
set(MODES 6)
set(RTOL 1e-6)
set(MODELS ${SOURCE}/configs/models/shrouded_blade)

file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})

function(run_step)
  execute_process(COMMAND ${ARGN} WORKING_DIRECTORY ${WORK}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    string(REPLACE ";" " " cmd "${ARGN}")
    message(FATAL_ERROR "step failed (${rc}): ${cmd}\n${out}\n${err}")
  endif()
  set(step_output "${out}" PARENT_SCOPE)
endfunction()

# Fails unless the run written to `dir` reached the end of its frequency sweep.
function(require_reached_end dir)
  file(READ ${dir}/summary.json summary)
  string(JSON reached ERROR_VARIABLE json_err GET "${summary}" termination reached_end)
  if(json_err OR NOT reached)
    message(FATAL_ERROR "the response curve did not reach the end of the sweep (${json_err}): "
                        "see ${dir}/summary.json")
  endif()
endfunction()

# (a) the model, with the Gmsh mesh kept for CalculiX's cyclic solve
run_step(python3 ${MODELS}/build_model.py --preset test_case --out ${WORK}/model --keep-work)
file(READ ${WORK}/model/model.json model_json)
string(JSON sectors GET "${model_json}" parameters sectors)
math(EXPR nd_max "${sectors} / 2")

# (b) a scene on the generated files (paths relative to the scene), EO1 around family 1
# (115.3 Hz free; the shroud contact with a variable normal load opens near the peak)
file(WRITE ${WORK}/scene.yaml "\
name: fe_pipeline_check
description: Gmsh/CalculiX test-case blade, ${sectors} sectors, EO1, 1D shroud friction.
cyclic: {sectors: ${sectors}, engine_order: 1}
structure:
  provider: fe_sector
  params:
    mass: model/sector_mass.mtx
    stiffness: model/sector_stiffness.mtx
    cyclic_pairs: model/cyclic_pairs.txt
    sectors: ${sectors}
    modes: ${MODES}
    modal_damping: [0.002]
    solver: sparse
  dofs: model/dofs.yaml
excitation:
  - {dof: excitation, amplitude: 2.0, direction: [0.0, 1.0, 0.0]}
contacts:
  - name: shroud
    law: jenkins_1d
    between: [{node: shroud_right, sector: 0}, {node: shroud_left, sector: 1}]
    frame: {tangent1: [0.0, 0.0, 1.0], normal: [0.0, -1.0, 0.0]}
    params: {kt: 2.0e5, kn: 1.0e5, mu: 0.5, normal_load: 5.0}
harmonic_balance: {harmonics: [0, 1], samples_per_period: 256}
continuation:
  frequency: {from: 95, to: 135, unit: Hz}
  step: {initial: 0.5, min: 1.0e-6, max: 1.0}
  displacement_scale: 2.0e-5
output:
  response: [response]
")
# families.csv is written with the plots (output.plots, default true)
run_step(${FRICHB} --log-level warn modes ${WORK}/scene.yaml -o ${WORK}/modes)
if(NOT EXISTS ${WORK}/modes/families.csv)
  message(FATAL_ERROR "frichb modes wrote no families.csv")
endif()

# (c) the oracle: CalculiX's cyclic-symmetry frequencies, nodal diameters 0..sectors/2
run_step(python3 ${MODELS}/ccx_cyclic_frequencies.py ${WORK}/model --nmin 0 --nmax ${nd_max}
         --modes ${MODES} --out ${WORK}/ccx_cyclic.json)

# (d) compare (CMake has no floating-point arithmetic)
set(compare [=[
import csv, json, sys
families, oracle, modes, rtol = sys.argv[1], sys.argv[2], int(sys.argv[3]), float(sys.argv[4])
ccx = json.load(open(oracle))["nodal_diameters"]
rows = list(csv.DictReader(open(families)))
if sorted(int(r["nodal_diameter"]) for r in rows) != sorted(int(nd) for nd in ccx):
    sys.exit("nodal diameters differ: frichb %s, CalculiX %s" % (
        [r["nodal_diameter"] for r in rows], sorted(ccx)))
worst, bad = [(0.0, None)] * modes, []
for r in rows:
    nd = str(int(r["nodal_diameter"]))
    for k in range(modes):
        key = "family%d_hz" % (k + 1)
        if key not in r:
            sys.exit("families.csv has no column " + key)
        f, g = float(r[key]), ccx[nd][k]
        d = abs(f - g) / g
        if d > worst[k][0]:
            worst[k] = (d, nd)
        if d > rtol:
            bad.append("ND %s family %d: frichb %.9g Hz, CalculiX %.9g Hz (rel. %.2e)" % (
                nd, k + 1, f, g, d))
for k, (d, nd) in enumerate(worst):
    print("family %d: worst relative difference %.2e (ND %s)" % (k + 1, d, nd))
print("overall worst %.2e, tolerance %.0e" % (max(w[0] for w in worst), rtol))
if bad:
    sys.exit("frichb modes and CalculiX's cyclic symmetry disagree:\n" + "\n".join(bad))
]=])
execute_process(COMMAND python3 -c "${compare}" ${WORK}/modes/families.csv
                        ${WORK}/ccx_cyclic.json ${MODES} ${RTOL}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message(STATUS "frichb modes vs CalculiX cyclic symmetry (${sectors} sectors, "
               "ND 0..${nd_max}):\n${out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "frequency comparison failed (${rc}):\n${err}")
endif()

# (e) a short forced-response sweep with the shroud friction contact
run_step(${FRICHB} --log-level warn run ${WORK}/scene.yaml -o ${WORK}/run)
require_reached_end(${WORK}/run)

# (f) the shipped case-study scenes of the test case (configs/case_studies), on this model:
# copied beside a models/generated/test_case folder as they expect; case 2's study is
# validated run by run, case 1 runs with one harmonic.
file(MAKE_DIRECTORY ${WORK}/configs/case_studies ${WORK}/configs/models/generated)
file(COPY ${WORK}/model/ DESTINATION ${WORK}/configs/models/generated/test_case)
file(GLOB case_scenes ${SOURCE}/configs/case_studies/test_case_*.yaml)
file(COPY ${case_scenes} DESTINATION ${WORK}/configs/case_studies)
run_step(${FRICHB} --log-level warn validate
         ${WORK}/configs/case_studies/test_case_2_eo1_gap_to_preload.yaml)
run_step(${FRICHB} --log-level warn run ${WORK}/configs/case_studies/test_case_1_eo3.yaml
         --set harmonic_balance.max_harmonic=1 -o ${WORK}/case1)
require_reached_end(${WORK}/case1)

# (g) the blade without contacts (the linear response) with steps of up to 10 Hz: every
# resonance of ND 1 in the window (EO1; frequencies from `frichb modes` above) has a traced
# point inside its half-power band and a local maximum within 0.5 % of the peak of a dense
# sampling of the same response around it (steps of a fiftieth of the half-width; the linear
# response at a frequency is exact, so the dense maximum is the peak to 2e-4).
set(free_from 95)
set(free_to 300)
file(READ ${WORK}/scene.yaml scene_text)
string(REGEX REPLACE "contacts:.*harmonic_balance:" "contacts: []\nharmonic_balance:"
       free_text "${scene_text}")
string(REGEX REPLACE "frequency: {from: 95, to: 135, unit: Hz}\n  step: {initial: 0.5, min: 1.0e-6, max: 1.0}"
       "frequency: {from: ${free_from}, to: ${free_to}, unit: Hz}\n  step: {initial: 10, min: 1.0e-6, max: 10}"
       free_text "${free_text}")
if(free_text STREQUAL scene_text OR NOT free_text MATCHES "max: 10}")
  message(FATAL_ERROR "could not derive the contact-free scene from ${WORK}/scene.yaml")
endif()
file(WRITE ${WORK}/free.yaml "${free_text}")
run_step(${FRICHB} --log-level warn run ${WORK}/free.yaml -o ${WORK}/free)
require_reached_end(${WORK}/free)
set(zeta 0.002)
set(dense_points "")
execute_process(COMMAND python3 -c "
import csv, sys
row = [r for r in csv.DictReader(open(sys.argv[1])) if int(r['nodal_diameter']) == 1][0]
lo, hi = float(sys.argv[2]), float(sys.argv[3])
print(';'.join(v for k, v in row.items() if k.startswith('family') and lo < float(v) < hi))
" ${WORK}/modes/families.csv ${free_from} ${free_to}
                OUTPUT_VARIABLE families OUTPUT_STRIP_TRAILING_WHITESPACE RESULT_VARIABLE rc)
if(NOT rc EQUAL 0 OR families STREQUAL "")
  message(FATAL_ERROR "no ND 1 family between ${free_from} and ${free_to} Hz in families.csv")
endif()
set(index 0)
foreach(f IN LISTS families)
  execute_process(COMMAND python3 -c "
f, z = float('${f}'), ${zeta}
print('%.9g;%.9g;%.9g' % (f * (1 - 5 * z), f * (1 + 5 * z), f * z / 50))"
                  OUTPUT_VARIABLE window OUTPUT_STRIP_TRAILING_WHITESPACE)
  list(GET window 0 lo)
  list(GET window 1 hi)
  list(GET window 2 step)
  string(REGEX REPLACE "frequency: {from: ${free_from}, to: ${free_to}, unit: Hz}\n  step: {initial: 10, min: 1.0e-6, max: 10}"
         "frequency: {from: ${lo}, to: ${hi}, unit: Hz}\n  step: {initial: ${step}, min: 1.0e-9, max: ${step}}"
         dense_text "${free_text}")
  file(WRITE ${WORK}/dense${index}.yaml "${dense_text}")
  run_step(${FRICHB} --log-level warn run ${WORK}/dense${index}.yaml -o ${WORK}/dense${index})
  list(APPEND dense_points ${WORK}/dense${index}/response.csv)
  math(EXPR index "${index} + 1")
endforeach()
execute_process(COMMAND python3 -c "
import csv, sys
zeta, traced, dense = float(sys.argv[1]), sys.argv[2], sys.argv[3:]
def curve(path):
    rows = list(csv.reader(open(path)))[1:]
    return [(float(r[1]), float(r[3])) for r in rows]  # (Hz, amplitude of the response DOF)
points, bad, checked = curve(traced), [], 0
for path in dense:
    ref = curve(path)
    i = max(range(len(ref)), key=lambda j: ref[j][1])
    if i == 0 or i == len(ref) - 1:
        print('%.6g Hz: no peak at the response DOF (the mode is not seen there)' % ref[len(ref) // 2][0])
        continue
    at, peak = ref[i]
    hw = zeta * at
    inside = [j for j, p in enumerate(points) if abs(p[0] - at) <= hw]
    maxima = [points[j][1] for j in inside if 0 < j < len(points) - 1
              and points[j][1] >= points[j - 1][1] and points[j][1] >= points[j + 1][1]]
    best = max(maxima, default=0.0)
    err = (best - peak) / peak
    checked += 1
    print('%.6g Hz: %d traced points in the half-power band, traced peak %.6g m, dense %.6g m '
          '(relative %+.2e)' % (at, len(inside), best, peak, err))
    if not inside or abs(err) > 5e-3:
        bad.append('%.6g Hz' % at)
print('%d traced points from 95 to 300 Hz' % len(points))
if checked == 0:
    sys.exit('no resonance seen at the response DOF')
if bad:
    sys.exit('resonances not resolved by the traced curve: ' + ', '.join(bad))
" ${zeta} ${WORK}/free/response.csv ${dense_points}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message(STATUS "contact-free blade, traced against dense sampling:\n${out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "contact-free blade: ${err}")
endif()
