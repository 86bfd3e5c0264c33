#include "frichb/core/commands/loop.hpp"

#include <spdlog/spdlog.h>

#include <cmath>
#include <numbers>

#include "frichb/core/numerics/harmonics.hpp"
#include "frichb/core/plugin_host/periodic_trace.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/plugin/sdk.hpp"

namespace frichb::core {

namespace fs = std::filesystem;
using sdk::Param;

namespace {

const frichb_param_spec* term_fields() {
  static const frichb_param_spec f[] = {
      Param::integer("harmonic", "temporal harmonic n of the term (0: a constant)").at_least(0),
      Param::real("amplitude", "m", "amplitude A"),
      Param::real("phase_deg", "deg", "phase p: A sin(n theta + p) or A cos(n theta + p)")
          .defaults_to(0),
      Param::text("function", "sin or cos").defaults_to_text("sin").choices("sin|cos"),
  };
  return f;
}
constexpr std::size_t kTermFields = 4;

const std::vector<frichb_param_spec>& top_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::text("name", "short name, used in plots").defaults_to_text(""),
      Param::text("description", "free text").defaults_to_text(""),
      Param::text("law", "contact-law plugin name"),
      Param::text_list("plugin_paths", "extra plugin folders, relative to the input file")
          .optional(),
  };
  return s;
}
const std::vector<frichb_param_spec>& motion_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::records("t1", "first tangential component", term_fields(), kTermFields).optional(),
      Param::records("t2", "second tangential component", term_fields(), kTermFields).optional(),
      Param::records("n", "normal component (> 0 closes)", term_fields(), kTermFields).optional(),
  };
  return s;
}
const std::vector<frichb_param_spec>& sampling_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::integer("max_harmonic", "force harmonics reported: 0..max_harmonic")
          .defaults_to(15)
          .at_least(1),
      Param::integer("samples_per_period", "time samples of the trace")
          .defaults_to(1024)
          .at_least(4),
      Param::real("significance", "",
                  "a force harmonic is significant above this fraction of "
                  "the largest one")
          .defaults_to(0.01)
          .greater_than(0)
          .less_than(1),
      Param::integer("max_passes", "bound on passes over the period").defaults_to(500).at_least(1),
  };
  return s;
}
const std::vector<frichb_param_spec>& output_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::boolean("plots", "write loop.png with gnuplot").defaults_to(1),
  };
  return s;
}

sdk::Params view(const std::vector<frichb_param_spec>& schema, const ParamValues& values) {
  return sdk::Params(schema.data(), schema.size(), values.data());
}

}  // namespace

std::vector<CoreSection> loop_schemas() {
  return {{"(top level)", top_schema(),
           "Sections: `params` (the law's parameters), `motion`, `sampling`, `output`."},
          {"motion", motion_schema(),
           "Each component is a list of terms; a component not given stays at zero. Harmonic 0 "
           "adds the constant `amplitude`."},
          {"sampling", sampling_schema(), ""},
          {"output", output_schema(), ""}};
}

