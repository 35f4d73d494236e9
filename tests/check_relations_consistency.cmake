# Runs benchmarks/relations_consistency.py on three relations whose triangle is off by exactly
# 0.1 m (a->b then b->c ends at (1, 1); a->c says (1, 1.1)) and on the trajectory that agrees
# with the first two: the script must report the 0.1 m inconsistency and the 0.1 m error of the
# long relation on it. Then --log on four short relations made from a log's odometry, one with
# its translation and three moved by lattice vectors of 5 cm ((5, 0), (0, -5), (5, 5) cm), their
# yaws by 1, 2, 0 and 1 steps of 0.25 deg, and the trajectory that is the odometry: the script
# must find the lattices, the trajectory's errors are the corrections, and it lies all the way
# from the relations towards the odometry.
# Arguments: -DPYTHON=<interpreter> -DSCRIPT=<script> -DWORK_DIR=<dir>.
file(MAKE_DIRECTORY "${WORK_DIR}")
file(WRITE "${WORK_DIR}/triangle.relations"
     "1.0 2.0 1 0 0 0 0 1.5707963267948966\n"
     "2.0 3.5 1 0 0 0 0 0\n"
     "1.0 3.5 1 1.1 0 0 0 1.5707963267948966\n")
file(WRITE "${WORK_DIR}/triangle.txt"
     "1.0 0 0 0\n2.0 1 0 1.5707963267948966\n3.5 1 1 1.5707963267948966\n")
execute_process(COMMAND "${PYTHON}" "${SCRIPT}" "${WORK_DIR}/triangle.relations"
                        --trajectory "${WORK_DIR}/triangle.txt"
                OUTPUT_VARIABLE out RESULT_VARIABLE rc)
message("${out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "relations_consistency.py failed (${rc})")
endif()
foreach(expected
        "3 relations, 1 triangles: inconsistency median 0.1000 m, max 0.1000 m"
        "long  relations on a triangle inconsistent by > 0.08 m: 1, mean error 0.1000 m"
        "short relations on a triangle inconsistent by > 0.08 m: 2, mean error 0.0000 m")
  string(FIND "${out}" "${expected}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "expected \"${expected}\"")
  endif()
endforeach()

file(WRITE "${WORK_DIR}/lattice.relations"
     "1.0 1.2 0.300000000 0.000000000 0 0 0 0.104363323\n"
     "1.2 1.4 0.353492920 0.019800183 0 0 0 0.108726646\n"
     "1.4 1.6 0.307926827 -0.040996139 0 0 0 0.050000000\n"
     "1.0 1.4 0.650000000 0.100000000 0 0 0 0.204363323\n")
file(WRITE "${WORK_DIR}/lattice.clf"
     "FLASER 1 1.0 0 0 0 0 0 0 1.0 host 1.0\n"
     "FLASER 1 1.0 0.3 0 0.1 0.3 0 0.1 1.2 host 1.2\n"
     "FLASER 1 1.0 0.6 0.05 0.2 0.6 0.05 0.2 1.4 host 1.4\n"
     "FLASER 1 1.0 0.9 0.12 0.25 0.9 0.12 0.25 1.6 host 1.6\n")
file(WRITE "${WORK_DIR}/lattice.txt" "1.0 0 0 0\n1.2 0.3 0 0.1\n1.4 0.6 0.05 0.2\n1.6 0.9 0.12 0.25\n")
execute_process(COMMAND "${PYTHON}" "${SCRIPT}" "${WORK_DIR}/lattice.relations"
                        --log "${WORK_DIR}/lattice.clf" --trajectory "${WORK_DIR}/lattice.txt"
                OUTPUT_VARIABLE out RESULT_VARIABLE rc)
message("${out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "relations_consistency.py --log failed (${rc})")
endif()
foreach(expected
        "4 short relations against the log's odometry: 1 with its translation (within 0.1 mm)"
        "3 of 3 corrections on the lattice of h = 0.0500 m"
        "an error-free trajectory scores about 0.0191 m on these 4 relations"
        "yaw corrections: 4 of 4 on offset 0.0000 + k * 0.00436 rad (0.250 deg)"
        "trajectory on the short relations with the odometry's translation: 1, mean error 0.0000 m"
        "trajectory on the short relations with a corrected one: 3, mean error 0.0569 m"
        "on the corrected ones the trajectory lies on average 100 % of the way from the relation")
  string(FIND "${out}" "${expected}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "expected \"${expected}\"")
  endif()
endforeach()
