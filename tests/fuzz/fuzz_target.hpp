#pragma once

// What a fuzz target provides: the libFuzzer entry point, and seed inputs for the corpus that
// fuzz_driver.cpp mutates (and writes out for a libFuzzer run).

#include <cstddef>
#include <cstdint>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace dco::fuzz {
std::vector<std::vector<std::uint8_t>> seeds();
}
