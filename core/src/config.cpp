#include "dco/core/config.hpp"

#include <algorithm>
#include <cassert>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "dco/core/error.hpp"
#include "dco/core/printable.hpp"
#include "dco/core/utf8.hpp"

namespace dco {
namespace {

// A value as written by the user, before it is checked against the key's type and range.
using Value = std::variant<double, std::int64_t, bool, std::string>;

std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t\r\n") - first + 1);
}

std::string show(const Value& v) {
  return std::visit(
      [](const auto& x) -> std::string {
        using X = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<X, std::string>)
          return "\"" + printable(x) + "\"";
        else
          return fmt::format("{}", x);
      },
      v);
}

std::string join(const std::vector<std::string>& items, std::string_view sep) {
  std::string out;
  for (const auto& s : items) out += (out.empty() ? "" : std::string(sep)) + s;
  return out;
}

// Checks `v` against the entry's type, range or choices; returns the problem or "".
template <typename E>
std::string problem(const E& e, const Value& v) {
  if (std::holds_alternative<double*>(e.target)) {
    double d = 0;
    if (const auto* f = std::get_if<double>(&v))
      d = *f;
    else if (const auto* i = std::get_if<std::int64_t>(&v))
      d = static_cast<double>(*i);
    else
      return fmt::format("expects a number, got {}", show(v));
    if (!(d >= e.min && d <= e.max))
      return fmt::format("value {} is outside [{}, {}]", show(v), e.min, e.max);
  } else if (std::holds_alternative<int*>(e.target)) {
    const auto* i = std::get_if<std::int64_t>(&v);
    if (std::holds_alternative<double>(v))
      return fmt::format("expects an integer, got the float {}", show(v));
    if (i == nullptr) return fmt::format("expects an integer, got {}", show(v));
    if (!(static_cast<double>(*i) >= e.min && static_cast<double>(*i) <= e.max))
      return fmt::format("value {} is outside [{}, {}]", *i, e.min, e.max);
  } else if (std::holds_alternative<bool*>(e.target)) {
    if (!std::holds_alternative<bool>(v))
      return fmt::format("expects true or false, got {}", show(v));
  } else {
    const auto* s = std::get_if<std::string>(&v);
    if (s == nullptr) return fmt::format("expects a string, got {}", show(v));
    // TOML files are UTF-8; a --set could bring any bytes, which no file could then hold.
    if (!is_valid_utf8(*s)) return "the string is not valid UTF-8";
    if (!e.choices.empty() && std::find(e.choices.begin(), e.choices.end(), *s) == e.choices.end())
      return fmt::format("\"{}\" is not one of {}", printable(*s), join(e.choices, ", "));
  }
  return {};
}

// Writes a value that `problem` accepted.
template <typename E>
void store(const E& e, const Value& v) {
  if (auto* const* d = std::get_if<double*>(&e.target)) {
    // + 0.0 turns -0 into 0: no parameter means anything by the sign of zero (1 / -0 is -inf),
    // and the printed configuration reads back as written.
    **d = (std::holds_alternative<double>(v) ? std::get<double>(v)
                                             : static_cast<double>(std::get<std::int64_t>(v))) +
          0.0;
  } else if (auto* const* i = std::get_if<int*>(&e.target)) {
    **i = static_cast<int>(std::get<std::int64_t>(v));
  } else if (auto* const* b = std::get_if<bool*>(&e.target)) {
    **b = std::get<bool>(v);
  } else {
    *std::get<std::string*>(e.target) = std::get<std::string>(v);
  }
}

std::optional<Value> from_toml(const toml::node& n) {
  if (const auto* f = n.as_floating_point()) return Value(f->get());
  if (const auto* i = n.as_integer()) return Value(i->get());
  if (const auto* b = n.as_boolean()) return Value(b->get());
  if (const auto* s = n.as_string()) return Value(s->get());
  return std::nullopt;
}

// from_chars over the whole text, which may start with '+' as a TOML number may.
template <typename T>
std::errc parse_whole(std::string_view s, T& out) {
  if (s.size() > 1 && s.front() == '+' && s[1] != '+' && s[1] != '-') s.remove_prefix(1);
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  if (s.empty() || end != s.data() + s.size()) return std::errc::invalid_argument;
  return ec;
}

}  // namespace

void ConfigSchema::add(std::string key, double* target, double min, double max, std::string doc) {
  assert(target && !find(key) && min <= max);
  entries_.push_back({std::move(key), target, min, max, {}, std::move(doc)});
}

