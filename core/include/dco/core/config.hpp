#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

namespace dco {

// Binds dotted keys ("stereo.lambda_ad") to fields of plain parameter structs, then fills them
// from a TOML file ([stereo] lambda_ad = 10) and from "key=value" overrides. Unknown keys, wrong
// types and out-of-range values are rejected with the file and line (or the override text), so a
// typo never silently leaves a default in place.
class ConfigSchema {
 public:
  void add(std::string key, double* target, double min, double max, std::string doc);
  void add(std::string key, int* target, int min, int max, std::string doc);
  void add(std::string key, bool* target, std::string doc);
  void add(std::string key, std::string* target, std::vector<std::string> choices, std::string doc);

  // Throws dco::Error("FILE:LINE: ...") on the first problem; a missing file is an error too.
  void load_file(const std::filesystem::path& path);
  // Parses TOML text; `origin` names it in messages.
  void load_string(std::string_view toml, std::string_view origin);
  // "stereo.lambda_ad=12.5", "stereo.use_color=false", "stereo.mode=fast".
  void set(std::string_view assignment);

  bool has(std::string_view key) const;
  // True once a file or an override gave the key a value (even its default).
  bool was_set(std::string_view key) const;
  // One line per key: name, current value, range or choices, and the doc string.
  std::string describe() const;
  // Every key with its current value as TOML would write it ("12.5", "true", "\"fast\""), in
  // registration order.
  std::vector<std::pair<std::string, std::string>> values() const;
  // The current values as a TOML document that load_file accepts, one table per section, each
  // key preceded by its doc string and range as a comment.
  std::string to_toml() const;

 private:
  struct Entry {
    std::string key;
    std::variant<double*, int*, bool*, std::string*> target;
    double min = 0, max = 0;
    std::vector<std::string> choices;
    std::string doc;
  };
  const Entry* find(std::string_view key) const;
  void assign(const Entry& e, std::string_view text, const std::string& where);
  static std::string value_text(const Entry& e);
  static std::string range_text(const Entry& e);

  std::vector<Entry> entries_;
  std::vector<std::string> assigned_;
};

}  // namespace dco
