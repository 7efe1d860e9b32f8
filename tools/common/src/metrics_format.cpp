// Text and JSON renderings of SceneMetrics (declared in metrics.hpp).

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "dco/tools/json.hpp"
#include "dco/tools/metrics.hpp"

namespace dco::tools {
namespace {

// One table column: header text, digits after the point, and how to read the value.
struct Column {
  const char* header;
  int precision;
  double (*value)(const SceneMetrics&);
};

// clang-format off
constexpr Column kColumns[] = {
    {"dens%",    2, [](const SceneMetrics& m) { return m.density; }},
    {"bad1",     2, [](const SceneMetrics& m) { return m.all.bad1; }},
    {"bad2",     2, [](const SceneMetrics& m) { return m.all.bad2; }},
    {"bad4",     2, [](const SceneMetrics& m) { return m.all.bad4; }},
    {"avgerr",   3, [](const SceneMetrics& m) { return m.all.avgerr; }},
    {"bad1p",    2, [](const SceneMetrics& m) { return m.pred.bad1; }},
    {"bad2p",    2, [](const SceneMetrics& m) { return m.pred.bad2; }},
    {"bad4p",    2, [](const SceneMetrics& m) { return m.pred.bad4; }},
    {"avgerrp",  3, [](const SceneMetrics& m) { return m.pred.avgerr; }},
    {"nocc2",    2, [](const SceneMetrics& m) { return m.nocc.bad2; }},
    {"nocc2p",   2, [](const SceneMetrics& m) { return m.nocc_pred.bad2; }},
    {"occErr",   2, [](const SceneMetrics& m) { return m.occ_err; }},
    {"occErrP",  2, [](const SceneMetrics& m) { return m.occ_err_pred; }},
    {"bandErr",  2, [](const SceneMetrics& m) { return m.band_err; }},
    {"bandErrP", 2, [](const SceneMetrics& m) { return m.band_err_pred; }},
    {"bandFr",   2, [](const SceneMetrics& m) { return m.band_front; }},
    {"bandBh",   2, [](const SceneMetrics& m) { return m.band_behind; }},
    {"bandEdge", 2, [](const SceneMetrics& m) { return m.band_edge; }},
    {"bandSurf", 2, [](const SceneMetrics& m) { return m.band_surface; }},
    {"fill%",    2, [](const SceneMetrics& m) { return m.filled; }},
    {"bad2M",    2, [](const SceneMetrics& m) { return m.matched.bad2; }},
    {"bad2F",    2, [](const SceneMetrics& m) { return m.filled_err.bad2; }},
    {"bandM",    2, [](const SceneMetrics& m) { return m.band_matched; }},
    {"bandF",    2, [](const SceneMetrics& m) { return m.band_filled; }},
    {"ms",       1, [](const SceneMetrics& m) { return m.time_ms; }},
};
// clang-format on
constexpr int kValueWidth = 9;

// Right-aligned in `width` with at least one space before it: a value too wide for its fixed
// digits (a wild prediction, a 16-bit ground truth read as pixels) goes in exponent form rather
// than run into the cell before it.
std::string cell(double value, int precision, int width) {
  if (std::isnan(value)) return fmt::format("{:>{}}", "-", width);
  std::string text = fmt::format("{:.{}f}", value, precision);
  if (static_cast<int>(text.size()) >= width) text = fmt::format("{:.1e}", value);
  return fmt::format("{:>{}}", text, width);
}

std::string table_row(const SceneMetrics& m, std::size_t name_width) {
  std::string line = fmt::format("{:<{}}", m.scene, name_width);
  for (const Column& c : kColumns) line += cell(c.value(m), c.precision, kValueWidth);
  line += '\n';
  return line;
}

std::string stats_json(const ErrorStats& s) {
  return fmt::format(R"({{"pixels": {}, "bad1": {}, "bad2": {}, "bad4": {}, "avgerr": {}}})",
                     s.pixels, json_number(s.bad1), json_number(s.bad2), json_number(s.bad4),
                     json_number(s.avgerr));
}

std::string scene_json(const SceneMetrics& m) {
  std::string planes;
  for (const double p : m.planes) planes += (planes.empty() ? "" : ", ") + json_number(p);
  return fmt::format(
      R"({{"scene": {}, "width": {}, "height": {}, "gt_pixels": {}, "predicted_pixels": {}, )"
      R"("density": {}, "all": {}, "pred": {}, "nocc": {}, "nocc_pred": {}, )"
      R"("occlusion": {{"planes": [{}], "occ_err": {}, "occ_err_pred": {}, "band_err": {}, )"
      R"("band_err_pred": {}, "band_front": {}, "band_behind": {}, "band_edge": {}, )"
      R"("band_surface": {}}}, "matches": {}, "time_ms": {}}})",
      json_string(m.scene), m.width, m.height, m.gt_pixels, m.predicted_pixels,
      json_number(m.density), stats_json(m.all), stats_json(m.pred),
      m.has_nocc ? stats_json(m.nocc) : "null", m.has_nocc ? stats_json(m.nocc_pred) : "null",
      planes, json_number(m.occ_err), json_number(m.occ_err_pred), json_number(m.band_err),
      json_number(m.band_err_pred), json_number(m.band_front), json_number(m.band_behind),
      json_number(m.band_edge), json_number(m.band_surface),
      m.has_matches
          ? fmt::format(R"({{"filled": {}, "matched": {}, "filled_err": {}, "band_matched": {}, )"
                        R"("band_filled": {}}})",
                        json_number(m.filled), stats_json(m.matched), stats_json(m.filled_err),
                        json_number(m.band_matched), json_number(m.band_filled))
          : "null",
      json_number(m.time_ms));
}

std::string signed_cell(double value, int precision, int width) {
  if (std::isnan(value)) return fmt::format("{:>{}}", "-", width);
  return fmt::format("{:>+{}.{}f}", value, width, precision);
}

}  // namespace

std::string format_metrics_table(std::span<const SceneMetrics> scenes) {
  const SceneMetrics mean = mean_metrics(scenes);
  std::size_t name_width = mean.scene.size();
  for (const SceneMetrics& m : scenes) name_width = std::max(name_width, m.scene.size());
  name_width += 2;

  std::string out = fmt::format("{:<{}}", "scene", name_width);
  for (const Column& c : kColumns) out += fmt::format("{:>{}}", c.header, kValueWidth);
  out += '\n';
  for (const SceneMetrics& m : scenes) out += table_row(m, name_width);
  out += table_row(mean, name_width);
  out +=
      "(% of GT pixels; p = predicted pixels only, nocc = mask 255, avgerr in px; occ/band = wrong "
      "side of virtual planes at 20..80 % GT quantiles, band = within 3 px of the GT occlusion "
      "boundary, bandFr/bandBh = of it, predicted in front/behind, bandEdge/bandSurf = of it, "
      "within 3 px of a GT depth edge / where a plane crosses a smooth surface; fill% = left "
      "empty by the sparse map given with the prediction, bad2M/bad2F = bad-2 on the matched / "
      "filled pixels, bandM/bandF = of bandErr, on the matched / filled pixels; - = not "
      "defined)\n";
  return out;
}

std::string format_metrics_json(std::span<const SceneMetrics> scenes) {
  std::string out = "{\"scenes\": [";
  for (std::size_t i = 0; i < scenes.size(); ++i)
    out += (i == 0 ? "\n  " : ",\n  ") + scene_json(scenes[i]);
  out += scenes.empty() ? "]" : "\n]";
  out += ",\n\"mean\": " + scene_json(mean_metrics(scenes)) + "}";
  return out;
}

std::string format_comparison_table(std::span<const KeyComparison> rows, std::string_view a_name,
                                    std::string_view b_name) {
  constexpr int kLabel = 16, kWidth = 14;
  std::string out = fmt::format("{:<{}}{:>{}}{:>{}}{:>{}}{:>{}}\n", "metric", kLabel, a_name,
                                kWidth, b_name, kWidth, "difference", kWidth, "ratio", kWidth);
  for (const KeyComparison& r : rows)
    out +=
        fmt::format("{:<{}}{}{}{}{}\n", r.label, kLabel, cell(r.a, 2, kWidth), cell(r.b, 2, kWidth),
                    signed_cell(r.difference, 2, kWidth), cell(r.ratio, 3, kWidth));
  return out;
}

std::string format_comparison_json(std::span<const KeyComparison> rows, std::string_view a_name,
                                   std::string_view b_name) {
  std::string out = "{";
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const KeyComparison& r = rows[i];
    out += fmt::format(R"({}{}: {{{}: {}, {}: {}, "difference": {}, "ratio": {}}})",
                       i == 0 ? "\n  " : ",\n  ", json_string(r.metric), json_string(a_name),
                       json_number(r.a), json_string(b_name), json_number(r.b),
                       json_number(r.difference), json_number(r.ratio));
  }
  out += rows.empty() ? "}" : "\n}";
  return out;
}

}  // namespace dco::tools
