#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace dco {
class ConfigSchema;
}

namespace dco::tools {

// A command-line mistake (exit status 2), as opposed to a data problem (dco::Error, status 1).
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Walks argv one option at a time; accepts "--name value" and "--name=value".
class ArgCursor {
 public:
  ArgCursor(int argc, char** argv) : argc_(argc), argv_(argv) {}

  // Advances to the next argument; false at the end.
  bool next();
  std::string_view name() const { return name_; }
  // The option's value; throws UsageError when it has none.
  std::string value();
  // Confirms the option is a flag; throws UsageError for "--flag=value".
  bool flag() const;
  // Parses value() as an int; throws UsageError when it is not one.
  int int_value();
  // Parses value() as a number within [min, max]; throws UsageError otherwise.
  double number_value(double min, double max);

 private:
  int argc_;
  char** argv_;
  int index_ = 0;
  std::string_view name_;
  std::optional<std::string> inline_value_;
};

// Checks parameters loaded from an optional config file and --set assignments (`validate`
// throws dco::Error). Without a file every value came from the command line, so a refusal is a
// command-line mistake (UsageError); with one it is the data's (the error as thrown).
void validate_given(bool from_file, const std::function<void()>& validate);

// Whether two paths name one file: the same path, or one file through links (an output given
// twice, or over an input, would replace it).
bool same_file(const std::filesystem::path& a, const std::filesystem::path& b);

// Applies --set KEY=VALUE assignments in order. A bad one (no '=', an unknown key, a value out
// of range) is a command-line mistake: UsageError, exit status 2, as dcod's own --set.
void apply_sets(ConfigSchema& schema, const std::vector<std::string>& assignments);

// Throws UsageError unless `name` is a synthetic scene (hand, boxes, static): a command line
// naming another one is a usage error, found before any work.
void check_synthetic_name(const std::string& name);

struct ImageSize {
  int width = 0, height = 0;
};
// "WIDTHxHEIGHT" as given to `option` (e.g. --size); throws UsageError when malformed or when a
// side is below `minimum` or above `maximum`.
ImageSize parse_image_size(std::string_view option, const std::string& text, int minimum = 1,
                           int maximum = 16384);

// Errors are reported on exactly one line, whatever the message carried: line breaks and tabs
// become spaces, other control characters (a terminal escape in a file name) '?'.
std::string one_line(std::string text);

// Runs a tool's body and turns exceptions into "TOOL: error: ..." on stderr and an exit status:
// 2 for UsageError, 1 for anything else (dco::Error, OpenCV, the standard library).
int run_tool(std::string_view tool, const std::function<int()>& body);

}  // namespace dco::tools
