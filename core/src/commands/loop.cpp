#include "frichb/core/commands/loop.hpp"

#include <spdlog/spdlog.h>

#include <cmath>
#include <numbers>
#include <sstream>

#include "frichb/core/numerics/harmonics.hpp"
#include "frichb/core/plugin_host/periodic_trace.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/report/output.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/support/exit_codes.hpp"
#include "frichb/core/support/interrupt.hpp"
#include "frichb/core/support/version.hpp"
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

int run_loop(const LoopRequest& request) {
  const std::string file = request.input_file.string();
  const YamlContext ctx{file};
  try {
    YAML::Node root;
    {
      std::error_code ec;
      if (!fs::is_regular_file(request.input_file, ec))
        throw SceneError(file, 0, 0, "", "cannot open the loop input file");
      root = load_scene_yaml(request.input_file);
    }
    if (!root.IsMap()) ctx.fail(root, "", "a loop input is a YAML map");
    const auto top =
        validate_params(root, top_schema(), "", ctx,
                        std::vector<std::string>{"params", "motion", "sampling", "output"});
    const auto tv = view(top_schema(), top);
    std::vector<fs::path> extra;
    const auto listed_paths = tv.texts("plugin_paths");
    for (std::size_t i = 0; i < listed_paths.size(); ++i) {
      fs::path path(listed_paths[i]);
      if (!path.is_absolute()) path = request.input_file.parent_path() / path;
      std::error_code missing;
      if (!fs::is_directory(path, missing))
        ctx.fail(root["plugin_paths"][i], "plugin_paths[" + std::to_string(i) + "]",
                 "folder '" + path.string() +
                     "' does not exist (a relative path is taken from the input file's folder)");
      extra.push_back(path);
    }
    const Registry registry(Registry::default_search_path(extra));
    std::shared_ptr<const LoadedPlugin> plugin;
    try {
      check_plugin_allowed(registry.file_of(tv.text("law")), extra);
      plugin = registry.load(tv.text("law"), FRICHB_KIND_CONTACT_LAW);
    } catch (const PluginError& e) {
      ctx.fail(root["law"], "law", e.what());
    }
    const ParamValues law_values = validate_params(root["params"], plugin->schema(), "params", ctx);
    const auto motion = validate_params(root["motion"], motion_schema(), "motion", ctx);
    const auto sampling = validate_params(root["sampling"], sampling_schema(), "sampling", ctx);
    const auto output = validate_params(root["output"], output_schema(), "output", ctx);
    const auto mv = view(motion_schema(), motion);
    const auto sv = view(sampling_schema(), sampling);
    const int max_h = static_cast<int>(sv.integer("max_harmonic"));
    const int samples = static_cast<int>(sv.integer("samples_per_period"));
    std::vector<int> harmonics;
    for (int h = 0; h <= max_h; ++h) harmonics.push_back(h);
    if (const auto why = sampling_violation(samples, max_h); !why.empty())
      ctx.fail(root["sampling"], "sampling.samples_per_period", why);

    ContactLawInstance law(plugin, law_values);
    const HarmonicLayout layout(harmonics, samples);
    TraceOptions options;
    options.max_passes = static_cast<int>(sv.integer("max_passes"));
    PeriodicTracer tracer(law, layout, options);
    const auto& comps = tracer.components();
    const int c = layout.coefficient_count();

    // Motion coefficients of every component the law uses.
    Eigen::VectorXd u = Eigen::VectorXd::Zero(tracer.unknown_count());
    for (int k = 0; k < 3; ++k) {
      const char* name = kContactAxisNames[k];
      const auto it = std::find(comps.begin(), comps.end(), k);
      const std::size_t terms = mv.record_count(name);
      if (it == comps.end()) {
        if (terms)
          spdlog::warn("{}: law '{}' does not use motion.{}: ignored", file, plugin->name(), name);
        continue;
      }
      const auto a = static_cast<int>(it - comps.begin());
      for (std::size_t t = 0; t < terms; ++t) {
        const auto term = mv.record(name, t);
        const int n = static_cast<int>(term.integer("harmonic"));
        const double amp = term.real("amplitude");
        const double p = term.real("phase_deg") * std::numbers::pi / 180.0;
        const bool sine = term.text("function") == "sin";
        if (n > max_h)
          ctx.fail(root["motion"][name][t],
                   std::string("motion.") + name + "[" + std::to_string(t) + "].harmonic",
                   "harmonic " + std::to_string(n) +
                       " is above sampling.max_harmonic = " + std::to_string(max_h));
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

    ContactTrace trace;
    std::string error;
    if (!tracer.trace(u, JacobianMode::kNone, trace, &error)) {
      spdlog::error("{}: {}", file, error);
      return kExitInvalidInput;
    }
    if (!trace.periodic) spdlog::warn("{}: {}", file, trace.diagnostic);

    // Per-sample status: open when a used normal force is zero, slip when the state moved.
    const int d = tracer.dimension();
    const auto normal = std::find(comps.begin(), comps.end(), 2);
    std::vector<int> status(static_cast<std::size_t>(samples), 0);
    for (int j = 0; j < samples; ++j) {
      const int jp = (j + samples - 1) % samples;
      const bool moved = trace.state.cols() > 0 &&
                         (trace.state.row(j) - trace.state.row(jp)).cwiseAbs().maxCoeff() >
                             1e-12 * std::max(1.0, trace.state.cwiseAbs().maxCoeff());
      const bool open = normal != comps.end() && trace.force(j, normal - comps.begin()) <= 0.0;
      status[static_cast<std::size_t>(j)] = open ? 2 : (moved ? 1 : 0);
    }
    // Energy dissipated per cycle: the closed integral of f . du (tangential and normal).
    const double energy = dissipated_energy(trace);
    // Force harmonics of the raw law force.
    const ForceHarmonics harmonics_table = force_harmonics(trace.force, comps, max_h);
    nlohmann::json significant = nlohmann::json::object();
    const double threshold = sv.real("significance");
    for (int a = 0; a < d; ++a) {
      const auto& amplitude = harmonics_table.amplitude[static_cast<std::size_t>(a)];
      const double largest = *std::max_element(amplitude.begin() + 1, amplitude.end());
      std::vector<int> list;
      for (int h = 1; h <= max_h; ++h)
        if (amplitude[static_cast<std::size_t>(h)] > threshold * largest) list.push_back(h);
      significant[kContactAxisNames[comps[static_cast<std::size_t>(a)]]] = list;
    }

    fs::path out_dir = request.output_directory;
    if (out_dir.empty()) out_dir = fs::path("out") / request.input_file.stem();
    StagedOutput out(out_dir, {"loop.csv", "harmonics.csv", "summary.json", "loop.gp", "loop.png"});
    std::vector<std::string> header = {"phase"};
    for (int k : comps) header.push_back(std::string("u_") + kContactAxisNames[k] + "_m");
    for (int k : comps) header.push_back(std::string("f_") + kContactAxisNames[k] + "_N");
    header.push_back("status");
    std::vector<std::vector<double>> rows;
    for (int j = 0; j <= samples; ++j) {  // closed loop: the first sample repeated
      const int jj = j % samples;
      std::vector<double> r = {static_cast<double>(j) / samples};
      for (int a = 0; a < d; ++a) r.push_back(trace.displacement(jj, a));
      for (int a = 0; a < d; ++a) r.push_back(trace.force(jj, a));
      r.push_back(status[static_cast<std::size_t>(jj)]);
      rows.push_back(std::move(r));
    }
    write_csv(out.path("loop.csv"), header, rows);
    write_csv(out.path("harmonics.csv"), harmonics_table.header, harmonics_table.rows);
    int slipping = 0, open = 0;
    for (int s : status) {
      slipping += s == 1;
      open += s == 2;
    }
    const std::string name =
        tv.text("name").empty() ? request.input_file.stem().string() : tv.text("name");
    const nlohmann::json doc = {{"frichb_version", version()},
                                {"input", file},
                                {"law",
                                 {{"name", plugin->name()},
                                  {"version", plugin->descriptor().version},
                                  {"file", plugin->file().string()},
                                  {"params", law_values.to_json(plugin->schema())}}},
                                {"dissipated_energy_per_cycle_J", energy},
                                {"passes", trace.passes},
                                {"periodic", trace.periodic},
                                {"fraction_slipping", static_cast<double>(slipping) / samples},
                                {"fraction_open", static_cast<double>(open) / samples},
                                {"significant_force_harmonics", significant},
                                {"significance_threshold", threshold}};
    write_json(out.path("summary.json"), doc);
    if (view(output_schema(), output).boolean("plots")) {
      std::ostringstream gp;
      gp << "# gnuplot script written by frichb loop\n"
         << "set terminal pngcairo size " << (d > 1 ? 1400 : 800) << ",600 noenhanced\n"
         << "set output 'loop.png'\nset datafile separator ','\nset grid\nset key below\n";
      const bool two_d = comps.size() >= 2 && comps[1] == 1;
      if (d > 1)
        gp << "set multiplot layout 1,2 title "
           << gnuplot_string(name + " (" + plugin->name() + ")") << "\n";
      else
        gp << "set title " << gnuplot_string(name + " (" + plugin->name() + ")") << "\n";
      gp << "set xlabel 'u_t1 [m]'\nset ylabel 'T1 [N]'\n"
         << "plot 'loop.csv' using 2:" << 2 + d << " with lines lw 2 title 'T1 vs u_t1'\n";
      if (two_d) {
        gp << "set xlabel 'T1 [N]'\nset ylabel 'T2 [N]'\nset size ratio -1\n"
           << "plot 'loop.csv' using " << 2 + d << ":" << 3 + d
           << " with lines lw 2 title 'friction loop (T1, T2)'\n";
      } else if (d > 1) {
        gp << "set xlabel 'phase [period]'\nset ylabel 'force [N]'\n"
           << "plot 'loop.csv' using 1:" << 2 + d << " with lines lw 2 title 'T1', "
           << "'loop.csv' using 1:" << 1 + 2 * d << " with lines lw 2 title 'N'\n";
      }
      if (d > 1) gp << "unset multiplot\n";
      write_text(out.path("loop.gp"), gp.str());
      run_gnuplot(out.path("loop.gp"));
    }
    if (interrupted()) {  // a signal while gnuplot ran: nothing is committed
      spdlog::error("interrupted by signal {}; no output written", interrupt_signal());
      return interrupted_exit_code();
    }
    out.commit();
    spdlog::info(
        "{}: {} traced in {} passes; energy per cycle {:.6g} J; slipping {:.0f}% and open "
        "{:.0f}% of the period; wrote {}",
        file, plugin->name(), trace.passes, energy, 100.0 * slipping / samples,
        100.0 * open / samples, out_dir.string());
    return kExitOk;
  } catch (const SceneError& e) {
    spdlog::error("{}", e.what());
    return kExitInvalidInput;
  } catch (const PluginError& e) {
    spdlog::error("{}: {}", file, e.what());
    return kExitInvalidInput;
  } catch (const OutputError& e) {
    spdlog::error("{}: writing the outputs: {}", file, e.what());
    return e.user_error() ? kExitInvalidInput : kExitOutput;
  } catch (const std::exception& e) {
    spdlog::error("{}: {}", file, e.what());
    return kExitInternal;
  }
}

}  // namespace frichb::core
