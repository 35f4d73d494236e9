# Runs benchmarks/relations_consistency.py on three relations whose triangle is off by exactly
# 0.1 m (a->b then b->c ends at (1, 1); a->c says (1, 1.1)) and on the trajectory that agrees
# with the first two: the script must report the 0.1 m inconsistency and the 0.1 m error of the
# long relation on it. Arguments: -DPYTHON=<interpreter> -DSCRIPT=<script> -DWORK_DIR=<dir>.
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
