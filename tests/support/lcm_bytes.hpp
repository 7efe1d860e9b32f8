#pragma once

// The wire bytes of one LCM message (any lcm-gen type), for tests that build logs and payloads.

#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

namespace dco::testing {

template <class Message>
std::vector<std::uint8_t> lcm_bytes(const Message& m) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(m.getEncodedSize()));
  EXPECT_EQ(m.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  return bytes;
}

}  // namespace dco::testing
