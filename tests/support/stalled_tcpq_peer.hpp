#pragma once

// A tcpq peer (LCM's TCP provider) that answers the handshake and then reads nothing more: every
// send to it blocks once the socket buffers are full, as to a peer behind a link gone dead. Made
// silent, it accepts the connection and holds its answer until answer() (a server that hangs):
// LCM's set-up then waits for it.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

#include <gtest/gtest.h>

namespace dco::testing {

class StalledTcpqPeer {
 public:
  enum class Handshake { kAnswered, kSilent };

  explicit StalledTcpqPeer(Handshake handshake = Handshake::kAnswered)
      : answer_(handshake == Handshake::kAnswered) {
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
      const int peer = accept(listener_, nullptr, nullptr);
      {
        std::lock_guard lock(mutex_);
        peer_ = peer;
      }
      if (peer < 0) return;
      std::uint8_t hello[8];
      [[maybe_unused]] const ssize_t got = recv(peer, hello, sizeof hello, MSG_WAITALL);
      std::unique_lock lock(mutex_);
      changed_.wait(lock, [&] { return answer_ || closing_; });
      if (closing_) return;
      lock.unlock();
      // LCM tcpq's magic and protocol version, big-endian.
      const std::uint8_t answer[8] = {0x28, 0x76, 0x17, 0xfa, 0x00, 0x00, 0x01, 0x00};
      [[maybe_unused]] const ssize_t sent = send(peer, answer, sizeof answer, MSG_NOSIGNAL);
    });
  }
  ~StalledTcpqPeer() {
    {
      std::lock_guard lock(mutex_);
      closing_ = true;
    }
    changed_.notify_all();
    shutdown(listener_, SHUT_RDWR);
    thread_.join();
    if (peer_ >= 0) close(peer_);  // unblocks a send or a set-up still waiting on it
    close(listener_);
  }
  std::string url() const { return "tcpq://127.0.0.1:" + std::to_string(port_); }
  // A silent peer answers the handshake now (at once if it has not been asked yet).
  void answer() {
    {
      std::lock_guard lock(mutex_);
      answer_ = true;
    }
    changed_.notify_all();
  }

 private:
  int listener_ = -1, peer_ = -1;
  int port_ = 0;
  std::mutex mutex_;
  std::condition_variable changed_;
  bool answer_ = true, closing_ = false;
  std::thread thread_;
};

}  // namespace dco::testing
