#include <gtest/gtest.h>

#include "c_abi_smoke.h"
#include "dco/client.h"
#include "ipc_test_support.hpp"

namespace dco::ipc::testing {
namespace {

TEST(ClientCAbi, ACProgramReadsAFrame) {
  TempDir dir;
  RingOptions o;
  o.width = 32;
  o.height = 8;
  RingWriter writer(dir.path() / "depth.shm", o);
  std::uint64_t seq = 0;
  float first = 0;
  EXPECT_EQ(dco_test_c_read(writer.path().c_str(), &seq, &first), DCO_E_NO_FRAME);
  publish_pattern(writer, 77);
  ASSERT_EQ(dco_test_c_read(writer.path().c_str(), &seq, &first), DCO_OK);
  EXPECT_EQ(seq, 77u);
  EXPECT_FLOAT_EQ(first, pattern_depth(77, 0, 0));
  EXPECT_EQ(dco_test_c_read((dir.path() / "none").c_str(), &seq, &first), DCO_E_NO_SEGMENT);
}

// Appending fields must not move the ones callers compiled against.
TEST(ClientCAbi, StructsStartWithTheirSize) {
  dco_frame_view v;
  dco_frame_view_init(&v);
  EXPECT_EQ(v.struct_size, sizeof(dco_frame_view));
  EXPECT_EQ(v.info.struct_size, sizeof(dco_frame_info));
  dco_client_options o;
  dco_client_options_init(&o);
  EXPECT_EQ(o.struct_size, sizeof(dco_client_options));
  EXPECT_EQ(o.expected_uid, getuid());
  EXPECT_EQ(offsetof(dco_frame_view, struct_size), 0u);
  EXPECT_EQ(offsetof(dco_frame_buffer, struct_size), 0u);
}

}  // namespace
}  // namespace dco::ipc::testing
