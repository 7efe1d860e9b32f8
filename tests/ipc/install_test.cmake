# Installs libdco-client into a fresh prefix, then builds and runs a C program against it through
# pkg-config and a C++ program through its CMake package. Arguments: BUILD_DIR, WORK_DIR,
# SOURCE_DIR, C_COMPILER, GENERATOR.

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  set(run_output "${out}" PARENT_SCOPE)
endfunction()

set(prefix ${WORK_DIR}/prefix)
file(REMOVE_RECURSE ${WORK_DIR})
run(${CMAKE_COMMAND} --install ${BUILD_DIR} --component client --prefix ${prefix})

file(GLOB_RECURSE pc_files ${prefix}/*/dco-client.pc)
list(LENGTH pc_files n)
if(NOT n EQUAL 1)
  message(FATAL_ERROR "expected one dco-client.pc under ${prefix}, found: ${pc_files}")
endif()
get_filename_component(pc_dir ${pc_files} DIRECTORY)
set(ENV{PKG_CONFIG_PATH} ${pc_dir})
run(pkg-config --cflags dco-client)
string(STRIP "${run_output}" cflags)
run(pkg-config --libs dco-client)
string(STRIP "${run_output}" libs)
separate_arguments(cflags UNIX_COMMAND "${cflags}")
separate_arguments(libs UNIX_COMMAND "${libs}")
if(NOT cflags MATCHES "${prefix}")
  message(FATAL_ERROR "pkg-config points outside the prefix: ${cflags}")
endif()
run(${C_COMPILER} -std=c99 -Wall -Wextra -Werror -pedantic ${cflags} ${SOURCE_DIR}/consumer.c
    ${libs} -o ${WORK_DIR}/consumer_c)
get_filename_component(lib_dir ${pc_dir} DIRECTORY)
set(ENV{LD_LIBRARY_PATH} ${lib_dir})
run(${WORK_DIR}/consumer_c)

run(${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${WORK_DIR}/cpp -G ${GENERATOR}
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build ${WORK_DIR}/cpp)
run(${WORK_DIR}/cpp/consumer_cpp)
file(REMOVE_RECURSE ${WORK_DIR})
