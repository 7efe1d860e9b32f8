// The libusb transport on whatever bus the test machine has: often none at all (a container
// without usbfs), so these tests hold for an empty bus and check real devices only when present.

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "dco/drivers/usb_transport.hpp"

namespace dco::drivers {
namespace {

using namespace std::chrono_literals;

constexpr std::uint16_t kIndemindVendor = 0x05a9, kIndemindProduct = 0xf581;

// A transport, or the reason libusb could not start here (then the test is skipped).
class LibusbTransportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    try {
      transport_ = make_libusb_transport();
    } catch (const UsbError& e) {
      ASSERT_STRNE(e.what(), "");
      GTEST_SKIP() << "libusb unavailable: " << e.what();
    }
  }

  std::unique_ptr<UsbTransport> transport_;
};

struct SysfsDevice {
  std::uint16_t vendor = 0, product = 0;
  int bus = 0, address = 0;
};

std::string read_line(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);
  return line;
}

// The kernel's own view of the bus, to check list() against; empty without sysfs.
std::vector<SysfsDevice> sysfs_devices() {
  std::vector<SysfsDevice> out;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/sys/bus/usb/devices", ec)) {
    const auto& dir = entry.path();
    const std::string vendor = read_line(dir / "idVendor");
    const std::string product = read_line(dir / "idProduct");
    const std::string bus = read_line(dir / "busnum");
    const std::string address = read_line(dir / "devnum");
    if (vendor.empty() || product.empty() || bus.empty() || address.empty()) continue;
    try {
      out.push_back({static_cast<std::uint16_t>(std::stoul(vendor, nullptr, 16)),
                     static_cast<std::uint16_t>(std::stoul(product, nullptr, 16)), std::stoi(bus),
                     std::stoi(address)});
    } catch (const std::exception&) {
      // An attribute that is not a number is not a device to compare with.
    }
  }
  return out;
}

void expect_well_formed(const UsbDeviceInfo& d) {
  SCOPED_TRACE(d.port_path);
  EXPECT_GE(d.bus, 1);
  EXPECT_LE(d.bus, 255);
  EXPECT_GE(d.address, 1);
  EXPECT_LE(d.address, 127);
  const std::string prefix = std::to_string(d.bus) + "-";
  ASSERT_GT(d.port_path.size(), prefix.size());
  EXPECT_EQ(d.port_path.compare(0, prefix.size(), prefix), 0);
  EXPECT_TRUE(std::all_of(
      d.port_path.begin() + static_cast<std::ptrdiff_t>(prefix.size()), d.port_path.end(),
      [](char c) { return std::isdigit(static_cast<unsigned char>(c)) || c == '.'; }));
  const std::set<int> speeds = {0, 1, 12, 480, 5000, 10000, 20000};
  EXPECT_TRUE(speeds.contains(d.speed_mbps)) << d.speed_mbps;
  EXPECT_TRUE(std::all_of(d.serial.begin(), d.serial.end(), [](char c) {
    return std::isprint(static_cast<unsigned char>(c));
  })) << d.serial;
}

TEST_F(LibusbTransportTest, ListsNoCameraWhereNoneIsAttached) {
  const auto sysfs = sysfs_devices();
  const bool camera_attached = std::any_of(sysfs.begin(), sysfs.end(), [](const SysfsDevice& d) {
    return d.vendor == kIndemindVendor && d.product == kIndemindProduct;
  });
  const auto cameras = transport_->list(kIndemindVendor, kIndemindProduct);
  if (!camera_attached) {
    EXPECT_TRUE(cameras.empty());
  }
  for (const auto& c : cameras) expect_well_formed(c);
}

TEST_F(LibusbTransportTest, ListedDevicesAreWellFormedAndOnTheBus) {
  // Linux root hubs (1d6b:0002, 1d6b:0003) and whatever else sysfs shows.
  std::set<std::pair<std::uint16_t, std::uint16_t>> ids = {{0x1d6b, 0x0002}, {0x1d6b, 0x0003}};
  const auto sysfs = sysfs_devices();
  for (const auto& d : sysfs) ids.emplace(d.vendor, d.product);
  for (const auto& [vendor, product] : ids) {
    const auto listed = transport_->list(vendor, product);
    std::set<std::pair<int, int>> seen;
    for (const auto& d : listed) {
      expect_well_formed(d);
      EXPECT_TRUE(seen.emplace(d.bus, d.address).second) << "listed twice: " << d.port_path;
      if (!sysfs.empty()) {
        EXPECT_TRUE(std::any_of(sysfs.begin(), sysfs.end(),
                                [&](const SysfsDevice& s) {
                                  return s.vendor == vendor && s.product == product &&
                                         s.bus == d.bus && s.address == d.address;
                                }))
            << "not in sysfs: " << d.port_path;
      }
    }
  }
}

