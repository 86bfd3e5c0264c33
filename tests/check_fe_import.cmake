# `frichb import` end to end: the shrouded blade test case (build_model.py, Gmsh + CalculiX) is
# exported by tests/export_vendor_formats.py in the four vendor formats (Abaqus matrix input in
# mm-t-s units and global frames; Abaqus coordinate format; ANSYS HBMAT with the nodes'
# cylindrical frames; ANSYS APDL Math Matrix Market in global frames), each is imported with
# `frichb import`, and `frichb modes` on the imported files must give
#   (1) the frequencies of `frichb modes` on build_model.py's own files to 1e-9 relative (the
#       sharp check: the same matrices, converted, rotated and renumbered on another route), and
#   (2) CalculiX's own cyclic-symmetry frequencies (ccx_cyclic_frequencies.py, run once) to
#       1e-6 relative (CalculiX prints 7 significant digits: at most 2.5e-7 in a frequency).
# The shroud contact nodes coincide with the neighbour's at rest but are not tied, in
# build_model.py's files as in CalculiX's cyclic model: they go to --not-cyclic.
# Everything is written under ${WORK}.
set(MODES 6)
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
  set(step_output "${out}${err}" PARENT_SCOPE)
endfunction()

# The modes of a scene on the files of folder `model` (fe_sector, cyclic_pairs.txt) into
# ${WORK}/modes_<tag>/families.csv.
function(run_modes tag model)
  file(WRITE ${WORK}/${tag}.yaml "\
name: fe_import_${tag}
cyclic: {sectors: ${sectors}, engine_order: 1}
structure:
  provider: fe_sector
  params:
    mass: ${model}/sector_mass.mtx
    stiffness: ${model}/sector_stiffness.mtx
    cyclic_pairs: ${model}/cyclic_pairs.txt
    sectors: ${sectors}
    modes: ${MODES}
    modal_damping: [0.002]
    solver: sparse
  dofs: {probe: 0}
excitation:
  - {dof: probe, amplitude: 1.0}
contacts: []
harmonic_balance: {harmonics: [1], samples_per_period: 16}
continuation:
  frequency: {from: 95, to: 135, unit: Hz}
output:
  response: [probe]
  plots: false
")
  run_step(${FRICHB} --log-level warn modes ${WORK}/${tag}.yaml -o ${WORK}/modes_${tag})
endfunction()

# (a) the model with CalculiX's matrices kept, and its vendor exports
run_step(python3 ${MODELS}/build_model.py --preset test_case --out ${WORK}/model --keep-work)
file(READ ${WORK}/model/model.json model_json)
string(JSON sectors GET "${model_json}" parameters sectors)
string(JSON cyclic_node_pairs GET "${model_json}" counts cyclic_node_pairs)
math(EXPR nd_max "${sectors} / 2")
run_step(python3 ${SOURCE}/tests/export_vendor_formats.py ${WORK}/model ${WORK}/vendor)

# (b) the four imports
set(V ${WORK}/vendor)
set(common --sectors ${sectors} --not-cyclic ${V}/not_cyclic.txt)
run_step(${FRICHB} import abaqus-matrix-input --stiffness ${V}/abaqus_matrix_input/job_STIF1.mtx
         --mass ${V}/abaqus_matrix_input/job_MASS1.mtx --nodes ${V}/abaqus_matrix_input/job.inp
         --units mm-t-s --nodal-frames global ${common} -o ${WORK}/abaqus_matrix_input)
run_step(${FRICHB} import abaqus-coordinate --stiffness ${V}/abaqus_coordinate/job_STIF1.mtx
         --mass ${V}/abaqus_coordinate/job_MASS1.mtx --dof-map ${V}/abaqus_coordinate/equations.txt
         --nodes ${V}/abaqus_coordinate/nodes.csv ${common} -o ${WORK}/abaqus_coordinate)
run_step(${FRICHB} import ansys-hbmat --stiffness ${V}/ansys_hbmat/k.matrix
         --mass ${V}/ansys_hbmat/m.matrix --dof-map ${V}/ansys_hbmat/k.mapping
         --nodes ${V}/ansys_hbmat/sector.node --nodal-frames cylindrical ${common}
         -o ${WORK}/ansys_hbmat)
run_step(${FRICHB} import ansys-mmf --stiffness ${V}/ansys_mmf/k.mmf --mass ${V}/ansys_mmf/m.mmf
         --dof-map ${V}/ansys_mmf/k.mapping --nodes ${V}/ansys_mmf/sector.node ${common}
         -o ${WORK}/ansys_mmf)
set(formats abaqus_matrix_input abaqus_coordinate ansys_hbmat ansys_mmf)
foreach(format IN LISTS formats)
  foreach(name sector_stiffness.mtx sector_mass.mtx cyclic_pairs.txt mesh.yaml nodes.csv)
    if(NOT EXISTS ${WORK}/${format}/${name})
      message(FATAL_ERROR "frichb import ${format} wrote no ${name}")
    endif()
  endforeach()
endforeach()

# (c) the modes of build_model.py's files and of every import; CalculiX's cyclic symmetry
run_modes(reference model)
foreach(format IN LISTS formats)
  run_modes(${format} ${format})
endforeach()
run_step(python3 ${MODELS}/ccx_cyclic_frequencies.py ${WORK}/model --nmin 0 --nmax ${nd_max}
         --modes ${MODES} --out ${WORK}/ccx_cyclic.json)

# (d) compare (CMake has no floating-point arithmetic)
set(compare [=[
import csv, json, sys
work, modes, formats = sys.argv[1], int(sys.argv[2]), sys.argv[3].split(";")
def families(tag):
    rows = list(csv.DictReader(open("%s/modes_%s/families.csv" % (work, tag))))
    return {int(r["nodal_diameter"]): [float(r["family%d_hz" % (k + 1)]) for k in range(modes)]
            for r in rows}
reference = families("reference")
ccx = {int(nd): f for nd, f in json.load(open(work + "/ccx_cyclic.json"))["nodal_diameters"].items()}
if sorted(ccx) != sorted(reference):
    sys.exit("nodal diameters differ: frichb %s, CalculiX %s" % (sorted(reference), sorted(ccx)))
bad = []
for fmt in formats:
    got = families(fmt)
    if sorted(got) != sorted(reference):
        sys.exit("%s: nodal diameters %s, expected %s" % (fmt, sorted(got), sorted(reference)))
    worst_ref = max(abs(g - r) / r for nd in got for g, r in zip(got[nd], reference[nd]))
    worst_ccx = max(abs(g - c) / c for nd in got for g, c in zip(got[nd], ccx[nd][:modes]))
    print("%-20s vs build_model.py route %.2e (tolerance 1e-9), vs CalculiX cyclic %.2e "
          "(tolerance 1e-6)" % (fmt, worst_ref, worst_ccx))
    if worst_ref > 1e-9 or worst_ccx > 1e-6:
        bad.append(fmt)
if bad:
    sys.exit("imported frequencies differ: " + ", ".join(bad))
]=])
execute_process(COMMAND python3 -c "${compare}" ${WORK} ${MODES} "${formats}"
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message(STATUS "frichb import (${sectors} sectors, ND 0..${nd_max}, ${MODES} families):\n${out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "frequency comparison failed (${rc}):\n${err}")
endif()

# (e) the cyclic boundary found by position is build_model.py's, pair for pair
foreach(format IN LISTS formats)
  file(STRINGS ${WORK}/${format}/cyclic_pairs.txt imported REGEX "^[0-9]")
  file(STRINGS ${WORK}/model/cyclic_pairs.txt expected REGEX "^[0-9]")
  list(SORT imported)
  list(SORT expected)
  if(NOT imported STREQUAL expected)
    message(FATAL_ERROR "${format}: cyclic_pairs.txt differs from build_model.py's")
  endif()
endforeach()

# (f) a malformed vendor line: exit code 2 and the file:line in the message
file(READ ${V}/abaqus_coordinate/job_MASS1.mtx mass_text)
file(WRITE ${WORK}/bad_mass.mtx "${mass_text}1, 2\n")
execute_process(COMMAND ${FRICHB} import abaqus-coordinate
                        --stiffness ${V}/abaqus_coordinate/job_STIF1.mtx
                        --mass ${WORK}/bad_mass.mtx --dof-map ${V}/abaqus_coordinate/equations.txt
                        --nodes ${V}/abaqus_coordinate/nodes.csv ${common} -o ${WORK}/bad
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
string(REGEX MATCH "bad_mass.mtx:[0-9]+: expected 'row, column, value'" located "${err}")
if(NOT rc EQUAL 2 OR NOT located OR EXISTS ${WORK}/bad/sector_mass.mtx)
  message(FATAL_ERROR "a malformed line: exit ${rc} (expected 2), message:\n${err}")
endif()
