// The pure helpers of the reports' plots (report/plot_style.hpp) and the short name and unit
// of a study's swept key (commands/study.hpp's sweep_quantity).
//
// Oracles: the unit thresholds, decade spans and spacings below are worked out by hand from
// the values given; the units are those the plugins' schemas declare (jenkins_1d: kt in N/m,
// normal_load in N, mu dimensionless; lumped: masses in kg; the core's excitation amplitude in
// N).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include "frichb/core/commands/study.hpp"
#include "frichb/core/report/plot_style.hpp"

namespace {

namespace fs = std::filesystem;
using namespace frichb::core;

TEST(PlotStyle, LengthUnitFromTheLargestValue) {
  // 35 µm of amplitude: below 1 mm, shown in µm.
  EXPECT_EQ(length_scale(3.5e-5).unit, "µm");
  EXPECT_EQ(length_scale(3.5e-5).factor, 1e6);
  EXPECT_EQ(length_scale(9.99e-4).unit, "µm");
  // From 1 mm on: mm.
  EXPECT_EQ(length_scale(1e-3).unit, "mm");
  EXPECT_EQ(length_scale(1e-3).factor, 1e3);
  EXPECT_EQ(length_scale(0.02).unit, "mm");
  EXPECT_EQ(length_scale(0.999).unit, "mm");
  // From 1 m on: m.
  EXPECT_EQ(length_scale(1.5).unit, "m");
  EXPECT_EQ(length_scale(1.5).factor, 1.0);
  EXPECT_EQ(scale_factor_text(length_scale(1.5)), "1");
  // The magnitude decides (a displacement axis may be negative).
  EXPECT_EQ(length_scale(-0.004).unit, "mm");
  // Nothing to scale: µm.
  EXPECT_EQ(length_scale(0.0).unit, "µm");
  EXPECT_EQ(length_scale(std::numeric_limits<double>::quiet_NaN()).unit, "µm");
  EXPECT_EQ(scale_factor_text(length_scale(3.5e-5)), "1e6");
  EXPECT_EQ(scale_factor_text(length_scale(0.02)), "1e3");
}

ValueSpan span_of(const std::vector<double>& values) {
  ValueSpan span;
  for (double x : values) span.add(x);
  return span;
}

TEST(PlotStyle, LogAmplitudeAxisWhenTheCurvesSpanMoreThanADecade) {
  // 2 µm to 50 µm: a ratio of 25.
  const ValueSpan wide = span_of({5e-5, 2e-6, 1e-5});
  EXPECT_DOUBLE_EQ(wide.smallest_positive, 2e-6);
  EXPECT_DOUBLE_EQ(wide.largest, 5e-5);
  EXPECT_DOUBLE_EQ(wide.ratio(), 25.0);
  EXPECT_TRUE(log_amplitude_axis(AmplitudeAxis::automatic, wide));
  // 2 µm to 19 µm: 9.5, less than a decade.
  const ValueSpan narrow = span_of({2e-6, 1.9e-5});
  EXPECT_FALSE(log_amplitude_axis(AmplitudeAxis::automatic, narrow));
  // Exactly a decade (0.5 to 5, both exact in binary) is not more than one.
  EXPECT_FALSE(log_amplitude_axis(AmplitudeAxis::automatic, span_of({0.5, 5.0})));
  // Zeros, negatives and non-finite values do not set the smallest positive value: 1e-6 to
  // 1e-4 is two decades.
  const ValueSpan with_zero =
      span_of({0.0, -3e-4, 1e-6, std::numeric_limits<double>::infinity(), 1e-4});
  EXPECT_DOUBLE_EQ(with_zero.smallest_positive, 1e-6);
  EXPECT_DOUBLE_EQ(with_zero.largest, 1e-4);
  EXPECT_TRUE(log_amplitude_axis(AmplitudeAxis::automatic, with_zero));
  // No positive value: linear.
  EXPECT_EQ(span_of({0.0, 0.0}).ratio(), 0.0);
  EXPECT_FALSE(log_amplitude_axis(AmplitudeAxis::automatic, span_of({0.0, 0.0})));
  // output.amplitude_axis forces either way.
  EXPECT_FALSE(log_amplitude_axis(AmplitudeAxis::linear, wide));
  EXPECT_TRUE(log_amplitude_axis(AmplitudeAxis::log, narrow));
}

TEST(PlotStyle, LogSpacingOfSweptValues) {
  // The study of configs/studies: 13 values from 0.2 to 200, log-spaced (a factor 10^(1/4)
  // between neighbours).
  std::vector<double> geometric;
  geometric.reserve(13);
  for (int k = 0; k < 13; ++k) geometric.push_back(0.2 * std::pow(10.0, k / 4.0));
  EXPECT_TRUE(log_spaced(geometric));
  // 1-2-5 steps: log steps ln 2 = 0.69 and ln 2.5 = 0.92, within a factor 1.5.
  EXPECT_TRUE(log_spaced(std::vector<double>{1, 2, 5, 10, 20, 50, 100}));
  // In any order, and repeated as a grid repeats them.
  EXPECT_TRUE(log_spaced(std::vector<double>{100, 1, 10, 100, 1, 10}));
  EXPECT_TRUE(log_spaced(std::vector<double>{1, 100}));
  // 1, 2, ..., 20: log steps from ln 2 = 0.69 down to ln(20/19) = 0.05.
  std::vector<double> linear;
  linear.reserve(20);
  for (int k = 1; k <= 20; ++k) linear.push_back(k);
  EXPECT_FALSE(log_spaced(linear));
  // Geometric but within a decade (ratio 4).
  EXPECT_FALSE(log_spaced(std::vector<double>{1, 2, 4}));
  // Exactly a decade is not more than one.
  EXPECT_FALSE(log_spaced(std::vector<double>{1, 10}));
  // A zero or a negative value: no log axis.
  EXPECT_FALSE(log_spaced(std::vector<double>{0, 1, 10, 100}));
  EXPECT_FALSE(log_spaced(std::vector<double>{-1, 10, 100}));
  // One distinct value.
  EXPECT_FALSE(log_spaced(std::vector<double>{5, 5}));
  EXPECT_FALSE(log_spaced(std::vector<double>{}));
}

TEST(PlotStyle, LineTypesCycleColoursThenDashes) {
  const auto colours = palette_colours();
  ASSERT_EQ(colours.size(), 7u);
  EXPECT_EQ(std::set<std::string>(colours.begin(), colours.end()).size(), 7u);
  const std::string lines = line_types(9);
  // Curves 1-7: the seven colours, solid; curve 8: the first colour again, dashed (dt 2);
  // curve 9: the second colour, dashed.
  EXPECT_NE(lines.find("set linetype 1 lc rgb '#0072B2' lw 2 dt 1\n"), std::string::npos);
  EXPECT_NE(lines.find("set linetype 7 lc rgb '#000000' lw 2 dt 1\n"), std::string::npos);
  EXPECT_NE(lines.find("set linetype 8 lc rgb '#0072B2' lw 2 dt 2\n"), std::string::npos);
  EXPECT_NE(lines.find("set linetype 9 lc rgb '#D55E00' lw 2 dt 2\n"), std::string::npos);
  EXPECT_EQ(lines.find("set linetype 10 "), std::string::npos);
  EXPECT_EQ(line_types(0), "");
}

TEST(PlotStyle, LegendDigitsKeepTheValuesApart) {
  // 0.2, 0.356, 0.632 in three digits.
  EXPECT_EQ(distinguishing_digits(std::vector<double>{0.2, 0.355656, 0.632456}), 3);
  // 1.0001 and 1.0002 read "1" up to four digits, apart from five on.
  EXPECT_EQ(distinguishing_digits(std::vector<double>{1.0001, 1.0002}), 5);
  // Repeated values are one value.
  EXPECT_EQ(distinguishing_digits(std::vector<double>{7, 7, 7}), 3);
}

TEST(PlotStyle, LogAxesFitTheData) {
  EXPECT_EQ(log_axes(false, false), "");
  const std::string y = log_axes(false, true);
  EXPECT_NE(y.find("set logscale y\n"), std::string::npos);
  EXPECT_EQ(y.find("set logscale x"), std::string::npos);
  EXPECT_NE(y.find("set offsets 0, 0, graph 0.05, graph 0.05\n"), std::string::npos);
  const std::string xy = log_axes(true, true);
  EXPECT_NE(xy.find("set logscale x\n"), std::string::npos);
  EXPECT_NE(xy.find("set offsets graph 0.03, graph 0.03, graph 0.05, graph 0.05\n"),
            std::string::npos);
}

TEST(PlotStyle, AxisLabels) {
  EXPECT_EQ(axis_label("amplitude", "µm"), "amplitude [µm]");
  EXPECT_EQ(axis_label("max_harmonic", ""), "max_harmonic");
}

TEST(PlotStyle, ShortNameAndUnitOfASweptKey) {
  const BoundScene bound = load_bound_scene(SceneInput{
      fs::path(FRICHB_SOURCE_DIR) / "configs" / "studies" / "damper_normal_load_sweep.yaml",
      {},
      false});
  const Scene& scene = bound.scene;
  const auto expect = [&](const std::string& path, const std::string& name,
                          const std::string& unit) {
    SCOPED_TRACE(path);
    const SweepQuantity q = sweep_quantity(scene, path);
    EXPECT_EQ(q.name, name);
    EXPECT_EQ(q.unit, unit);
  };
  // A contact law's parameter, the contact by name or by index.
  expect("contacts.platform_friction.params.normal_load", "normal_load", "N");
  expect("contacts.0.params.kt", "kt", "N/m");
  expect("contacts.platform_friction.params.mu", "mu", "");
  // The structure provider's: an entry of a number list.
  expect("structure.params.masses.1", "masses[1]", "kg");
  // The core's sections, in both spellings of a list index.
  expect("excitation.0.amplitude", "amplitude", "N");
  expect("excitation[0].amplitude", "amplitude", "N");
  expect("harmonic_balance.max_harmonic", "max_harmonic", "");
  // A scene variable has no schema.
  expect("variables.pairs", "pairs", "");
}

TEST(PlotStyle, LoadStudyKeepsNameUnitAndSpacing) {
  const BoundScene bound = load_bound_scene(SceneInput{
      fs::path(FRICHB_SOURCE_DIR) / "configs" / "studies" / "damper_normal_load_sweep.yaml",
      {},
      false});
  const StudySpec study = load_study(bound.scene);
  ASSERT_EQ(study.sweeps.size(), 1u);
  EXPECT_EQ(study.sweeps[0].name, "normal_load");
  EXPECT_EQ(study.sweeps[0].unit, "N");
  EXPECT_TRUE(study.sweeps[0].log_spacing);  // spacing: log
  ASSERT_EQ(study.sweeps[0].values.size(), 13u);
  EXPECT_DOUBLE_EQ(study.sweeps[0].values.front(), 0.2);
  EXPECT_DOUBLE_EQ(study.sweeps[0].values.back(), 200.0);
}

}  // namespace
