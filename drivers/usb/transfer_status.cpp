#include "dco/drivers/usb_transport.hpp"

namespace dco::drivers {

const char* to_string(TransferStatus status) {
  switch (status) {
    case TransferStatus::kCompleted:
      return "completed";
    case TransferStatus::kTimedOut:
      return "timed out";
    case TransferStatus::kStall:
      return "stall";
    case TransferStatus::kNoDevice:
      return "no device";
    case TransferStatus::kOverflow:
      return "overflow";
    case TransferStatus::kCancelled:
      return "cancelled";
    case TransferStatus::kError:
      return "error";
  }
  return "unknown";
}

}  // namespace dco::drivers
