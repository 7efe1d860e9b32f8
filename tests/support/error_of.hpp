#pragma once

#include <gtest/gtest.h>

#include <string>

#include "dco/core/error.hpp"

namespace dco::testing {

// The message of the dco::Error that `f` throws, or a test failure when it throws none.
template <typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "no dco::Error thrown";
  return {};
}

}  // namespace dco::testing
