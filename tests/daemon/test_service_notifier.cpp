#include "dco/daemon/service_notifier.hpp"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <string>

#include <gtest/gtest.h>

#include "support/temp_dir.hpp"

namespace dco::testing {
namespace {

// The status quotes the source, whose description may hold a file path: a line break in it must
// not become an assignment of its own (a WATCHDOG=1 that pings while the pipeline is stalled).
TEST(ServiceNotifier, AStatusCannotAddAnAssignment) {
  TempDir dir;
  const std::string path = (dir / "notify").string();
  const int fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  ASSERT_GE(fd, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, path.c_str(), sizeof(addr.sun_path) - 1);
  ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0) << path;
  const timeval timeout{2, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);

  const char* previous = std::getenv("NOTIFY_SOCKET");
  const std::string saved = previous ? previous : "";
  setenv("NOTIFY_SOCKET", path.c_str(), 1);
  const daemon::ServiceNotifier notifier;
  notifier.status("lcmlog:///logs/a\nWATCHDOG=1\n.log");
  notifier.ready("up\r\n");
  if (previous)
    setenv("NOTIFY_SOCKET", saved.c_str(), 1);
  else
    unsetenv("NOTIFY_SOCKET");

  const auto next = [fd] {
    char buf[512];
    const ssize_t n = recv(fd, buf, sizeof buf, 0);
    return n > 0 ? std::string(buf, static_cast<std::size_t>(n)) : std::string("(nothing)");
  };
  EXPECT_EQ(next(), "STATUS=lcmlog:///logs/a?WATCHDOG=1?.log");
  EXPECT_EQ(next(), "READY=1\nSTATUS=up??");
  close(fd);
}

}  // namespace
}  // namespace dco::testing
