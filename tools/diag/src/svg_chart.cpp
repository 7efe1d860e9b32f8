#include "dco/diag/svg_chart.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

namespace dco::diag {
namespace {

constexpr int kLeft = 58, kRight = 14, kTop = 36, kBottom = 36;

struct Axes {
  double x0, x1, y0, y1;
  int w, h;
  double px(double x) const { return kLeft + (x - x0) / (x1 - x0) * (w - kLeft - kRight); }
  double py(double y) const { return h - kBottom - (y - y0) / (y1 - y0) * (h - kTop - kBottom); }
};

std::string tick_label(double v, double step) {
  const double wanted = step > 0 && step < 1 ? std::ceil(-std::log10(step)) : 0;
  const int decimals = static_cast<int>(std::clamp(wanted, 0.0, 9.0));
  return fmt::format("{:.{}f}", v, decimals);
}

std::string open_chart(const ChartFrame& f) {
  return fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} "
      "{1}\" font-family=\"sans-serif\" font-size=\"11\">\n"
      "<rect width=\"{0}\" height=\"{1}\" fill=\"#fff\"/>\n"
      "<text x=\"{2}\" y=\"16\" font-size=\"13\" font-weight=\"bold\">{3}</text>\n",
      f.width, f.height, kLeft, escape_markup(f.title));
}

// Frame, grid, ticks and axis labels.
std::string draw_axes(const ChartFrame& f, const Axes& a, const std::vector<double>& xt,
                      const std::vector<double>& yt) {
  std::string out;
  const double xs = xt.size() > 1 ? xt[1] - xt[0] : 1, ys = yt.size() > 1 ? yt[1] - yt[0] : 1;
  for (double y : yt)
    out += fmt::format(
        "<line x1=\"{0}\" x2=\"{1}\" y1=\"{2:.1f}\" y2=\"{2:.1f}\" stroke=\"#ddd\"/>"
        "<text x=\"{3}\" y=\"{4:.1f}\" text-anchor=\"end\">{5}</text>\n",
        kLeft, f.width - kRight, a.py(y), kLeft - 4, a.py(y) + 4, tick_label(y, ys));
  for (double x : xt)
    out += fmt::format(
        "<line x1=\"{0:.1f}\" x2=\"{0:.1f}\" y1=\"{1}\" y2=\"{2}\" stroke=\"#eee\"/>"
        "<text x=\"{0:.1f}\" y=\"{3}\" text-anchor=\"middle\">{4}</text>\n",
        a.px(x), kTop, f.height - kBottom, f.height - kBottom + 14, tick_label(x, xs));
  out += fmt::format(
      "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#888\"/>\n", kLeft,
      kTop, f.width - kLeft - kRight, f.height - kTop - kBottom);
  out += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n",
                     (kLeft + f.width - kRight) / 2, f.height - 4, escape_markup(f.x_label));
  out += fmt::format(
      "<text transform=\"translate(12 {}) rotate(-90)\" text-anchor=\"middle\">{}</text>\n",
      (kTop + f.height - kBottom) / 2, escape_markup(f.y_label));
  return out;
}

// Keeps the lowest and highest point of each pixel column, in x order.
std::vector<std::pair<double, double>> thin(const std::vector<std::pair<double, double>>& xy,
                                            const Axes& a) {
  const auto columns = static_cast<std::size_t>(a.w - kLeft - kRight);
  if (xy.size() <= 2 * columns) return xy;
  std::vector<std::pair<double, double>> out;
  std::size_t i = 0;
  while (i < xy.size()) {
    const long column = std::lround(a.px(xy[i].first));
    std::size_t lo = i, hi = i, j = i;
    for (; j < xy.size() && std::lround(a.px(xy[j].first)) == column; ++j) {
      if (xy[j].second < xy[lo].second) lo = j;
      if (xy[j].second > xy[hi].second) hi = j;
    }
    out.push_back(xy[std::min(lo, hi)]);
    if (lo != hi) out.push_back(xy[std::max(lo, hi)]);
    i = j;
  }
  return out;
}

std::string no_data(const ChartFrame& f) {
  return open_chart(f) +
         fmt::format(
             "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\" fill=\"#888\">no data in "
             "this log</text>\n</svg>\n",
             f.width / 2, f.height / 2);
}

}  // namespace

std::string escape_markup(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        // Control characters (a corrupt string) would make the document invalid XML.
        out += static_cast<unsigned char>(c) < 0x20 && c != '\n' && c != '\t' ? '?' : c;
    }
  }
  return out;
}