void ConfigSchema::add(std::string key, int* target, int min, int max, std::string doc) {
  assert(target && !find(key) && min <= max);
  entries_.push_back({std::move(key), target, double(min), double(max), {}, std::move(doc)});
}

void ConfigSchema::add(std::string key, bool* target, std::string doc) {
  assert(target && !find(key));
  entries_.push_back({std::move(key), target, 0, 0, {}, std::move(doc)});
}

void ConfigSchema::add(std::string key, std::string* target, std::vector<std::string> choices,
                       std::string doc) {
  // No choices: any string is accepted.
  assert(target && !find(key));
  entries_.push_back({std::move(key), target, 0, 0, std::move(choices), std::move(doc)});
}

const ConfigSchema::Entry* ConfigSchema::find(std::string_view key) const {
  for (const Entry& e : entries_)
    if (e.key == key) return &e;
  return nullptr;
}

bool ConfigSchema::has(std::string_view key) const {
  return find(key) != nullptr;
}

void ConfigSchema::load_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::error_code ec;
  if (!in || std::filesystem::is_directory(path, ec))
    throw Error(fmt::format("{}: cannot open config file", path.string()));
  std::ostringstream ss;
  ss << in.rdbuf();
  load_string(ss.str(), path.string());
}

void ConfigSchema::load_string(std::string_view toml_text, std::string_view origin) {
  toml::table root;
  try {
    root = toml::parse(toml_text, origin);
  } catch (const toml::parse_error& e) {
    throw Error(fmt::format("{}:{}: {}", origin, e.source().begin.line, e.description()));
  }
  // Check everything before storing anything, so a bad file leaves every parameter as it was.
  std::vector<std::pair<const Entry*, Value>> accepted;
  auto fail = [&](const toml::node& n, std::string_view msg) {
    throw Error(fmt::format("{}:{}: {}", origin, n.source().begin.line, msg));
  };
  auto walk = [&](auto&& self, const toml::table& table, const std::string& prefix) -> void {
    for (auto&& [k, node] : table) {
      const std::string key = prefix + std::string(k.str());
      const Entry* e = find(key);
      if (const auto* sub = node.as_table(); sub && !e) {
        const bool known_section =
            std::any_of(entries_.begin(), entries_.end(), [&](const Entry& x) {
              return x.key.size() > key.size() && x.key.compare(0, key.size(), key) == 0 &&
                     x.key[key.size()] == '.';
            });
        if (!known_section) fail(node, fmt::format("unknown section '{}'", key));
        self(self, *sub, key + ".");
        continue;
      }
      if (!e) fail(node, fmt::format("unknown key '{}'", key));
      const auto v = from_toml(node);
      if (!v) fail(node, fmt::format("{}: unsupported value type (tables, arrays, dates)", key));
      if (const std::string p = problem(*e, *v); !p.empty()) fail(node, key + ": " + p);
      // TOML itself refuses a key given twice, but a quoted "a.b" and b in [a] are two of its
      // keys for one parameter: neither may win silently.
      if (std::any_of(accepted.begin(), accepted.end(),
                      [&](const auto& a) { return a.first == e; }))
        fail(node, fmt::format("{} is set twice (a quoted \"{}\" names the same key)", key, key));
      accepted.emplace_back(e, *v);
    }
  };
  walk(walk, root, "");
  for (const auto& [e, v] : accepted) {
    store(*e, v);
    assigned_.push_back(e->key);
  }
}

void ConfigSchema::set(std::string_view assignment) {
  const std::string where = "--set " + std::string(assignment);
  const auto eq = assignment.find('=');
  if (eq == std::string_view::npos) throw Error(where + ": expected key=value");
  const std::string key(trim(assignment.substr(0, eq)));
  const Entry* e = find(key);
  if (!e) throw Error(fmt::format("{}: unknown key '{}'", where, key));
  assign(*e, trim(assignment.substr(eq + 1)), where);
}

