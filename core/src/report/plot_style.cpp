// The look shared by the reports' gnuplot scripts (plot_style.hpp).
#include "frichb/core/report/plot_style.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

#include "frichb/core/support/format.hpp"
#include "frichb/core/support/output.hpp"

namespace frichb::core {

namespace {

// Okabe-Ito (Color Universal Design) without its yellow, which reads poorly on white: blue,
// vermillion, bluish green, reddish purple, orange, sky blue, black.
constexpr std::array<const char*, 7> kPalette = {"#0072B2", "#D55E00", "#009E73", "#CC79A7",
                                                 "#E69F00", "#56B4E9", "#000000"};
// gnuplot dash types: solid, dashed, dash-dot, dash-dot-dot.
constexpr std::array<int, 4> kDashes = {1, 2, 4, 5};

}  // namespace

LengthScale length_scale(double largest_m) {
  LengthScale scale;
  if (std::isfinite(largest_m) && std::abs(largest_m) >= 1.0) {
    scale.factor = 1.0;
    scale.unit = "m";
  } else if (std::isfinite(largest_m) && std::abs(largest_m) >= 1e-3) {
    scale.factor = 1e3;
    scale.unit = "mm";
  }
  return scale;
}

std::string scale_factor_text(const LengthScale& scale) {
  return scale.factor == 1.0 ? "1" : scale.factor == 1e3 ? "1e3" : "1e6";
}

void ValueSpan::add(double value) {
  if (!std::isfinite(value)) return;
  largest = std::max(largest, value);
  if (value > 0 && (smallest_positive == 0.0 || value < smallest_positive))
    smallest_positive = value;
}

double ValueSpan::ratio() const {
  return smallest_positive > 0 ? largest / smallest_positive : 0.0;
}

bool log_amplitude_axis(AmplitudeAxis mode, const ValueSpan& span) {
  if (mode == AmplitudeAxis::linear) return false;
  if (mode == AmplitudeAxis::log) return true;
  return span.ratio() > 10.0;
}

bool log_spaced(std::span<const double> values) {
  std::vector<double> sorted(values.begin(), values.end());
  std::sort(sorted.begin(), sorted.end());
  sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
  if (sorted.size() < 2 || !(sorted.front() > 0) || !std::isfinite(sorted.back())) return false;
  if (!(sorted.back() / sorted.front() > 10.0)) return false;
  double lo = std::numeric_limits<double>::infinity(), hi = 0.0;
  for (std::size_t k = 1; k < sorted.size(); ++k) {
    const double step = std::log(sorted[k] / sorted[k - 1]);
    lo = std::min(lo, step);
    hi = std::max(hi, step);
  }
  return hi <= 1.5 * lo;
}

std::string log_axes(bool x, bool y) {
  if (!x && !y) return "";
  std::ostringstream gp;
  // Labels at 2 and 5 times each power of ten too (those outside the range are not drawn):
  // an axis of one or two decades otherwise shows only one or two numbers.
  std::string fine = "(";
  for (int e = -3; e <= 4; ++e)
    for (const char* m : {"2", "5"})
      fine += (fine.size() > 1 ? ", " : "") + std::string(m) + "e" + std::to_string(e);
  fine += ")";
  if (x)
    gp << "set logscale x\nset autoscale xfix\nset grid mxtics\nset xtics add " << fine << "\n";
  if (y)
    gp << "set logscale y\nset autoscale yfix\nset grid mytics\nset ytics add " << fine << "\n";
  const char* side_x = x ? "graph 0.03" : "0";
  const char* side_y = y ? "graph 0.05" : "0";
  gp << "set offsets " << side_x << ", " << side_x << ", " << side_y << ", " << side_y << "\n";
  return gp.str();
}

int distinguishing_digits(std::span<const double> values) {
  std::vector<double> distinct(values.begin(), values.end());
  std::sort(distinct.begin(), distinct.end());
  distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
  for (int digits = 3; digits < 12; ++digits) {
    bool clash = false;
    for (std::size_t k = 1; k < distinct.size() && !clash; ++k)
      clash = format_number(distinct[k], digits) == format_number(distinct[k - 1], digits);
    if (!clash) return digits;
  }
  return 12;
}

std::string line_types(std::size_t count) {
  std::ostringstream gp;
  for (std::size_t k = 0; k < count; ++k)
    gp << "set linetype " << k + 1 << " lc rgb '" << kPalette[k % kPalette.size()] << "' lw 2 dt "
       << kDashes[(k / kPalette.size()) % kDashes.size()] << "\n";
  return gp.str();
}

std::span<const char* const> palette_colours() {
  return kPalette;
}

std::string plot_header(const std::string& png, int width, int height) {
  std::ostringstream gp;
  gp << "set encoding utf8\n"
     << "set terminal pngcairo size " << width << "," << height << " noenhanced font 'sans,11'\n"
     << "set output " << gnuplot_string(png) << "\n"
     << "set datafile separator ','\n"
     << "set grid back lc rgb '#c8c8c8' lw 1 dt 1, lc rgb '#e6e6e6' lw 1 dt 1\n";
  return gp.str();
}

std::string sequential_palette() {
  return "set palette defined (0 '#440154', 0.25 '#3B528B', 0.5 '#21918C', 0.75 '#5EC962', "
         "1 '#FDE725')\n";
}

std::string axis_label(const std::string& name, const std::string& unit) {
  return unit.empty() ? name : name + " [" + unit + "]";
}

}  // namespace frichb::core
