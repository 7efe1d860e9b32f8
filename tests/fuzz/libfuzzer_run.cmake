# Builds a fuzz target with clang++ -fsanitize=fuzzer,address,undefined and runs it for SECONDS
# on a corpus seeded by its driver. Prints "libFuzzer unavailable" (ctest: skipped) when clang
# cannot link libFuzzer (Debian: the libclang-rt-14-dev package).
# -D: CLANGXX, SOURCES and INCLUDES (each joined with '|'), WORK_DIR, DRIVER, SECONDS.
string(REPLACE "|" ";" sources "${SOURCES}")
string(REPLACE "|" ";" includes "${INCLUDES}")
list(TRANSFORM includes PREPEND -I)
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR}/corpus)
set(exe ${WORK_DIR}/fuzzer)
execute_process(
  COMMAND ${CLANGXX} -std=c++20 -O1 -g -fsanitize=fuzzer,address,undefined
          -fno-sanitize-recover=all -fno-omit-frame-pointer -o ${exe} ${sources} ${includes}
  RESULT_VARIABLE rc ERROR_VARIABLE err OUTPUT_QUIET)
if(NOT rc EQUAL 0)
  if(err MATCHES "libclang_rt\\.fuzzer|-lFuzzer|cannot find .*fuzzer")
    message("libFuzzer unavailable: ${err}")
    return()
  endif()
  message(FATAL_ERROR "clang++ build of the fuzz target failed:\n${err}")
endif()
execute_process(COMMAND ${DRIVER} --write-corpus ${WORK_DIR}/corpus RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "writing the seed corpus failed")
endif()
execute_process(
  COMMAND ${exe} -max_total_time=${SECONDS} -rss_limit_mb=1024 -malloc_limit_mb=256
          -print_final_stats=1 -artifact_prefix=${WORK_DIR}/ ${WORK_DIR}/corpus
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
string(REGEX MATCH "stat::number_of_executed_units: *[0-9]+" runs "${out}")
message("${runs}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "libFuzzer found a failing input (in ${WORK_DIR}):\n${out}")
endif()
