#pragma once

#include <stdexcept>
#include <string>

namespace dco {

// Every failure dco reports to a user (bad file, bad size, bad parameter) is an Error with one
// line that names the culprit. Programming errors stay asserts.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace dco
