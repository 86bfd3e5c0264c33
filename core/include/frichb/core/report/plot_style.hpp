// The look shared by every gnuplot script the reports write (run, study, loop, convergence,
// modes): the terminal and the grid, a colour-blind-safe palette of line types (the Okabe-Ito
// colours, then the same colours dashed), the unit a length axis is drawn in, the choice of a
// log amplitude axis, and the detection of log-spaced study values.
//
// The CSV files stay in SI units; a plot scales a length column with a `using` expression
// (column * LengthScale::factor). Pure functions: no I/O, no state.
#pragma once

#include <cstddef>
#include <span>
#include <string>

#include "frichb/core/scene/scene.hpp"

namespace frichb::core {

// A length unit for an axis: a value in metres times `factor` is in `unit`.
struct LengthScale {
  double factor = 1e6;
  std::string unit = "µm";
};
// The unit of an axis whose largest absolute value is `largest_m` metres: µm below 1 mm
// (and when `largest_m` is zero or not finite), mm from 1 mm, m from 1 m on (a prescribed
// motion of `frichb loop` given in metres).
LengthScale length_scale(double largest_m);
// `factor` as it goes into a gnuplot expression: "1e6" (µm), "1e3" (mm) or "1" (m).
std::string scale_factor_text(const LengthScale& scale);

// The smallest positive and the largest of some plotted values; `add` ignores values that are
// not finite.
struct ValueSpan {
  double smallest_positive = 0.0;  // 0 while no positive value was added
  double largest = 0.0;
  void add(double value);
  // largest / smallest_positive, or 0 while no positive value was added.
  double ratio() const;
};
// Whether an amplitude axis is logarithmic: as `mode` says when linear or log; automatic: when
// the plotted values span more than a decade (span.ratio() > 10).
bool log_amplitude_axis(AmplitudeAxis mode, const ValueSpan& span);

// Whether swept values are log-spaced: all positive, largest / smallest > 10, and the ratios
// of consecutive distinct values (sorted) about constant: the largest of their logarithms at
// most 1.5 times the smallest (a geometric series, or 1-2-5 steps). Fewer than two distinct
// values: false.
bool log_spaced(std::span<const double> values);

// The lines that make the x and/or y axis logarithmic: the range fitted to the data with a
// margin (rather than widened to whole decades) and a light grid at the minor tics. Empty when
// neither is.
std::string log_axes(bool x, bool y);

// The line types of a plot's curves: `set linetype k` for k = 1..count, curve k-1 in colour
// (k-1) mod 7 of the palette and dash type 1, 2, 4, 5 for the first, second, ... round of the
// colours. Plot curve i with `lt i+1`.
std::string line_types(std::size_t count);
// The colours of the palette, in the order line_types uses them (#rrggbb).
std::span<const char* const> palette_colours();

// The first lines of a script: a UTF-8 pngcairo terminal of `width` x `height` writing `png`,
// comma-separated data and a light grid behind the curves.
std::string plot_header(const std::string& png, int width, int height);

// A sequential colour-blind-safe colour map (viridis) for `set palette defined`.
std::string sequential_palette();

// The fewest significant digits (3 to 12) that keep the distinct `values` distinct in
// format_number: the precision of a legend's values.
int distinguishing_digits(std::span<const double> values);

// "name [unit]", or "name" when unit is empty.
std::string axis_label(const std::string& name, const std::string& unit);

}  // namespace frichb::core
