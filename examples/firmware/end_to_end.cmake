# End-to-end check of the firmware example (ctest firmware_end_to_end; the
# firmware itself ran in the fixture firmware_end_to_end_run and wrote
# DIR/fw_joints.csv). Defines: TOOL (host kincal), PYTHON, ROBOT, POSES, ERRORS,
# DIR, COMPARE (compare_joints.py), optional TOLERANCE (default 1e-9) and
# EFFECT (a `simulate --effect` value the machine also has, e.g.
# thermal:c=1.2e-5; the re-simulation then applies it too, at each point's
# temperature).
#   1. the host compensates the same poses with the same model;
#   2. the firmware's joint commands equal the host's (compare_joints.py);
#   3. the erroneous machine (the simulation's hidden errors, no noise) driven
#      by the firmware's commands reaches the held-out poses (layer 2) to the
#      noise level of the measurements the model came from, down from the
#      uncompensated error (pose_errors.py).
if(NOT DEFINED TOLERANCE)
  set(TOLERANCE 1e-9)
endif()
if(NOT DEFINED MAX_RMS_UM)
  set(MAX_RMS_UM 3)
endif()
if(NOT HELD_OUT)
  set(HELD_OUT L2-)  # the held-out rows' id prefix
endif()
if(NOT MIN_RMS_UM)
  set(MIN_RMS_UM 100)  # the uncompensated error the test must start from
endif()
get_filename_component(_here ${CMAKE_CURRENT_LIST_FILE} DIRECTORY)

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  message("${out}")
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${err}\nfailed (${rc}): ${ARGN}")
  endif()
endfunction()

if(NOT EXISTS ${DIR}/fw_joints.csv)
  message(FATAL_ERROR "${DIR}/fw_joints.csv missing: the firmware run (firmware_end_to_end_run) did not write it")
endif()
run(${TOOL} compensate --robot ${ROBOT} --model ${DIR}/model.json --poses ${POSES} --out ${DIR}/host_joints.csv)
run(${PYTHON} ${COMPARE} ${DIR}/fw_joints.csv ${DIR}/host_joints.csv --tolerance ${TOLERANCE})

# Re-simulate the erroneous machine, noise-free: uncompensated (nominal IK of
# the requested poses) and on the firmware's commands.
set(_effect)
set(_fw_joints ${DIR}/fw_joints.csv)
if(EFFECT)
  set(_effect --effect ${EFFECT})
  run(${PYTHON} ${_here}/with_temperature.py ${DIR}/fw_joints.csv ${POSES} ${DIR}/fw_joints_temp.csv)
  set(_fw_joints ${DIR}/fw_joints_temp.csv)
endif()
run(${TOOL} simulate --robot ${ROBOT} --poses ${POSES} --errors ${ERRORS} ${_effect}
    --out ${DIR}/reached_uncompensated.csv)
run(${TOOL} simulate --robot ${ROBOT} --poses ${_fw_joints} --errors ${ERRORS} ${_effect}
    --out ${DIR}/reached_firmware.csv)
# HELD_OUT: an id prefix, or role:<role> for the rows the poses file gives that role.
if(HELD_OUT MATCHES "^role:(.+)$")
  set(_rows --role ${CMAKE_MATCH_1} --poses ${POSES})
else()
  set(_rows --prefix ${HELD_OUT})
endif()
run(${PYTHON} ${_here}/pose_errors.py ${DIR}/reached_uncompensated.csv ${_rows} --label "held-out rows, uncompensated"
    --min-rms-um ${MIN_RMS_UM})
run(${PYTHON} ${_here}/pose_errors.py ${DIR}/reached_firmware.csv ${_rows} --label "held-out rows, firmware commands"
    --max-rms-um ${MAX_RMS_UM})
