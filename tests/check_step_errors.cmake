# Runs benchmarks/step_errors.py on a four-scan route whose trajectory is the truth except that
# the scans from the third on are turned 10° about the third's position (one step, 1 -> 2, is
# 10° off; the others are exact) and whose log's odometry is the truth: the script must find
# that one step, 10° and 0 m off, and the odometry exact.
# Arguments: -DPYTHON=<interpreter> -DSCRIPT=<script> -DWORK_DIR=<dir>.
file(MAKE_DIRECTORY "${WORK_DIR}")
file(WRITE "${WORK_DIR}/truth.txt" "1.0 0 0 0\n1.2 1 0 0\n1.4 2 0 0.5\n1.6 2.5 1 1.0\n")
file(WRITE "${WORK_DIR}/trajectory.txt"
     "1.0 0 0 0\n1.2 1 0 0\n1.4 2 0 0.674532925\n1.6 2.318755699 1.071631842 1.174532925\n")
file(WRITE "${WORK_DIR}/route.clf"
     "FLASER 1 1.0 0 0 0 0 0 0 1.0 host 1.0\n"
     "FLASER 1 1.0 1 0 0 1 0 0 1.2 host 1.2\n"
     "FLASER 1 1.0 2 0 0.5 2 0 0.5 1.4 host 1.4\n"
     "FLASER 1 1.0 2.5 1 1.0 2.5 1 1.0 1.6 host 1.6\n")
execute_process(COMMAND "${PYTHON}" "${SCRIPT}" "${WORK_DIR}/truth.txt"
                        "${WORK_DIR}/trajectory.txt" "${WORK_DIR}/route.clf" --worst 1
                OUTPUT_VARIABLE out RESULT_VARIABLE rc)
message("${out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "step_errors.py failed (${rc})")
endif()
foreach(expected
        "3 steps: trajectory off 0.0000 m 3.333 deg on average, odometry 0.0000 m 0.000 deg"
        "steps off by more than 3 deg: trajectory 1, odometry 0"
        "worst 1 steps by rotation error:\n  step 1 (1.2000 -> 1.4000), true 1.000 m 28.65 deg: trajectory off 0.000 m 10.00 deg, odometry off 0.000 m 0.00 deg")
  string(FIND "${out}" "${expected}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "expected \"${expected}\"")
  endif()
endforeach()
