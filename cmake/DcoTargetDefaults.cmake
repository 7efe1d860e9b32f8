# Compile settings shared by every dco target: warnings as errors, a sane x86 baseline, sanitizers.

if(CMAKE_SYSTEM_PROCESSOR MATCHES "x86_64|AMD64")
  # x86-64-v2 (SSE4.2 + POPCNT, every x86 CPU since 2009): census Hamming distances need popcnt.
  set(DCO_ARCH_FLAGS "-march=x86-64-v2" CACHE STRING "Target ISA flags for dco code")
else()
  set(DCO_ARCH_FLAGS "" CACHE STRING "Target ISA flags for dco code")
endif()

function(dco_target_defaults target)
  target_compile_features(${target} PUBLIC cxx_std_20)
  target_compile_options(${target} PRIVATE
    $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra -Wpedantic -Werror -Wshadow -Wnon-virtual-dtor
                              -Wno-error=deprecated-declarations>
    # nvcc: its own warnings as errors, and the host compiler's on the host side of .cu files.
    $<$<COMPILE_LANGUAGE:CUDA>:--Werror=all-warnings -Xcompiler=-Wall,-Wextra,-Werror>)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
    # GCC 12 reports impossible std::string overlaps at -O3 (GCC bug 105329).
    target_compile_options(${target} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:-Wno-restrict>
                                             $<$<COMPILE_LANGUAGE:CUDA>:-Xcompiler=-Wno-restrict>)
  endif()
  if(DCO_ARCH_FLAGS)
    separate_arguments(_arch UNIX_COMMAND "${DCO_ARCH_FLAGS}")
    string(REPLACE ";" "," _arch_cuda "${_arch}")
    target_compile_options(${target} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:${_arch}>
                                             $<$<COMPILE_LANGUAGE:CUDA>:-Xcompiler=${_arch_cuda}>)
  endif()
  if(DCO_SANITIZE)
    # Sanitizer instrumentation makes GCC's flow analysis report uninitialised reads inside
    # libstdc++ (std::regex, std::function) that do not exist in the real code.
    target_compile_options(${target} PRIVATE -fsanitize=${DCO_SANITIZE} -fno-omit-frame-pointer
                                             -fno-sanitize-recover=all -Wno-maybe-uninitialized)
    target_link_options(${target} PRIVATE -fsanitize=${DCO_SANITIZE})
  endif()
endfunction()
