// Label "slow": the restart scenario for longer, with eight readers and ten writer sessions.

#include <chrono>

#include <gtest/gtest.h>

#include "process_support.hpp"

namespace dco::ipc::testing {
namespace {

TEST(RingSoak, EightReadersAcrossTenWriterSessions) {
  run_restarts(10, std::chrono::milliseconds(2000), 8);
}

}  // namespace
}  // namespace dco::ipc::testing