namespace {

// A loop input read and validated: the law with its params, the sampling, the motion (its
// section's values, read into coefficients once the tracer's layout is known) and the output.
struct LoopInput {
  std::string file;
  std::string name;  // the input's name, or the file's stem
  YAML::Node root;
  std::shared_ptr<const LoadedPlugin> plugin;
  ParamValues law_values, motion, sampling, output;
  int max_harmonic = 0;
  int samples = 0;
};

LoopInput read_loop_input(const LoopRequest& request) {
  LoopInput in;
  in.file = request.input_file.string();
  const YamlContext ctx{in.file};
  {
    std::error_code ec;
    if (!fs::is_regular_file(request.input_file, ec))
      throw SceneError(in.file, 0, 0, "", "cannot open the loop input file");
    in.root = load_scene_yaml(request.input_file);
  }
  YAML::Node& root = in.root;
  if (!root.IsMap()) ctx.fail(root, "", "a loop input is a YAML map");
  const auto top =
      validate_params(root, top_schema(), "", ctx,
                      std::vector<std::string>{"params", "motion", "sampling", "output"});
  const auto tv = view(top_schema(), top);
  const std::vector<fs::path> extra =
      resolve_plugin_paths(tv.texts("plugin_paths"), root, request.input_file, "input", ctx);
  const Registry registry(Registry::default_search_path(extra));
  try {
    check_plugin_allowed(registry.file_of(tv.text("law")), extra, request.allow_input_plugins);
    in.plugin = registry.load(tv.text("law"), FRICHB_KIND_CONTACT_LAW);
  } catch (const PluginError& e) {
    ctx.fail(root["law"], "law", e.what());
  }
  in.law_values = validate_params(root["params"], in.plugin->schema(), "params", ctx);
  in.motion = validate_params(root["motion"], motion_schema(), "motion", ctx);
  in.sampling = validate_params(root["sampling"], sampling_schema(), "sampling", ctx);
  in.output = validate_params(root["output"], output_schema(), "output", ctx);
  const auto sv = view(sampling_schema(), in.sampling);
  in.max_harmonic = static_cast<int>(sv.integer("max_harmonic"));
  in.samples = static_cast<int>(sv.integer("samples_per_period"));
  if (const auto why = sampling_violation(in.samples, in.max_harmonic); !why.empty())
    ctx.fail(root["sampling"], "sampling.samples_per_period", why);
  in.name = tv.text("name").empty() ? request.input_file.stem().string() : tv.text("name");
  return in;
}

// The motion's coefficients in the tracer's unknown layout (component-major, each a HarmonicLayout
// coefficient vector). Terms of an axis the law does not use are ignored with a warning (logged
// and added to `warnings`).
Eigen::VectorXd motion_coefficients(const LoopInput& in, const PeriodicTracer& tracer,
                                    const HarmonicLayout& layout,
                                    std::vector<std::string>& warnings) {
  const YamlContext ctx{in.file};
  YAML::Node root = in.root;
  const auto mv = view(motion_schema(), in.motion);
  const auto& comps = tracer.components();
  const int c = layout.coefficient_count();
  Eigen::VectorXd u = Eigen::VectorXd::Zero(tracer.unknown_count());
  for (int k = 0; k < 3; ++k) {
    const char* name = kContactAxisNames[k];
    const auto it = std::find(comps.begin(), comps.end(), k);
    const std::size_t terms = mv.record_count(name);
    if (it == comps.end()) {
      if (terms) {
        warnings.push_back(fmt::format("{}: law '{}' does not use motion.{}: ignored", in.file,
                                       in.plugin->name(), name));
        spdlog::warn("{}", warnings.back());
      }
      continue;
    }
    const auto a = static_cast<int>(it - comps.begin());
    for (std::size_t t = 0; t < terms; ++t) {
      const auto term = mv.record(name, t);
      const int n = static_cast<int>(term.integer("harmonic"));
      const double amp = term.real("amplitude");
      const double p = term.real("phase_deg") * std::numbers::pi / 180.0;
      const bool sine = term.text("function") == "sin";
      if (n > in.max_harmonic)
        ctx.fail(root["motion"][name][t],
                 std::string("motion.") + name + "[" + std::to_string(t) + "].harmonic",
                 "harmonic " + std::to_string(n) +
                     " is above sampling.max_harmonic = " + std::to_string(in.max_harmonic));
      const auto k_index = static_cast<std::size_t>(n);
      if (n == 0) {
        u(a * c + layout.cos_index(0)) += amp;
        continue;
      }
      // A sin(n t + p) = A sin p cos + A cos p sin;  A cos(n t + p) = A cos p cos - A sin p sin
      u(a * c + layout.cos_index(k_index)) += sine ? amp * std::sin(p) : amp * std::cos(p);
      u(a * c + layout.sin_index(k_index)) += sine ? amp * std::cos(p) : -amp * std::sin(p);
    }
  }
  return u;
}

// What is read off a traced loop: per sample its status (0 stuck, 1 slipping: the state moved,
// 2 open: a used normal force is zero), the energy per cycle, the force harmonics and, per axis,
// the harmonics above the significance threshold (relative to the axis's largest from 1 up).
struct LoopAnalysis {
  std::vector<int> status;
  double energy = 0.0;
  ForceHarmonics harmonics;
  std::map<std::string, std::vector<int>> significant;
  double threshold = 0.0;
  int slipping = 0, open = 0;
};

LoopAnalysis analyse_loop(const LoopInput& in, const PeriodicTracer& tracer,
                          const ContactTrace& trace) {
  LoopAnalysis r;
  const int samples = in.samples;
  const auto& comps = tracer.components();
  const int d = tracer.dimension();
  const auto normal = std::find(comps.begin(), comps.end(), 2);
  r.status.assign(static_cast<std::size_t>(samples), 0);
  for (int j = 0; j < samples; ++j) {
    const int jp = (j + samples - 1) % samples;
    const bool moved =
        trace.state.cols() > 0 && (trace.state.row(j) - trace.state.row(jp)).cwiseAbs().maxCoeff() >
                                      1e-12 * std::max(1.0, trace.state.cwiseAbs().maxCoeff());
    const bool open = normal != comps.end() && trace.force(j, normal - comps.begin()) <= 0.0;
    r.status[static_cast<std::size_t>(j)] = open ? 2 : (moved ? 1 : 0);
  }
  for (int s : r.status) {
    r.slipping += s == 1;
    r.open += s == 2;
  }
  // Energy dissipated per cycle: the closed integral of f . du (tangential and normal).
  r.energy = trace.energy_per_cycle;
  r.harmonics = force_harmonics(trace.force, comps, in.max_harmonic);
  r.threshold = view(sampling_schema(), in.sampling).real("significance");
  for (int a = 0; a < d; ++a) {
    const auto& amplitude = r.harmonics.amplitude[static_cast<std::size_t>(a)];
    const double largest = *std::max_element(amplitude.begin() + 1, amplitude.end());
    std::vector<int> list;
    for (int h = 1; h <= in.max_harmonic; ++h)
      if (amplitude[static_cast<std::size_t>(h)] > r.threshold * largest) list.push_back(h);
    r.significant[kContactAxisNames[comps[static_cast<std::size_t>(a)]]] = list;
  }
  return r;
}

}  // namespace