std::vector<double> nice_ticks(double low, double high, int target_count) {
  const double raw = (high - low) / std::max(1, target_count);
  if (!(high > low) || !std::isfinite(raw) || !(raw > 0)) return {low};
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  double step = power;
  for (const double m : {1.0, 2.0, 5.0, 10.0})
    if (m * power >= raw) {
      step = m * power;
      break;
    }
  // Counted, not accumulated: a step below the values' precision must not loop for ever.
  std::vector<double> ticks;
  const double first = std::ceil(low / step - 1e-9);
  for (int k = 0; k <= 3 * target_count + 3; ++k) {
    const double t = (first + k) * step;
    if (t > high + step * 1e-9) break;
    ticks.push_back(std::abs(t) < step * 1e-9 ? 0.0 : t);
  }
  if (ticks.empty()) ticks.push_back(low);
  return ticks;
}

std::string line_chart_svg(const ChartFrame& f, const std::vector<ChartSeries>& series) {
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y1 = 0, y0 = 0;
  for (const ChartSeries& s : series)
    for (const auto& [x, y] : s.xy) {
      if (!std::isfinite(x) || !std::isfinite(y)) continue;
      x0 = std::min(x0, x);
      x1 = std::max(x1, x);
      y0 = std::min(y0, y);
      y1 = std::max(y1, y);
    }
  if (!std::isfinite(x0)) return no_data(f);
  if (x1 <= x0) x1 = x0 + 1;
  if (y1 <= y0) y1 = y0 + 1;
  const std::vector<double> xt = nice_ticks(x0, x1, 8);
  std::vector<double> yt = nice_ticks(y0, y1 * 1.05, 5);
  const Axes a{x0, x1, y0, std::max(y1 * 1.05, yt.back()), f.width, f.height};
  std::string out = open_chart(f) + draw_axes(f, a, xt, yt);
  int legend_x = f.width - kRight;
  for (auto s = series.rbegin(); s != series.rend(); ++s) {
    legend_x -= 14 + 7 * static_cast<int>(s->name.size());
    out += fmt::format(
        "<rect x=\"{}\" y=\"20\" width=\"10\" height=\"10\" fill=\"{}\"/><text x=\"{}\" "
        "y=\"29\">{}</text>\n",
        legend_x, escape_markup(s->color), legend_x + 13, escape_markup(s->name));
  }
  for (const ChartSeries& s : series) {
    const auto points = thin(s.xy, a);
    if (s.dots) {
      out += fmt::format("<g fill=\"{}\">", escape_markup(s.color));
      for (const auto& [x, y] : points)
        if (std::isfinite(x) && std::isfinite(y))
          out += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"1.6\"/>", a.px(x), a.py(y));
      out += "</g>\n";
    } else {
      out += fmt::format("<polyline fill=\"none\" stroke-width=\"1.3\" stroke=\"{}\" points=\"",
                         escape_markup(s.color));
      for (const auto& [x, y] : points)
        if (std::isfinite(x) && std::isfinite(y))
          out += fmt::format("{:.1f},{:.1f} ", a.px(x), a.py(y));
      out += "\"/>\n";
    }
  }
  return out + "</svg>\n";
}

std::string histogram_svg(const ChartFrame& f, const std::vector<float>& values, int bins) {
  if (values.empty() || bins < 1) return no_data(f);
  const auto [lo_it, hi_it] = std::minmax_element(values.begin(), values.end());
  double hi = *hi_it;
  // Values far from zero get the axis to themselves, from a round number below the smallest.
  double lo = std::min(0.0, static_cast<double>(*lo_it));
  if (*lo_it > 0.3 * hi) {
    const std::vector<double> ticks = nice_ticks(*lo_it, hi, 8);
    const double step = ticks.size() > 1 ? ticks[1] - ticks[0] : 1;
    lo = std::floor(*lo_it / step) * step;
  }
  if (hi <= lo) hi = lo + 1;
  const double width = (hi - lo) / bins;
  std::vector<long> counts(static_cast<std::size_t>(bins), 0);
  for (const float v : values)
    if (std::isfinite(v))
      counts[static_cast<std::size_t>(std::clamp((v - lo) / width, 0.0, bins - 1.0))]++;
  const long top = *std::max_element(counts.begin(), counts.end());
  std::vector<double> yt = nice_ticks(0, static_cast<double>(top) * 1.05, 5);
  const Axes a{lo, hi, 0, std::max(static_cast<double>(top) * 1.05, yt.back()), f.width, f.height};
  std::string out = open_chart(f) + draw_axes(f, a, nice_ticks(lo, hi, 8), yt);
  out += "<g fill=\"#4a7ebb\">";
  for (int b = 0; b < bins; ++b) {
    const long n = counts[static_cast<std::size_t>(b)];
    if (n == 0) continue;
    const double x = a.px(lo + b * width), xe = a.px(lo + (b + 1) * width);
    out += fmt::format(
        "<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\"><title>{:.2f}-{:.2f}: "
        "{}</title></rect>",
        x, a.py(static_cast<double>(n)), std::max(0.5, xe - x - 0.5),
        a.py(0) - a.py(static_cast<double>(n)), lo + b * width, lo + (b + 1) * width, n);
  }
  return out + "</g>\n</svg>\n";
}

}  // namespace dco::diag
