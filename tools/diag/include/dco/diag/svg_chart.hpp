#pragma once

// Small inline SVG charts for the HTML report: lines over time and a histogram. Self-contained
// markup (no scripts, no fonts to fetch), so the report opens offline.

#include <string>
#include <utility>
#include <vector>

namespace dco::diag {

struct ChartSeries {
  std::string name;
  std::string color;                          // CSS colour
  std::vector<std::pair<double, double>> xy;  // in x order
  bool dots = false;                          // markers instead of a line
};

struct ChartFrame {
  std::string title, x_label, y_label;
  int width = 760, height = 230;
};

// Series with more points than the chart has pixels are thinned to the extreme of each pixel
// column, so spikes stay visible. Empty series draw an empty frame that says "no data".
std::string line_chart_svg(const ChartFrame& frame, const std::vector<ChartSeries>& series);

// `bins` equal bins from 0 (or the minimum when it is negative) to the largest value.
std::string histogram_svg(const ChartFrame& frame, const std::vector<float>& values, int bins);

// Round tick positions covering [low, high]: steps of 1, 2 or 5 times a power of ten.
std::vector<double> nice_ticks(double low, double high, int target_count);

// Text made safe for HTML and SVG markup.
std::string escape_markup(const std::string& text);

}  // namespace dco::diag
