#pragma once

// A tcpq peer (LCM's TCP provider) that answers the handshake and then reads nothing more: every
// send to it blocks once the socket buffers are full, as to a peer behind a link gone dead.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <string>
#include <thread>

#include <gtest/gtest.h>

namespace dco::testing {

class StalledTcpqPeer {
 public:
  StalledTcpqPeer() {
    listener_ = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    const int small = 4096;
    setsockopt(listener_, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t length = sizeof address;
    EXPECT_EQ(bind(listener_, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
    EXPECT_EQ(listen(listener_, 1), 0);
    getsockname(listener_, reinterpret_cast<sockaddr*>(&address), &length);
    port_ = ntohs(address.sin_port);
    thread_ = std::thread([this] {
      peer_ = accept(listener_, nullptr, nullptr);
      if (peer_ < 0) return;
      std::uint8_t hello[8];
      [[maybe_unused]] const ssize_t got = recv(peer_, hello, sizeof hello, MSG_WAITALL);
      // LCM tcpq's magic and protocol version, big-endian.
      const std::uint8_t answer[8] = {0x28, 0x76, 0x17, 0xfa, 0x00, 0x00, 0x01, 0x00};
      [[maybe_unused]] const ssize_t sent = send(peer_, answer, sizeof answer, MSG_NOSIGNAL);
    });
  }
  ~StalledTcpqPeer() {
    shutdown(listener_, SHUT_RDWR);
    thread_.join();
    if (peer_ >= 0) close(peer_);  // unblocks a send still waiting on it
    close(listener_);
  }
  std::string url() const { return "tcpq://127.0.0.1:" + std::to_string(port_); }

 private:
  int listener_ = -1, peer_ = -1;
  int port_ = 0;
  std::thread thread_;
};

}  // namespace dco::testing