LoopResult trace_loop(const LoopRequest& request) {
  const std::string file = request.input_file.string();
  const LoopInput in = read_loop_input(request);
  ContactLawInstance law(in.plugin, in.law_values);
  std::vector<int> harmonics;
  for (int h = 0; h <= in.max_harmonic; ++h) harmonics.push_back(h);
  const HarmonicLayout layout(harmonics, in.samples);
  TraceOptions options;
  options.max_passes = static_cast<int>(view(sampling_schema(), in.sampling).integer("max_passes"));
  PeriodicTracer tracer(law, layout, options);
  LoopResult result;
  const Eigen::VectorXd u = motion_coefficients(in, tracer, layout, result.outcome.warnings);

  ContactTrace trace;
  std::string error;
  if (!tracer.trace(u, JacobianMode::kNone, trace, &error)) throw PluginError(error);
  if (!trace.periodic) {
    result.outcome.warnings.push_back(file + ": " + trace.diagnostic);
    spdlog::warn("{}", result.outcome.warnings.back());
  }
  LoopAnalysis analysis = analyse_loop(in, tracer, trace);
  result.input_file = request.input_file;
  result.name = in.name;
  result.law = in.plugin;
  result.law_params = in.law_values.to_json(in.plugin->schema());
  result.components = tracer.components();
  result.samples = in.samples;
  result.max_harmonic = in.max_harmonic;
  result.displacement_m = trace.displacement;
  result.force_N = trace.force;
  result.status = std::move(analysis.status);
  result.energy_per_cycle_J = analysis.energy;
  result.passes = trace.passes;
  result.periodic = trace.periodic;
  result.fraction_slipping = static_cast<double>(analysis.slipping) / in.samples;
  result.fraction_open = static_cast<double>(analysis.open) / in.samples;
  result.harmonics = std::move(analysis.harmonics);
  result.significant_harmonics = std::move(analysis.significant);
  result.significance_threshold = analysis.threshold;
  result.plots = view(output_schema(), in.output).boolean("plots");
  spdlog::info(
      "{}: {} traced in {} passes; energy per cycle {:.6g} J; slipping {:.0f}% and open "
      "{:.0f}% of the period",
      file, in.plugin->name(), trace.passes, result.energy_per_cycle_J,
      100.0 * result.fraction_slipping, 100.0 * result.fraction_open);
  return result;
}

}  // namespace frichb::core