void ConfigSchema::assign(const Entry& e, std::string_view text, const std::string& where) {
  // The text is read the way the key's type reads it: "10" is an integer, "true" a bool.
  Value v = std::string(text);
  if (std::holds_alternative<double*>(e.target)) {
    double d = 0;
    const std::errc ec = parse_whole(text, d);
    if (ec == std::errc::result_out_of_range)
      throw Error(fmt::format("{}: '{}' is beyond what a double holds", where, text));
    if (ec != std::errc() || !std::isfinite(d))
      throw Error(fmt::format("{}: '{}' is not a number", where, text));
    v = d;
  } else if (std::holds_alternative<int*>(e.target)) {
    std::int64_t i = 0;
    const std::errc ec = parse_whole(text, i);
    if (ec == std::errc::result_out_of_range)
      throw Error(fmt::format("{}: value {} is outside [{}, {}]", where, text, e.min, e.max));
    if (ec != std::errc()) throw Error(fmt::format("{}: '{}' is not an integer", where, text));
    v = i;
  } else if (std::holds_alternative<bool*>(e.target)) {
    if (text != "true" && text != "false")
      throw Error(fmt::format("{}: '{}' is not true or false", where, text));
    v = text == "true";
  } else if (text.size() >= 2 && text.front() == '"' && text.back() == '"') {
    v = std::string(text.substr(1, text.size() - 2));  // allow a shell-quoted "value"
  }
  if (const std::string p = problem(e, v); !p.empty()) throw Error(where + ": " + p);
  store(e, v);
  assigned_.push_back(e.key);
}

bool ConfigSchema::was_set(std::string_view key) const {
  return std::find(assigned_.begin(), assigned_.end(), key) != assigned_.end();
}

std::string ConfigSchema::value_text(const Entry& e) {
  if (const auto* d = std::get_if<double*>(&e.target)) return fmt::format("{}", **d);
  if (const auto* i = std::get_if<int*>(&e.target)) return fmt::format("{}", **i);
  if (const auto* b = std::get_if<bool*>(&e.target)) return **b ? "true" : "false";
  // A TOML basic string: quotes, backslashes and control characters escaped, so what is written
  // (dcod --print-config) reads back as the same value.
  std::string quoted = "\"";
  for (const char c : *std::get<std::string*>(e.target)) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\')
      quoted += fmt::format("\\{}", c);
    else if (u < 0x20 || u == 0x7f)
      quoted += fmt::format("\\u{:04X}", u);
    else
      quoted += c;
  }
  return quoted + "\"";
}

std::string ConfigSchema::range_text(const Entry& e) {
  if (std::holds_alternative<double*>(e.target) || std::holds_alternative<int*>(e.target))
    return fmt::format("[{}, {}]", e.min, e.max);
  if (std::holds_alternative<bool*>(e.target)) return "true|false";
  return e.choices.empty() ? "any string" : join(e.choices, "|");
}

std::vector<std::pair<std::string, std::string>> ConfigSchema::values() const {
  std::vector<std::pair<std::string, std::string>> out;
  out.reserve(entries_.size());
  for (const Entry& e : entries_) out.emplace_back(e.key, value_text(e));
  return out;
}

std::string ConfigSchema::to_toml() const {
  // Sections in order of first appearance, keys in registration order within each. Keys without
  // a section come first: after a [table] header TOML would read them as the table's.
  std::vector<std::string> sections;
  for (const Entry& e : entries_) {
    const std::string section = e.key.substr(0, e.key.rfind('.') + 1);
    if (std::find(sections.begin(), sections.end(), section) == sections.end())
      sections.push_back(section);
  }
  std::stable_partition(sections.begin(), sections.end(),
                        [](const std::string& section) { return section.empty(); });
  std::string out;
  for (const std::string& section : sections) {
    if (!section.empty())
      out +=
          fmt::format("{}[{}]\n", out.empty() ? "" : "\n", section.substr(0, section.size() - 1));
    for (const Entry& e : entries_) {
      if (e.key.substr(0, e.key.rfind('.') + 1) != section) continue;
      out += fmt::format("# {} ({})\n{} = {}\n", e.doc, range_text(e), e.key.substr(section.size()),
                         value_text(e));
    }
  }
  return out;
}

std::string ConfigSchema::describe() const {
  struct Row {
    std::string key, value, range, doc;
  };
  std::vector<Row> rows;
  for (const Entry& e : entries_) {
    Row r{e.key, value_text(e), range_text(e), e.doc};
    rows.push_back(std::move(r));
  }
  std::size_t wk = 0, wv = 0, wr = 0;
  for (const Row& r : rows) {
    wk = std::max(wk, r.key.size());
    wv = std::max(wv, r.value.size());
    wr = std::max(wr, r.range.size());
  }
  std::string out;
  for (const Row& r : rows)
    out += fmt::format("{:<{}}  {:<{}}  {:<{}}  {}\n", r.key, wk, r.value, wv, r.range, wr, r.doc);
  return out;
}

}  // namespace dco
