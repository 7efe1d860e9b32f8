// Built with find_package(dco-client) against an installed libdco-client.
#include <dco/client.hpp>

#include <cstdio>

int main() {
  dco::client::Options o;
  o.path = "/nonexistent/dco/depth.shm";
  try {
    dco::client::Client c(o);
  } catch (const dco::client::Error& e) {
    std::printf("%s\n", e.what());
    return e.status() == DCO_E_NO_SEGMENT ? 0 : 1;
  }
  return 1;
}