TEST_F(LibusbTransportTest, OpeningAVanishedDeviceSaysItIsGone) {
  UsbDeviceInfo invented;
  invented.bus = 250;
  invented.address = 250;
  try {
    transport_->open(invented);
    FAIL() << "opened a device that does not exist";
  } catch (const UsbError& e) {
    EXPECT_TRUE(e.no_device());
    const std::string what = e.what();
    EXPECT_NE(what.find("device"), std::string::npos) << what;
    EXPECT_NE(what.find("250"), std::string::npos) << what;
    EXPECT_NE(what.find("gone"), std::string::npos) << what;
  }
}

TEST_F(LibusbTransportTest, OpeningAListedDeviceAtAnotherPortSaysItIsGone) {
  // The same bus and address at another port is a new device that reused the address.
  for (const auto& d : sysfs_devices()) {
    for (auto info : transport_->list(d.vendor, d.product)) {
      info.port_path += ".9";
      try {
        transport_->open(info);
        FAIL() << "opened " << info.port_path;
      } catch (const UsbError& e) {
        EXPECT_TRUE(e.no_device()) << e.what();
      }
      return;
    }
  }
  GTEST_SKIP() << "no USB device visible here";
}

TEST_F(LibusbTransportTest, HandleEventsReturnsWithinItsTimeout) {
  const auto start = std::chrono::steady_clock::now();
  EXPECT_NO_THROW(transport_->handle_events(50ms));
  EXPECT_NO_THROW(transport_->handle_events(0ms));
  EXPECT_NO_THROW(transport_->handle_events(-5ms));
  EXPECT_LT(std::chrono::steady_clock::now() - start, 1s);
}

TEST_F(LibusbTransportTest, HotplugWatchCanBeReplacedAndOutlivedByNothing) {
  int first = 0, second = 0;
  transport_->watch_hotplug(kIndemindVendor, kIndemindProduct, [&first] { ++first; });
  transport_->handle_events(10ms);
  transport_->watch_hotplug(kIndemindVendor, kIndemindProduct, [&second] { ++second; });
  transport_->handle_events(10ms);
  transport_->watch_hotplug(0x1d6b, 0x0002, {});  // an empty function just ends the watch
  transport_->watch_hotplug(kIndemindVendor, kIndemindProduct, [&second] { ++second; });
  // No camera comes or goes here.
  EXPECT_EQ(first, 0);
  EXPECT_EQ(second, 0);
  transport_.reset();  // deregisters before the context goes
}

TEST_F(LibusbTransportTest, TransportsAreIndependent) {
  auto other = make_libusb_transport();
  other->watch_hotplug(kIndemindVendor, kIndemindProduct, [] {});
  transport_->watch_hotplug(kIndemindVendor, kIndemindProduct, [] {});
  other.reset();
  EXPECT_NO_THROW(transport_->list(kIndemindVendor, kIndemindProduct));
  EXPECT_NO_THROW(transport_->handle_events(1ms));
}

TEST(UsbTransferStatus, NamesAreDistinct) {
  const TransferStatus all[] = {TransferStatus::kCompleted, TransferStatus::kTimedOut,
                                TransferStatus::kStall,     TransferStatus::kNoDevice,
                                TransferStatus::kOverflow,  TransferStatus::kCancelled,
                                TransferStatus::kError};
  std::set<std::string> names;
  for (TransferStatus s : all) {
    const std::string name = to_string(s);
    EXPECT_FALSE(name.empty());
    EXPECT_NE(name, "unknown");
    names.insert(name);
  }
  EXPECT_EQ(names.size(), std::size(all));
}

}  // namespace
}  // namespace dco::drivers
