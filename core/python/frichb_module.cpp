// The Python module `frichb`: the verbs of the core as functions that return objects holding
// numpy arrays, with the results `frichb` gives on the command line (the same functions run).
//
// Threading: each call releases the GIL while it computes, on a thread of its own; the calling
// thread waits for it and, when it is Python's main thread, checks for signals every 50 ms: a
// Ctrl-C stops the call through its stop token (support/interrupt.hpp) and raises
// KeyboardInterrupt once the computation has returned (a continuation step, a Newton
// iteration). Calls from several Python threads run at once, each with its own token.
// Errors: a scene the core refuses raises frichb.SceneError (file, line, column, key), a plugin
// frichb.PluginError, an output folder that cannot be written frichb.OutputError; a bad
// override ValueError.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <array>
#include <chrono>
#include <complex>
#include <csignal>
#include <exception>
#include <filesystem>
#include <future>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "frichb/core/commands/convergence.hpp"
#include "frichb/core/commands/loop.hpp"
#include "frichb/core/commands/modes.hpp"
#include "frichb/core/commands/nma.hpp"
#include "frichb/core/commands/peaks.hpp"
#include "frichb/core/commands/run.hpp"
#include "frichb/core/commands/study.hpp"
#include "frichb/core/commands/timesim.hpp"
#include "frichb/core/commands/validate.hpp"
#include "frichb/core/numerics/harmonics.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/plugin_host/schema.hpp"
#include "frichb/core/report/convergence_report.hpp"
#include "frichb/core/report/loop_report.hpp"
#include "frichb/core/report/modes_report.hpp"
#include "frichb/core/report/nma_report.hpp"
#include "frichb/core/report/peaks_report.hpp"
#include "frichb/core/report/run_report.hpp"
#include "frichb/core/report/study_report.hpp"
#include "frichb/core/report/timesim_report.hpp"
#include "frichb/core/support/interrupt.hpp"
#include "frichb/core/support/output.hpp"
#include "frichb/core/support/version.hpp"

namespace py = pybind11;
namespace core = frichb::core;
namespace fs = std::filesystem;

namespace {

// The module's exception classes (created at import, alive for the rest of the process).
struct ErrorClasses {
  py::handle base, scene, plugin, output;
};
ErrorClasses& error_classes() {
  static ErrorClasses classes;
  return classes;
}

// `compute()` on a thread of its own with the GIL released. From Python's main thread, a
// signal whose Python handler raises (Ctrl-C: KeyboardInterrupt) stops the call through
// `source` and is raised once the computation has returned.
template <typename Compute>
auto call_stoppable(const core::StopSource& source, Compute compute) -> decltype(compute()) {
  using namespace std::chrono_literals;
  py::gil_scoped_release released;
  auto running = std::async(std::launch::async, std::move(compute));
  while (running.wait_for(50ms) != std::future_status::ready) {
    py::gil_scoped_acquire held;
    if (PyErr_CheckSignals() != 0) {
      source.request_stop(SIGINT);
      {
        py::gil_scoped_release waiting;
        running.wait();
      }
      throw py::error_already_set();
    }
  }
  return running.get();
}

// The scene input of a call: a scene file (str or os.PathLike) or a scene as a dict (written
// as JSON text, which YAML reads, one key per line so that errors give useful lines; named
// "<dict>" in the current folder, which its relative paths are taken from), `set` as
// overrides (each value written as YAML flow text: JSON), the plugin permission.
core::SceneInput scene_input(const py::object& scene, const py::dict& set,
                             bool allow_scene_plugins) {
  const py::object dumps = py::module_::import("json").attr("dumps");
  core::SceneInput input;
  input.allow_scene_plugins = allow_scene_plugins;
  if (py::isinstance<py::dict>(scene)) {
    input.file = fs::current_path() / "<dict>";
    // NaN and infinities refused here: JSON has no text for them that YAML reads as a number.
    input.text = py::str(dumps(scene, py::arg("indent") = 1, py::arg("allow_nan") = false))
                     .cast<std::string>();
  } else if (py::isinstance<py::str>(scene) || py::isinstance<py::bytes>(scene) ||
             py::hasattr(scene, "__fspath__")) {
    input.file = scene.cast<fs::path>();
  } else {
    throw py::type_error("scene: a path (str or os.PathLike) or a dict, not " +
                         py::str(py::type::of(scene).attr("__name__")).cast<std::string>());
  }
  for (const auto& [key, value] : set) {
    std::string assignment = py::str(key);
    assignment += "=";
    assignment += py::str(dumps(value, py::arg("allow_nan") = false)).cast<std::string>();
    input.overrides.push_back(core::parse_scene_override(assignment));
  }
  return input;
}

// Column `k` of a result table as a numpy array.
py::array_t<double> column(const std::vector<std::vector<double>>& rows, std::size_t k) {
  py::array_t<double> out(static_cast<py::ssize_t>(rows.size()));
  auto view = out.mutable_unchecked<1>();
  for (std::size_t i = 0; i < rows.size(); ++i) view(static_cast<py::ssize_t>(i)) = rows[i].at(k);
  return out;
}

// The index of the response node `name` of a run (output.response).
std::size_t response_node(const core::RunResult& r, const std::string& name) {
  std::string known;
  for (std::size_t j = 0; j < r.table.nodes.size(); ++j) {
    if (r.table.nodes[j].name == name) return j;
    known += (known.empty() ? "" : ", ") + r.table.nodes[j].name;
  }
  throw py::key_error("'" + name +
                      "' is not a response node of the scene (output.response: " + known + ")");
}

// The complex harmonic amplitudes of a response node at every point: [point, component,
// harmonic], m (node_harmonics).
py::array_t<std::complex<double>> response_harmonics(const core::RunResult& r,
                                                     const std::string& name) {
  const std::size_t j = response_node(r, name);
  const auto& table = r.table.harmonics;
  const auto harmonics = static_cast<py::ssize_t>(r.prepared.model->layout().harmonics().size());
  py::array_t<std::complex<double>> out({static_cast<py::ssize_t>(table.size()),
                                         static_cast<py::ssize_t>(r.table.nodes[j].kept.size()),
                                         harmonics});
  auto view = out.mutable_unchecked<3>();
  for (std::size_t i = 0; i < table.size(); ++i) {
    const Eigen::MatrixXcd& x = table[i][j];
    for (Eigen::Index d = 0; d < x.rows(); ++d)
      for (Eigen::Index k = 0; k < x.cols(); ++k) view(static_cast<py::ssize_t>(i), d, k) = x(d, k);
  }
  return out;
}

void check_point(const core::RunResult& r, std::size_t point) {
  if (point >= r.summary.points.size())
    throw py::index_error("point " + std::to_string(point) + " of a curve of " +
                          std::to_string(r.summary.points.size()) + " points");
}

// Complex amplitudes x [component, harmonic] (the layout's harmonics) at a point as a time
// signal over one period: (t, x(t) [component, sample]).
std::pair<py::array_t<double>, py::array_t<double>> rebuild_signal(const core::RunResult& r,
                                                                   const Eigen::MatrixXcd& x,
                                                                   std::size_t point, int samples) {
  if (samples < 1) throw py::value_error("samples: at least 1");
  const auto& model = *r.prepared.model;
  const double omega = r.summary.points[point].y(model.equation_count());
  const auto& harmonics = model.layout().harmonics();
  py::array_t<double> t(samples);
  py::array_t<double> signal(
      {static_cast<py::ssize_t>(x.rows()), static_cast<py::ssize_t>(samples)});
  auto tv = t.mutable_unchecked<1>();
  auto sv = signal.mutable_unchecked<2>();
  for (int s = 0; s < samples; ++s) {
    const double phase = 2 * std::numbers::pi * s / samples;  // omega t
    tv(s) = phase / omega;
    for (Eigen::Index d = 0; d < x.rows(); ++d) {
      double value = 0.0;
      for (Eigen::Index k = 0; k < x.cols(); ++k)
        value += (x(d, k) * std::polar(1.0, harmonics[static_cast<std::size_t>(k)] * phase)).real();
      sv(d, s) = value;
    }
  }
  return {t, signal};
}

// Raises ValueError when the run kept no contact harmonics (output.contact_forces off).
void require_contact_harmonics(const core::RunResult& r) {
  if (r.table.contacts.empty() && !r.summary.points.empty())
    throw py::value_error(
        "the run kept no contact harmonics: run it with set={'output.contact_forces': True}");
}

// The index of contact `name` among the model's contacts.
std::size_t contact_index(const core::RunResult& r, const std::string& name) {
  const auto& contacts = r.prepared.model->contacts();
  for (std::size_t c = 0; c < contacts.size(); ++c)
    if (contacts[c].name == name) return c;
  std::string known;
  for (std::size_t c = 0; c < std::min<std::size_t>(contacts.size(), 8); ++c)
    known += (known.empty() ? "" : ", ") + contacts[c].name;
  if (contacts.size() > 8) known += ", ... (" + std::to_string(contacts.size()) + " in all)";
  throw py::key_error("'" + name + "' is not a contact of the scene (contacts: " + known + ")");
}

const char* component_name(int component) {
  static constexpr std::array<const char*, 3> kNames = {"t1", "t2", "n"};
  return kNames.at(static_cast<std::size_t>(component));
}

// One member (displacement or force) of a contact's harmonics at every point: [point,
// component, harmonic].
py::array_t<std::complex<double>> contact_array(const core::RunResult& r, std::size_t c,
                                                Eigen::MatrixXcd core::ContactHarmonics::*member) {
  const auto points = static_cast<py::ssize_t>(r.table.contacts.size());
  const auto components =
      static_cast<py::ssize_t>(r.prepared.model->contacts()[c].tracer->components().size());
  const auto harmonics = static_cast<py::ssize_t>(r.prepared.model->layout().harmonics().size());
  py::array_t<std::complex<double>> out({points, components, harmonics});
  auto view = out.mutable_unchecked<3>();
  for (py::ssize_t i = 0; i < points; ++i) {
    const Eigen::MatrixXcd& x = r.table.contacts[static_cast<std::size_t>(i)][c].*member;
    for (py::ssize_t a = 0; a < components; ++a)
      for (py::ssize_t k = 0; k < harmonics; ++k) view(i, a, k) = x(a, k);
  }
  return out;
}

// A dense matrix as a 2-D numpy array (copied).
py::array_t<double> eigen_matrix(const Eigen::MatrixXd& m) {
  py::array_t<double> out({static_cast<py::ssize_t>(m.rows()), static_cast<py::ssize_t>(m.cols())});
  auto view = out.mutable_unchecked<2>();
  for (Eigen::Index i = 0; i < m.rows(); ++i)
    for (Eigen::Index j = 0; j < m.cols(); ++j) view(i, j) = m(i, j);
  return out;
}

std::size_t column_index(const core::RunResult& r, const std::string& name) {
  const auto& header = r.table.header;
  for (std::size_t k = 0; k < header.size(); ++k)
    if (header[k] == name) return k;
  std::string known;
  for (const auto& h : header) known += (known.empty() ? "" : ", ") + h;
  throw py::key_error("no column '" + name + "' (columns: " + known + ")");
}

py::dict peak_dict(const core::NodePeak& p) {
  py::dict d;
  d["node"] = p.node;
  d["amplitude_m"] = p.amplitude_m;
  d["omega_rad_s"] = p.omega_rad_s;
  d["frequency_hz"] = p.omega_rad_s / (2 * std::numbers::pi);
  d["refined"] = p.refined;
  return d;
}

// Writes `result` into `folder` as the program does (staged, committed whole) with the GIL
// released; Ctrl-C ends gnuplot, commits nothing and raises KeyboardInterrupt.
template <typename Result, typename Write>
void write_folder(const Result& result, const fs::path& folder,
                  const std::vector<std::string>& managed, const Write& write) {
  const core::StopSource source;
  call_stoppable(source, [&] {
    core::StagedOutput out(folder, managed, core::StagingControl(source.token()));
    write(result, out);
    out.commit();
  });
}

// A vector as a numpy array (copied).
template <typename T>
py::array_t<T> array(const std::vector<T>& values) {
  return py::array_t<T>(static_cast<py::ssize_t>(values.size()), values.data());
}

// Rows of equal length as a 2-D numpy array [rows, columns] (copied).
py::array_t<double> matrix(const std::vector<std::vector<double>>& rows) {
  const auto n = static_cast<py::ssize_t>(rows.size());
  const auto m = static_cast<py::ssize_t>(rows.empty() ? 0 : rows.front().size());
  py::array_t<double> out({n, m});
  auto view = out.mutable_unchecked<2>();
  for (py::ssize_t i = 0; i < n; ++i)
    for (py::ssize_t k = 0; k < m; ++k)
      view(i, k) = rows[static_cast<std::size_t>(i)].at(static_cast<std::size_t>(k));
  return out;
}

// A run's outcome in a study or convergence row.
py::dict run_outcome_dict(const core::RunOutcome& o) {
  py::dict d;
  d["exit_code"] = o.exit_code;
  d["termination"] = o.termination;
  d["message"] = o.message;
  d["points"] = o.points;
  d["unknowns"] = o.unknowns;
  py::list peaks;
  for (const auto& p : o.peaks) peaks.append(peak_dict(p));
  d["peaks"] = peaks;
  py::list amplification;
  for (const auto& a : o.amplification) {
    py::dict entry;
    entry["node"] = a.node;
    entry["factor"] = a.factor;
    entry["worst_blade"] = a.worst_blade;
    amplification.append(entry);
  }
  d["amplification"] = amplification;
  d["wall_seconds"] = o.wall_seconds;
  return d;
}

// A verb whose members are written as they end: the folder is staged when `compute` asks for
// it (`stage(managed)` returns the staged output), and the result written into it and
// committed when its status is 0 or 3, all on the call's thread with the GIL released.
template <typename Compute, typename Write>
auto compute_into_folder(const core::StopSource& source, const fs::path& folder,
                         const std::vector<std::string>& managed, const Compute& compute,
                         const Write& write) {
  return call_stoppable(source, [&] {
    std::optional<core::StagedOutput> out;
    const auto stage = [&]() -> core::StagedOutput& {
      if (!out) out.emplace(folder, managed, core::StagingControl(source.token()));
      return *out;
    };
    auto result = compute(stage);
    const int status = result.outcome.status;
    if (status == core::kExitOk || status == core::kExitIncomplete) {
      write(result, stage());
      stage().commit();
    }
    return result;
  });
}

// The outcome's attributes every result has.
template <typename Class>
void outcome_attributes(Class& c) {
  using Result = typename Class::type;
  c.def_property_readonly(
       "status", [](const Result& r) { return r.outcome.status; },
       "The exit code the program gives: 0 completed, 3 ended before its aim (results kept).")
      .def_property_readonly(
          "termination", [](const Result& r) { return r.outcome.termination; },
          "How the verb ended, a word: 'completed', 'not_periodic', 'max_points', ...")
      .def_property_readonly(
          "message", [](const Result& r) { return r.outcome.message; },
          "Why it ended early; empty when completed.")
      .def_property_readonly(
          "warnings", [](const Result& r) { return r.outcome.warnings; },
          "The warnings logged while it ran, in order.");
}

// An exception class `name` of the module, derived from `bases`.
py::handle make_error(py::module_& m, const char* name, py::handle bases, const char* doc) {
  PyObject* cls =
      PyErr_NewExceptionWithDoc((std::string("frichb.") + name).c_str(), doc, bases.ptr(), nullptr);
  if (cls == nullptr) throw py::error_already_set();
  m.add_object(name, py::handle(cls));
  return cls;
}

void translate_errors(std::exception_ptr failure) {
  const ErrorClasses& classes = error_classes();
  try {
    std::rethrow_exception(std::move(failure));
  } catch (const core::SceneError& e) {
    py::object error = py::reinterpret_borrow<py::object>(classes.scene)(e.what());
    error.attr("file") = e.file();
    error.attr("line") = e.line();
    error.attr("column") = e.column();
    error.attr("key") = e.key_path();
    error.attr("reason") = e.message();
    PyErr_SetObject(classes.scene.ptr(), error.ptr());
  } catch (const core::PluginError& e) {
    PyErr_SetString(classes.plugin.ptr(), e.what());
  } catch (const core::OutputError& e) {
    PyErr_SetString(classes.output.ptr(), e.what());
  } catch (const core::Interrupted& e) {
    PyErr_SetString(PyExc_KeyboardInterrupt, e.what());
  }
}

// The log: spdlog's default logger on stderr, and set_log_level.
void bind_logging(py::module_& m) {
  // Logging: warnings and errors on stderr, as the program's; set_log_level("info") shows
  // progress.
  if (!spdlog::get("frichb")) {
    auto logger = spdlog::stderr_color_mt("frichb");
    logger->set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");
    spdlog::set_default_logger(logger);
    spdlog::set_level(spdlog::level::warn);
  }
  m.def(
      "set_log_level",
      [](const std::string& level) {
        const auto parsed = spdlog::level::from_str(level);
        if (parsed == spdlog::level::off && level != "off")
          throw py::value_error(
              "log level: trace, debug, info, warning, error, critical or off, "
              "not '" +
              level + "'");
        spdlog::set_level(parsed);
      },
      py::arg("level"),
      "The level of the core's log on stderr: 'debug', 'info' (progress), 'warning' (the "
      "default), 'error' or 'off'.");
}

// The exception classes and the translation of the core's exceptions.
void bind_errors(py::module_& m) {
  ErrorClasses& classes = error_classes();
  classes.base = make_error(m, "Error", PyExc_RuntimeError, "Any error FricHB raises.");
  const py::tuple scene_bases = py::make_tuple(classes.base, py::handle(PyExc_ValueError));
  classes.scene = make_error(
      m, "SceneError", scene_bases,
      "A scene the core refuses: .file, .line, .column (1-based; 0 when unknown), .key (the "
      "key path, e.g. contacts[0].params.mu) and .reason.");
  classes.plugin = make_error(m, "PluginError", classes.base,
                              "A plugin that cannot be found, loaded or created.");
  classes.output =
      make_error(m, "OutputError", classes.base, "An output folder that cannot be written.");
  py::register_exception_translator(translate_errors);
}

// The Python class of RunResult, bound in parts by the functions below.
using RunResultClass = py::class_<core::RunResult, std::shared_ptr<core::RunResult>>;

// RunResult's curve: response.csv's table and columns, the response harmonics, time signals.
void bind_run_result_curve(RunResultClass& result_class) {
  result_class
      .def_property_readonly(
          "columns", [](const core::RunResult& r) { return r.table.header; },
          "The names of response.csv's columns, in order.")
      .def_property_readonly(
          "table",
          [](const core::RunResult& r) {
            const auto rows = static_cast<py::ssize_t>(r.table.rows.size());
            const auto cols = static_cast<py::ssize_t>(r.table.header.size());
            py::array_t<double> out({rows, cols});
            auto view = out.mutable_unchecked<2>();
            for (py::ssize_t i = 0; i < rows; ++i)
              for (py::ssize_t k = 0; k < cols; ++k)
                view(i, k) = r.table.rows[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)];
            return out;
          },
          "response.csv's numbers, one row per point of the curve: an array [points, columns].")
      .def(
          "column",
          [](const core::RunResult& r, const std::string& name) {
            return column(r.table.rows, column_index(r, name));
          },
          py::arg("name"), "One column of response.csv by name, e.g. 'blade_amplitude_m'.")
      .def_property_readonly(
          "frequency_hz",
          [](const core::RunResult& r) {
            return column(r.table.rows, column_index(r, "frequency_hz"));
          },
          "The excitation frequency of each point, Hz.")
      .def_property_readonly(
          "omega_rad_s",
          [](const core::RunResult& r) {
            return column(r.table.rows, column_index(r, "omega_rad_s"));
          },
          "The excitation frequency of each point, rad/s.")
      .def(
          "amplitude",
          [](const core::RunResult& r, const std::string& node) {
            return column(r.table.rows, column_index(r, node + "_amplitude_m"));
          },
          py::arg("node"),
          "The amplitude of a response node at each point, m (maximum over the period of the "
          "displacement norm).")
      .def_property_readonly(
          "harmonics",
          [](const core::RunResult& r) {
            return r.prepared.model ? r.prepared.model->layout().harmonics() : std::vector<int>();
          },
          "The kept harmonics n, in the order of the last axis of response_harmonics.")
      .def("response_harmonics", &response_harmonics, py::arg("node"),
           "The complex harmonic amplitudes X of a response node's DOFs at every point: an array "
           "[point, component, harmonic], m, component in the order of the node's DOFs in "
           "structure.dofs, harmonic in the order of `harmonics`. Component d moves as "
           "x(t) = sum over k of Re(X[point, d, k] exp(i n_k omega t)) (response_harmonics.csv "
           "holds Re X as cos_m and -Im X as sin_m).")
      .def_property_readonly(
          "response_dofs",
          [](const core::RunResult& r) {
            std::vector<std::pair<std::string, int>> dofs;
            for (const auto& node : r.table.nodes)
              for (std::size_t d = 0; d < node.kept.size(); ++d)
                dofs.emplace_back(node.name, static_cast<int>(d));
            return dofs;
          },
          "(node, component) of every response DOF, nodes in the order of output.response: the "
          "axis of all_response_harmonics.")
      .def(
          "all_response_harmonics",
          [](const core::RunResult& r) {
            std::size_t dofs = 0;
            for (const auto& node : r.table.nodes) dofs += node.kept.size();
            const auto points = static_cast<py::ssize_t>(r.table.harmonics.size());
            const auto harmonics =
                static_cast<py::ssize_t>(r.prepared.model->layout().harmonics().size());
            py::array_t<std::complex<double>> out(
                {points, static_cast<py::ssize_t>(dofs), harmonics});
            auto view = out.mutable_unchecked<3>();
            for (py::ssize_t i = 0; i < points; ++i) {
              py::ssize_t row = 0;
              for (const Eigen::MatrixXcd& x : r.table.harmonics[static_cast<std::size_t>(i)])
                for (Eigen::Index d = 0; d < x.rows(); ++d, ++row)
                  for (py::ssize_t k = 0; k < harmonics; ++k) view(i, row, k) = x(d, k);
            }
            return out;
          },
          "Every response DOF's complex harmonic amplitudes at every point in one array [point, "
          "DOF, harmonic], m, the DOFs as response_dofs lists them (each node's as "
          "response_harmonics(node) gives them).")
      .def(
          "time_signal",
          [](const core::RunResult& r, const std::string& name, std::size_t point, int samples) {
            check_point(r, point);
            const Eigen::MatrixXcd& x = r.table.harmonics.at(point).at(response_node(r, name));
            return rebuild_signal(r, x, point, samples);
          },
          py::arg("node"), py::arg("point"), py::arg("samples") = 256,
          "The time signal of a response node over one period at a point of the curve, rebuilt "
          "from its harmonics: (t, x) with t the sample times, s (t = 0 where the excitation's "
          "phase is 0; samples equally spaced over the period), and x an array [component, "
          "sample], m.");
}

// RunResult's contact methods (output.contact_forces).
void bind_run_result_contacts(RunResultClass& result_class) {
  result_class
      .def_property_readonly(
          "contacts",
          [](const core::RunResult& r) {
            std::vector<std::string> names;
            if (r.prepared.model)
              for (const auto& c : r.prepared.model->contacts()) names.push_back(c.name);
            return names;
          },
          "The contacts' names (a patch's pairs each by its own name), in the order of "
          "contact_harmonics.csv.")
      .def(
          "contact_components",
          [](const core::RunResult& r, const std::string& name) {
            std::vector<std::string> names;
            for (const int a :
                 r.prepared.model->contacts()[contact_index(r, name)].tracer->components())
              names.emplace_back(component_name(a));
            return names;
          },
          py::arg("contact"),
          "The local components a contact's law uses, in the order of the component axis of "
          "contact_harmonics: a subset of 't1', 't2', 'n'.")
      .def(
          "contact_harmonics",
          [](const core::RunResult& r, const std::string& name) {
            const std::size_t c = contact_index(r, name);
            require_contact_harmonics(r);
            return py::make_tuple(contact_array(r, c, &core::ContactHarmonics::displacement),
                                  contact_array(r, c, &core::ContactHarmonics::force));
          },
          py::arg("contact"),
          "A contact's harmonics at every point (the run needs output.contact_forces): "
          "(U, F), arrays [point, component, harmonic] of complex amplitudes, U the relative "
          "displacement (m) and F the law's force on it (N, the preload in the static term when "
          "harmonic 0 is kept), components as contact_components, harmonics as `harmonics`; "
          "u(t) = sum over k of Re(U[point, a, k] exp(i n_k omega t)). contact_harmonics.csv "
          "holds the same numbers (cos = Re, sin = -Im).")
      .def(
          "contact_periodic",
          [](const core::RunResult& r, const std::string& name) {
            const std::size_t c = contact_index(r, name);
            require_contact_harmonics(r);
            std::vector<bool> periodic;
            for (const auto& at_point : r.table.contacts) periodic.push_back(at_point[c].periodic);
            return periodic;
          },
          py::arg("contact"),
          "Whether the contact's trace settled to a periodic state at each point (False: its "
          "force is that of the last pass; contact_harmonics.csv's `periodic` column).")
      .def(
          "contact_signal",
          [](const core::RunResult& r, const std::string& name, std::size_t point, int samples) {
            check_point(r, point);
            const std::size_t c = contact_index(r, name);
            require_contact_harmonics(r);
            const core::ContactHarmonics& h = r.table.contacts.at(point).at(c);
            auto [t, u] = rebuild_signal(r, h.displacement, point, samples);
            auto [t2, f] = rebuild_signal(r, h.force, point, samples);
            return py::make_tuple(t, u, f);
          },
          py::arg("contact"), py::arg("point"), py::arg("samples") = 256,
          "A contact's relative displacement and force over one period at a point, rebuilt from "
          "their kept harmonics: (t, u, f), t in s, u [component, sample] in m, f [component, "
          "sample] in N. The force's series stops at the kept harmonics; contact_trace gives the "
          "force the law computes.")
      .def(
          "contact_trace",
          [](const core::RunResult& r, const std::string& name, std::size_t point) {
            check_point(r, point);
            const std::size_t c = contact_index(r, name);
            // The model's tracer of the contact is shared by every call on this result: the
            // trace runs holding the GIL, so that two Python threads never trace at once.
            core::ContactTrace trace;
            std::string error;
            if (!r.prepared.model->trace_contact(c, r.summary.points[point].y, trace, &error))
              throw std::runtime_error("contact '" + name + "' failed at point " +
                                       std::to_string(point) + ": " + error);
            py::dict d;
            d["displacement"] = eigen_matrix(trace.displacement.transpose());
            d["force"] = eigen_matrix(trace.force.transpose());
            d["periodic"] = trace.periodic;
            d["energy_per_cycle_j"] = trace.energy_per_cycle;
            return d;
          },
          py::arg("contact"), py::arg("point"),
          "The contact traced again over one period at a point, on the run's own samples "
          "(harmonic_balance.samples_per_period times trace_oversampling, the first at phase "
          "0): a dict with "
          "'displacement' [component, sample] (m) and 'force' [component, sample] (N, the law's "
          "force, preload included), 'periodic' and 'energy_per_cycle_j'.");
}

// RunResult: the outcome, peaks, summary and write, then the curve and the contacts.
void bind_run_result(py::module_& m) {
  RunResultClass result_class(
      m, "RunResult",
      "The response curve of a scene (frichb.run): the rows of response.csv as numpy arrays, "
      "the peaks, how the curve ended. write(folder) writes what `frichb run` writes.");
  result_class
      .def_property_readonly(
          "status", [](const core::RunResult& r) { return r.outcome.status; },
          "The exit code `frichb run` gives: 0 completed, 3 ended early (results all the same).")
      .def_property_readonly(
          "termination", [](const core::RunResult& r) { return r.outcome.termination; },
          "How the verb ended: 'completed', or the continuation's reason ('max_points', ...).")
      .def_property_readonly(
          "message", [](const core::RunResult& r) { return r.outcome.message; },
          "Why it ended early, with a suggestion; empty when completed.")
      .def_property_readonly(
          "warnings", [](const core::RunResult& r) { return r.outcome.warnings; },
          "The warnings logged while it ran, in order.");
  bind_run_result_curve(result_class);
  bind_run_result_contacts(result_class);
  result_class
      .def_property_readonly(
          "peaks",
          [](const core::RunResult& r) {
            py::list peaks;
            for (const auto& p : r.peaks) peaks.append(peak_dict(p));
            return peaks;
          },
          "One dict per response node with a peak: node, amplitude_m, omega_rad_s, "
          "frequency_hz, refined.")
      .def_property_readonly(
          "mistuning",
          [](const core::RunResult& r) -> py::object {
            if (!r.mistuning) return py::none();
            return py::module_::import("json").attr("loads")(
                core::mistuning_json(*r.mistuning).dump());
          },
          "A mistuned disk's comparison with the tuned disk (the scene's `mistuning`), as "
          "summary.json's `mistuning` section: deviations, and per response node every blade's "
          "peak (blade_peak_m, blade_peak_hz, blade_peak_solved), the tuned peak, the "
          "amplification and the worst blade; None for any other scene.")
      .def_property_readonly(
          "points", [](const core::RunResult& r) { return r.summary.points.size(); },
          "The points of the response curve.")
      .def_property_readonly(
          "unknowns",
          [](const core::RunResult& r) {
            return r.prepared.model ? r.prepared.model->equation_count() : 0;
          },
          "The harmonic-balance unknowns.")
      .def_property_readonly(
          "wall_seconds", [](const core::RunResult& r) { return r.wall_seconds; },
          "The run's wall time, s.")
      .def_property_readonly(
          "summary",
          [](const core::RunResult& r) {
            const core::RunRecord record{*r.scene,  *r.prepared.model, r.prepared.setup,
                                         r.summary, r.table,           r.loops};
            nlohmann::json loops = nlohmann::json::array();
            for (const core::FrictionLoop& loop : r.loops)
              loops.push_back(core::friction_loop_entry(record, loop));
            const nlohmann::json timing = {{"setup_s", r.setup_seconds},
                                           {"continuation_s", r.continuation_seconds},
                                           {"post_and_output_s", r.post_seconds},
                                           {"total_s", r.wall_seconds}};
            nlohmann::json doc = core::run_summary(record, loops, timing, r.options.study_context);
            if (r.mistuning) doc["mistuning"] = core::mistuning_json(*r.mistuning);
            return py::module_::import("json").attr("loads")(doc.dump());
          },
          "summary.json's content as a dict (termination, peaks, turning points, harmonic "
          "truncation, the profile, the validated scene, ...), without what only write() "
          "produces: the friction loops are listed without their file names, the contact "
          "states not at all, and the times leave out the writing.")
      .def(
          "write",
          [](const core::RunResult& r, const fs::path& folder) {
            write_folder(r, folder, core::run_outputs(), core::write_run);
          },
          py::arg("folder"),
          "Writes what `frichb run` writes into `folder` (replaced as a whole: response.csv, "
          "summary.json, the loops, the plots).")
      .def("__repr__", [](const core::RunResult& r) {
        return "<frichb.RunResult " + r.outcome.termination + ", " +
               std::to_string(r.summary.points.size()) + " points>";
      });
}

// frichb.run.
void bind_run(py::module_& m) {
  m.def(
      "run",
      [](const py::object& scene, const py::dict& set, bool allow_scene_plugins,
         int contact_threads, const py::object& plots, const py::object& progress) {
        const core::StopSource source;
        core::RunOptions options;
        options.stop = source.token();
        options.contact_threads = contact_threads;
        if (!plots.is_none()) options.plots = plots.cast<bool>() ? 1 : 0;
        // The callback runs on the computing thread, holding the GIL while it runs; what it
        // raises stops the run and is raised here.
        std::exception_ptr raised;
        if (!progress.is_none())
          options.on_point = [&](std::size_t point, double frequency_hz) {
            py::gil_scoped_acquire held;
            if (raised) return;
            try {
              progress(point, frequency_hz);
            } catch (const py::error_already_set&) {
              raised = std::current_exception();
              source.request_stop(SIGINT);
            }
          };
        const core::SceneInput input = scene_input(scene, set, allow_scene_plugins);
        auto result = std::make_shared<core::RunResult>(
            call_stoppable(source, [&] { return core::run_scene(input, options); }));
        if (raised) std::rethrow_exception(raised);
        return result;
      },
      py::arg("scene"), py::arg("set") = py::dict(), py::arg("allow_scene_plugins") = false,
      py::arg("contact_threads") = 0, py::arg("plots") = py::none(),
      py::arg("progress") = py::none(),
      "Traces the response curve of a scene, as `frichb run SCENE --set KEY=VALUE ...` does.\n\n"
      "scene: the scene file, or the scene as a dict (its relative paths from the current\n"
      "folder). set: {key path: value} overrides, e.g.\n"
      "{'contacts.damper.params.mu': 0.3}. allow_scene_plugins: load plugins from the\n"
      "scene's plugin_paths. contact_threads: threads tracing the contacts (0: one per core).\n"
      "plots: make the PNGs when written (None: the scene's output.plots).\n"
      "progress: called as progress(point, frequency_hz) after each point of the curve (on\n"
      "another thread; what it raises stops the run and is raised).\n"
      "Returns a RunResult (a curve that ends early is a result: its status is 3). Raises\n"
      "SceneError or PluginError for input the core refuses, KeyboardInterrupt on Ctrl-C.");
}

// frichb.validate and ValidationResult.
void bind_validate(py::module_& m) {
  py::class_<core::ValidationResult>(m, "ValidationResult",
                                     "What frichb.validate found: the scene as run would load it.")
      .def_readonly("structure", &core::ValidationResult::structure)
      .def_readonly("structure_version", &core::ValidationResult::structure_version)
      .def_readonly("contacts", &core::ValidationResult::contacts)
      .def_readonly("plugin_files", &core::ValidationResult::plugin_files)
      .def_readonly("study_runs", &core::ValidationResult::study_runs)
      .def_property_readonly("warnings",
                             [](const core::ValidationResult& r) { return r.outcome.warnings; })
      .def("__repr__", [](const core::ValidationResult& r) {
        return "<frichb.ValidationResult " + r.scene_file.string() + ": " + r.structure + ", " +
               std::to_string(r.contacts.size()) + " contact(s)>";
      });

  m.def(
      "validate",
      [](const py::object& scene, const py::dict& set, bool allow_scene_plugins) {
        const core::StopSource source;
        const core::SceneInput input = scene_input(scene, set, allow_scene_plugins);
        return call_stoppable(source, [&] { return core::validate_scene({input}); });
      },
      py::arg("scene"), py::arg("set") = py::dict(), py::arg("allow_scene_plugins") = false,
      "Checks a scene as `frichb validate` does (every check run makes before its first Newton\n"
      "iteration, every run of its study: section). Returns a ValidationResult; raises\n"
      "SceneError or PluginError.");
}

// frichb.timesim and TimesimResult.
void bind_timesim(py::module_& m) {
  py::class_<core::TimesimResult> timesim_result(
      m, "TimesimResult",
      "The time-integration reference of a scene at one frequency (frichb.timesim): the last "
      "period at the response nodes.");
  outcome_attributes(timesim_result);
  timesim_result
      .def_property_readonly(
          "frequency_hz", [](const core::TimesimResult& r) { return r.options.frequency_hz; },
          "The excitation frequency, Hz.")
      .def_readonly("periodic", &core::TimesimResult::periodic,
                    "The response repeated (relative 1e-8, three periods in a row).")
      .def_readonly("periods", &core::TimesimResult::periods, "Periods integrated.")
      .def_readonly("harmonics", &core::TimesimResult::harmonics,
                    "The scene's kept harmonics, the order of harmonic_amplitudes_m.")
      .def_property_readonly(
          "time_s", [](const core::TimesimResult& r) { return array(r.time_s); },
          "Sample times of the last period, s, from the period's start.")
      .def_property_readonly(
          "nodes",
          [](const core::TimesimResult& r) {
            py::dict nodes;
            for (const auto& n : r.nodes) {
              py::dict node;
              node["amplitude_m"] = n.amplitude_m;
              node["half_peak_to_peak_m"] = n.half_peak_to_peak_m;
              node["harmonic_amplitudes_m"] = array(n.harmonic_amplitudes_m);
              node["samples_m"] = matrix(n.samples_m);
              nodes[py::str(n.node)] = node;
            }
            return nodes;
          },
          "Per response node: amplitude_m (maximum of the displacement norm), "
          "half_peak_to_peak_m, harmonic_amplitudes_m (per harmonic), samples_m [dof, sample].")
      .def_readonly("wall_seconds", &core::TimesimResult::wall_seconds, "Wall time, s.")
      .def(
          "write",
          [](const core::TimesimResult& r, const fs::path& folder) {
            write_folder(r, folder, core::timesim_outputs(), core::write_timesim);
          },
          py::arg("folder"), "Writes what `frichb timesim -o folder` writes.");

  m.def(
      "timesim",
      [](const py::object& scene, double frequency_hz, const py::dict& set,
         bool allow_scene_plugins, int steps_per_period, int max_periods) {
        const core::StopSource source;
        core::TimesimRequest request;
        request.scene = scene_input(scene, set, allow_scene_plugins);
        request.integration.frequency_hz = frequency_hz;
        request.integration.steps_per_period = steps_per_period;
        request.integration.max_periods = max_periods;
        request.integration.stop = source.token();
        return call_stoppable(source, [&] { return core::integrate_scene(request); });
      },
      py::arg("scene"), py::arg("frequency_hz"), py::arg("set") = py::dict(),
      py::arg("allow_scene_plugins") = false, py::arg("steps_per_period") = 4000,
      py::arg("max_periods") = 3000,
      "Integrates a scene without cyclic symmetry in time at one excitation frequency until\n"
      "its response repeats, as `frichb timesim SCENE --at-hz F` does. Returns a\n"
      "TimesimResult; raises SceneError (a cyclic scene too), ValueError for options out of\n"
      "range, KeyboardInterrupt on Ctrl-C.");
}

// frichb.modes and ModesResult.
void bind_modes(py::module_& m) {
  py::class_<core::ModesResult> modes_result(
      m, "ModesResult",
      "The natural frequencies of the structure without contacts per harmonic index "
      "(frichb.modes), with the engine-order excitation lines.");
  outcome_attributes(modes_result);
  modes_result.def_readonly("sectors", &core::ModesResult::sectors, "1: not cyclic.")
      .def_readonly("engine_order", &core::ModesResult::engine_order, "0: none.")
      .def_property_readonly(
          "modes",
          [](const core::ModesResult& r) {
            std::vector<int> h, nd, wave, family;
            std::vector<double> f;
            for (const auto& mode : r.modes) {
              h.push_back(mode.harmonic_index);
              nd.push_back(mode.nodal_diameter);
              wave.push_back(mode.wave);
              family.push_back(mode.family);
              f.push_back(mode.frequency_hz);
            }
            py::dict columns;
            columns["harmonic_index"] = array(h);
            columns["nodal_diameter"] = array(nd);
            columns["wave"] = array(wave);
            columns["family"] = array(family);
            columns["frequency_hz"] = array(f);
            return columns;
          },
          "modes.csv's columns as arrays: harmonic_index, nodal_diameter, wave (+1 forward, -1 "
          "backward, 0), family, frequency_hz.")
      .def_property_readonly(
          "frequencies_hz",
          [](const core::ModesResult& r) {
            std::vector<std::vector<double>> rows;
            for (const auto& by_nd : r.frequencies_hz)
              rows.emplace_back(by_nd.begin(),
                                by_nd.begin() + static_cast<std::ptrdiff_t>(r.families));
            return matrix(rows);
          },
          "families.csv: [nodal diameter, family], Hz (the families every nodal diameter has).")
      .def_property_readonly(
          "excitation",
          [](const core::ModesResult& r) {
            py::list lines;
            for (const auto& e : r.excitation) {
              py::dict line;
              line["rpm"] = e.rpm;
              line["harmonic"] = e.harmonic;
              line["harmonic_index"] = e.harmonic_index;
              line["nodal_diameter"] = e.nodal_diameter;
              line["frequency_hz"] = e.frequency_hz;
              lines.append(line);
            }
            return lines;
          },
          "excitation.csv: a dict per speed and harmonic n of the engine order.")
      .def(
          "write",
          [](const core::ModesResult& r, const fs::path& folder) {
            write_folder(r, folder, core::modes_outputs(), core::write_modes);
          },
          py::arg("folder"), "Writes what `frichb modes -o folder` writes.");

  m.def(
      "modes",
      [](const py::object& scene, const py::object& rpm, const py::dict& set,
         bool allow_scene_plugins) {
        const core::StopSource source;
        core::ModesOptions options{scene_input(scene, set, allow_scene_plugins), 0.0, 0.0};
        if (!rpm.is_none()) {
          if (py::isinstance<py::tuple>(rpm) || py::isinstance<py::list>(rpm)) {
            const auto range = rpm.cast<std::vector<double>>();
            if (range.size() != 2) throw py::value_error("rpm: one speed, or (low, high)");
            options.rpm_low = range[0];
            options.rpm_high = range[1];
          } else {
            options.rpm_low = options.rpm_high = rpm.cast<double>();
          }
          if (!(options.rpm_low > 0 && options.rpm_high >= options.rpm_low))
            throw py::value_error("rpm: a positive speed, or (low, high) with 0 < low <= high");
        }
        return call_stoppable(source, [&] { return core::compute_modes(options); });
      },
      py::arg("scene"), py::arg("rpm") = py::none(), py::arg("set") = py::dict(),
      py::arg("allow_scene_plugins") = false,
      "The natural frequencies of the structure without contacts per harmonic index, as\n"
      "`frichb modes SCENE --rpm A:B` does; rpm: one speed or (low, high), for the\n"
      "engine-order excitation lines. Returns a ModesResult.");
}

// PeaksResult.
void bind_peaks_result(py::module_& m) {
  py::class_<core::PeaksResult> peaks_result(
      m, "PeaksResult",
      "The resonance peak of one node traced against a contact or excitation parameter "
      "(frichb.peaks).");
  outcome_attributes(peaks_result);
  auto field = [](double core::TrackedPeak::*member) {
    return [member](const core::PeaksResult& r) {
      std::vector<double> values;
      for (const auto& p : r.peaks) values.push_back(p.*member);
      return array(values);
    };
  };
  peaks_result.def_readonly("parameter", &core::PeaksResult::parameter, "The scene path varied.")
      .def_readonly("node", &core::PeaksResult::node)
      .def_readonly("logarithmic", &core::PeaksResult::logarithmic,
                    "Whether the continuation stepped in the parameter's logarithm.")
      .def_readonly("start_frequency_hz", &core::PeaksResult::start_frequency_hz)
      .def_readonly("mu_over_force", &core::PeaksResult::mu_over_force,
                    "With normalise: mu / f, 1/N (mu N0 / f is the normal load times it); else 0.")
      .def_readonly("per_force", &core::PeaksResult::per_force,
                    "With normalise: 1 / f, 1/N; else 0.")
      .def_readonly("start_amplitude_m", &core::PeaksResult::start_amplitude_m)
      .def_property_readonly("parameter_values", field(&core::TrackedPeak::parameter),
                             "peaks.csv's parameter column, along the peak curve.")
      .def_property_readonly("frequency_hz", field(&core::TrackedPeak::frequency_hz),
                             "The peak frequency at each point, Hz.")
      .def_property_readonly("amplitude_m", field(&core::TrackedPeak::amplitude_m),
                             "The peak amplitude at each point, m (the run's peak measure).")
      .def_property_readonly("newton_iterations",
                             [](const core::PeaksResult& r) {
                               std::vector<int> values;
                               for (const auto& p : r.peaks) values.push_back(p.newton_iterations);
                               return array(values);
                             })
      .def_property_readonly(
          "branch",
          [](const core::PeaksResult& r) {
            std::vector<int> values;
            for (const auto& p : r.peaks) values.push_back(p.branch);
            return array(values);
          },
          "peaks.csv's branch column: 0, then one more after each jump.")
      .def_property_readonly(
          "jumps",
          [](const core::PeaksResult& r) {
            py::list jumps;
            for (const auto& j : r.jumps) {
              py::dict d;
              d["from_parameter"] = j.from_parameter;
              d["from_frequency_hz"] = j.from_frequency_hz;
              d["from_amplitude_m"] = j.from_amplitude_m;
              d["parameter"] = j.parameter;
              d["to_frequency_hz"] = j.to_frequency_hz;
              d["to_amplitude_m"] = j.to_amplitude_m;
              d["reason"] = j.reason;
              jumps.append(d);
            }
            return jumps;
          },
          "summary.json's jumps: where a branch ended and the tracking went on from a run's "
          "peak.")
      .def_property_readonly(
          "exchanges",
          [](const core::PeaksResult& r) {
            py::list exchanges;
            for (const auto& e : r.exchanges) {
              py::dict d;
              d["other_peak"] = e.overtaken ? "overtakes" : "falls_below";
              d["bracket"] = py::make_tuple(e.bracket_from, e.bracket_to);
              d["located"] = e.located;
              d["other_frequency_hz"] = e.other_frequency_hz;
              if (e.located) {
                d["parameter"] = e.parameter;
                d["amplitude_m"] = e.amplitude_m;
                d["frequency_hz"] = e.frequency_hz;
              } else {
                d["why_not_located"] = e.message;
              }
              exchanges.append(d);
            }
            return exchanges;
          },
          "summary.json's exchanges: where another peak of the response overtakes the traced "
          "one (or falls below it again), solved where it could be.")
      .def_property_readonly(
          "stable",
          [](const core::PeaksResult& r) -> py::object {
            if (r.peaks.empty() || !r.peaks.front().stable) return py::none();
            std::vector<int> values;
            for (const auto& p : r.peaks) values.push_back(p.stable ? (*p.stable ? 1 : 0) : -1);
            return array(values);
          },
          "peaks.csv's stable column (1 stable, 0 unstable, -1 not computed), with the scene's "
          "output.stability; else None.")
      .def_property_readonly("largest_multiplier", field(&core::TrackedPeak::largest_multiplier),
                             "The largest Floquet multiplier's modulus at each point (NaN "
                             "without output.stability).")
      .def_property_readonly("d_frequency_hz_d_parameter",
                             field(&core::TrackedPeak::d_frequency_hz_d_parameter),
                             "Hz per unit of the parameter; NaN where the curve turns in it.")
      .def_property_readonly("d_amplitude_m_d_parameter",
                             field(&core::TrackedPeak::d_amplitude_m_d_parameter),
                             "m per unit of the parameter; NaN where the curve turns in it.")
      .def_property_readonly(
          "optimum",
          [](const core::PeaksResult& r) -> py::object {
            if (!r.optimum) return py::none();
            const auto& best = r.peaks[*r.optimum];
            const auto& solved = r.solved_optimum;
            py::dict d;
            d["solved"] = solved.solved;
            d["parameter"] = solved.solved ? solved.parameter : best.parameter;
            d["frequency_hz"] = solved.solved ? solved.frequency_hz : best.frequency_hz;
            d["amplitude_m"] = solved.solved ? solved.amplitude_m : best.amplitude_m;
            d["lowest_point"] = *r.optimum;
            d["at_range_end"] = r.optimum_at_end;
            return d;
          },
          "summary.json's optimum: solved between the traced points, or the lowest traced peak "
          "(None when nothing was traced).")
      .def_readonly("termination", &core::PeaksResult::termination,
                    "How the peak curve's continuation ended ('reached_end', ...).")
      .def(
          "write",
          [](const core::PeaksResult& r, const fs::path& folder) {
            write_folder(r, folder, core::peaks_outputs(), core::write_peaks);
          },
          py::arg("folder"), "Writes what `frichb peaks -o folder` writes.");
}

// frichb.peaks.
void bind_peaks(py::module_& m) {
  bind_peaks_result(m);
  m.def(
      "peaks",
      [](const py::object& scene, const std::string& parameter, double start, double end,
         const std::string& node, const py::object& near, int check_runs, const std::string& axis,
         bool normalise, const py::dict& set, bool allow_scene_plugins) {
        const core::StopSource source;
        core::PeaksOptions options;
        if (!near.is_none()) options.near_hz = near.cast<double>();
        if (check_runs < 0) throw py::value_error("check_runs: 0 or more");
        options.check_runs = check_runs;
        options.scene = scene_input(scene, set, allow_scene_plugins);
        options.parameter = parameter;
        options.from = start;
        options.to = end;
        options.node = node;
        options.normalise = normalise;
        options.stop = source.token();
        if (axis == "log")
          options.logarithmic = true;
        else if (axis == "linear")
          options.logarithmic = false;
        else if (axis != "auto")
          throw py::value_error("axis: 'auto', 'linear' or 'log'");
        return call_stoppable(source, [&] { return core::track_peaks(options); });
      },
      py::arg("scene"), py::arg("parameter"), py::arg("start"), py::arg("end"),
      py::arg("node") = "", py::arg("near") = py::none(),
      py::arg("check_runs") = core::kDefaultCheckRuns, py::arg("axis") = "auto",
      py::arg("normalise") = false, py::arg("set") = py::dict(),
      py::arg("allow_scene_plugins") = false,
      "The resonance peak of `node` (default: the first of output.response; the start run's\n"
      "highest peak, or with `near` (Hz) the one nearest it) traced against the scene path\n"
      "`parameter` from `start` to `end`, as `frichb peaks SCENE --vary\n"
      "PARAMETER=START:END` does. Returns a PeaksResult.");
}

// NmaResult.syntheses: a dict per level, as summary.json's synthesis.levels.
py::list synthesis_levels(const core::NmaResult& r) {
  py::list out;
  for (const core::SynthesisedResponse& s : r.syntheses) {
    py::dict level;
    level["excitation_scale"] = s.scale;
    const core::SynthesisedPeak& p = s.peak;
    level["peak"] =
        py::dict(py::arg("found") = p.found, py::arg("frequency_hz") = p.frequency_hz,
                 py::arg("amplitude") = p.amplitude, py::arg("damping_ratio") = p.damping_ratio,
                 py::arg("node_amplitude_mode_m") = p.node_amplitude_m,
                 py::arg("node_amplitude_m") = p.node_amplitude_with_residual_m,
                 py::arg("residual_share") = p.residual_share, py::arg("message") = p.message);
    std::vector<double> frequency, amplitude, node_mode, node;
    for (const core::SynthesisedPoint& c : s.curve) {
      frequency.push_back(c.frequency_hz);
      amplitude.push_back(c.amplitude);
      node_mode.push_back(c.node_amplitude_m);
      node.push_back(c.node_amplitude_with_residual_m);
    }
    level["curve"] = py::dict(py::arg("frequency_hz") = array(frequency),
                              py::arg("amplitude") = array(amplitude),
                              py::arg("node_amplitude_mode_m") = array(node_mode),
                              py::arg("node_amplitude_m") = array(node));
    level["check"] = py::dict(
        py::arg("converged") = s.check.converged,
        py::arg("node_amplitude_m") = s.check.node_amplitude_m,
        py::arg("error_mode") = s.check.error, py::arg("error") = s.check.error_with_residual,
        py::arg("newton_iterations") = s.check.newton_iterations,
        py::arg("seconds") = s.check.seconds, py::arg("message") = s.check.message);
    if (s.full)
      level["full_run"] = py::dict(
          py::arg("found") = s.full->found, py::arg("frequency_hz") = s.full->frequency_hz,
          py::arg("node_amplitude_m") = s.full->node_amplitude_m,
          py::arg("amplitude_error_mode") = s.full->amplitude_error,
          py::arg("amplitude_error") = s.full->amplitude_error_with_residual,
          py::arg("frequency_error") = s.full->frequency_error, py::arg("points") = s.full->points,
          py::arg("seconds") = s.full->seconds, py::arg("termination") = s.full->termination,
          py::arg("message") = s.full->message);
    else
      level["full_run"] = py::none();
    out.append(level);
  }
  return out;
}

// frichb.nma and NmaResult.
void bind_nma(py::module_& m) {
  py::class_<core::NmaResult> nma_result(
      m, "NmaResult",
      "A nonlinear mode: frequency and damping ratio against amplitude (frichb.nma).");
  outcome_attributes(nma_result);
  auto field = [](double core::NmaPoint::*member) {
    return [member](const core::NmaResult& r) {
      std::vector<double> values;
      for (const auto& p : r.points) values.push_back(p.*member);
      return array(values);
    };
  };
  nma_result.def_readonly("mode", &core::NmaResult::mode, "The mode, counted from 1.")
      .def_readonly("harmonic_index", &core::NmaResult::harmonic_index,
                    "The structure's harmonic index of harmonic 1 (0 without cyclic symmetry).")
      .def_readonly("free_frequency_hz", &core::NmaResult::free_frequency_hz,
                    "The mode's natural frequency without contacts, Hz.")
      .def_readonly("start_frequency_hz", &core::NmaResult::start_frequency_hz,
                    "The mode's undamped frequency with each contact's tangent at rest, Hz.")
      .def_property_readonly(
          "amplitude_range", [](const core::NmaResult& r) { return py::make_tuple(r.from, r.to); },
          "The amplitudes traced, (from, to), m sqrt(kg).")
      .def_property_readonly("amplitude", field(&core::NmaPoint::amplitude),
                             "nma.csv's amplitude: the mode's fundamental modal coordinate, "
                             "m sqrt(kg).")
      .def_property_readonly("frequency_hz", field(&core::NmaPoint::frequency_hz),
                             "The mode's frequency at each amplitude, Hz.")
      .def_property_readonly("damping_ratio", field(&core::NmaPoint::damping_ratio),
                             "The mode's damping ratio at each amplitude (structure and "
                             "contacts).")
      .def_property_readonly("xi", field(&core::NmaPoint::xi),
                             "The damping shift at each amplitude, rad/s (2 zeta w).")
      .def_property_readonly("contact_energy_j", field(&core::NmaPoint::contact_energy_j),
                             "The energy the contacts dissipate per cycle, J.")
      .def_property_readonly("stuck_share", field(&core::NmaPoint::stuck))
      .def_property_readonly("slipping_share", field(&core::NmaPoint::slipping))
      .def_property_readonly("open_share", field(&core::NmaPoint::open))
      .def_property_readonly("contact_motion_m", field(&core::NmaPoint::contact_motion_m),
                             "The largest contact component's harmonic-1 amplitude, m.")
      .def_property_readonly("higher_harmonics_share", field(&core::NmaPoint::higher_harmonics),
                             "The contacts' motion in harmonics 2 and up against 1 and up.")
      .def_property_readonly(
          "most_damped",
          [](const core::NmaResult& r) -> py::object {
            const auto best = core::most_damped_point(r);
            if (!best) return py::none();
            return py::int_(*best);
          },
          "The index of the point with the largest damping ratio (None without points).")
      .def_readonly("termination_of_continuation", &core::NmaResult::termination,
                    "How the continuation ended ('reached_end', ...).")
      .def_property_readonly(
          "syntheses", synthesis_levels,
          "The forced responses synthesised at `synthesise`, one dict per level as\n"
          "summary.json's synthesis.levels, with the curve as arrays (synthesis.csv's columns).")
      .def_readonly("backbone_seconds", &core::NmaResult::wall_seconds,
                    "The backbone's wall time, s.")
      .def_readonly("synthesis_seconds", &core::NmaResult::synthesis_seconds,
                    "The syntheses' wall time, s.")
      .def_readonly("check_seconds", &core::NmaResult::check_seconds,
                    "The harmonic-balance checks' wall time, s.")
      .def_readonly("full_run_seconds", &core::NmaResult::full_run_seconds,
                    "The full runs' wall time (against_run), s.")
      .def(
          "write",
          [](const core::NmaResult& r, const fs::path& folder) {
            write_folder(r, folder, core::nma_outputs(), core::write_nma);
          },
          py::arg("folder"), "Writes what `frichb nma -o folder` writes.");
  m.def(
      "nma",
      [](const py::object& scene, int mode, const py::object& amplitude, const py::dict& set,
         bool allow_scene_plugins, const std::vector<double>& synthesise, bool against_run) {
        const core::StopSource source;
        core::NmaOptions options;
        for (const double level : synthesise)
          if (!(level > 0 && std::isfinite(level)))
            throw py::value_error("synthesise: excitation levels > 0, finite");
        if (against_run && synthesise.empty())
          throw py::value_error("against_run compares syntheses: give synthesise levels");
        options.synthesise = synthesise;
        options.against_run = against_run;
        if (mode < 1) throw py::value_error("mode: counted from 1");
        options.mode = mode;
        if (!amplitude.is_none()) {
          const auto range = amplitude.cast<std::pair<double, double>>();
          if (!(range.first > 0 && range.second > range.first && std::isfinite(range.second)))
            throw py::value_error("amplitude: (from, to) with 0 < from < to");
          options.from = range.first;
          options.to = range.second;
        }
        options.scene = scene_input(scene, set, allow_scene_plugins);
        options.stop = source.token();
        return call_stoppable(source, [&] { return core::compute_nonlinear_modes(options); });
      },
      py::arg("scene"), py::arg("mode") = 1, py::arg("amplitude") = py::none(),
      py::arg("set") = py::dict(), py::arg("allow_scene_plugins") = false,
      py::arg("synthesise") = std::vector<double>{}, py::arg("against_run") = false,
      "Mode `mode` (1: the lowest) of the scene's structure with its contacts as a nonlinear\n"
      "mode, continued in its modal amplitude, as `frichb nma SCENE --mode K --amplitude\n"
      "FROM:TO` does. amplitude: (from, to) in m sqrt(kg), or None for the contact motion from\n"
      "1 nm to 1 mm. synthesise: excitation levels (multiples of the scene's harmonic-1\n"
      "excitation) whose forced responses are synthesised from the backbone and checked, as\n"
      "--synthesise; against_run: also trace each level's full response, as --against-run.\n"
      "Returns an NmaResult.");
}

// frichb.loop and LoopResult.
void bind_loop(py::module_& m) {
  py::class_<core::LoopResult> loop_result(
      m, "LoopResult",
      "One contact law traced over a prescribed periodic relative motion (frichb.loop).");
  outcome_attributes(loop_result);
  loop_result.def_readonly("name", &core::LoopResult::name)
      .def_property_readonly(
          "law", [](const core::LoopResult& r) { return r.law ? r.law->name() : std::string(); },
          "The contact law's name.")
      .def_property_readonly(
          "law_params",
          [](const core::LoopResult& r) {
            return py::module_::import("json").attr("loads")(r.law_params.dump());
          },
          "The law's validated parameters, defaults filled in.")
      .def_property_readonly(
          "components",
          [](const core::LoopResult& r) {
            std::vector<std::string> names;
            for (const int c : r.components) names.emplace_back(core::kContactAxisNames[c]);
            return names;
          },
          "The local axes of the columns of displacement_m and force_N ('t1', 't2', 'n').")
      .def_readonly("displacement_m", &core::LoopResult::displacement_m,
                    "The prescribed relative motion, [sample, component], m.")
      .def_readonly("force_N", &core::LoopResult::force_N,
                    "The law's force, [sample, component], N.")
      .def_property_readonly(
          "stick_slip_status", [](const core::LoopResult& r) { return array(r.status); },
          "Per sample: 0 stuck, 1 slipping, 2 open.")
      .def_readonly("energy_per_cycle_J", &core::LoopResult::energy_per_cycle_J,
                    "The energy dissipated per cycle, J (the closed integral of f . du).")
      .def_readonly("passes", &core::LoopResult::passes)
      .def_readonly("periodic", &core::LoopResult::periodic)
      .def_readonly("fraction_slipping", &core::LoopResult::fraction_slipping)
      .def_readonly("fraction_open", &core::LoopResult::fraction_open)
      .def(
          "write",
          [](const core::LoopResult& r, const fs::path& folder) {
            write_folder(r, folder, core::loop_outputs(), core::write_loop);
          },
          py::arg("folder"), "Writes what `frichb loop -o folder` writes.");

  m.def(
      "loop",
      [](const fs::path& input, bool allow_scene_plugins) {
        const core::StopSource source;
        const core::LoopRequest request{input, allow_scene_plugins};
        return call_stoppable(source, [&] { return core::trace_loop(request); });
      },
      py::arg("input"), py::arg("allow_scene_plugins") = false,
      "Traces one contact law under the periodic relative motion a loop input prescribes, as\n"
      "`frichb loop INPUT` does. Returns a LoopResult; raises SceneError or PluginError.");
}

// frichb.study and StudyResult.
void bind_study(py::module_& m) {
  py::class_<core::StudyResult> study_result(
      m, "StudyResult",
      "A study: the scene run once for every value of the keys its study: section sweeps "
      "(frichb.study), one row per run.");
  outcome_attributes(study_result);
  study_result
      .def_property_readonly(
          "sweeps",
          [](const core::StudyResult& r) {
            std::vector<std::string> paths;
            for (const auto& s : r.study.sweeps) paths.push_back(s.path);
            return paths;
          },
          "The swept key paths, in the order of each row's values.")
      .def_property_readonly(
          "node", [](const core::StudyResult& r) { return r.study.node; },
          "The node whose peaks the study compares (study.node).")
      .def_property_readonly(
          "runs",
          [](const core::StudyResult& r) {
            py::list rows;
            for (const auto& run : r.runs) {
              py::dict row = run_outcome_dict(run.outcome);
              row["id"] = run.id;
              row["values"] = run.values;
              rows.append(row);
            }
            return rows;
          },
          "A dict per run: id (its folder under runs/), values (one per sweep), exit_code, "
          "termination, message, points, unknowns, peaks, wall_seconds.")
      .def_property_readonly(
          "optimum",
          [](const core::StudyResult& r) -> py::object {
            if (r.optimum >= r.runs.size()) return py::none();
            return py::int_(r.optimum);
          },
          "The index of the run with the lowest peak of `node` among those that reached the end "
          "of their sweep (None when none did).")
      .def_readonly("optimum_amplitude_m", &core::StudyResult::optimum_amplitude_m)
      .def_readonly("failed_runs", &core::StudyResult::failed_runs)
      .def_property_readonly(
          "amplification",
          [](const core::StudyResult& r) {
            py::dict out;
            for (const auto& a : core::amplification_statistics(r)) {
              py::dict d;
              d["runs"] = a.count;
              d["mean"] = a.mean;
              d["p95"] = a.p95;
              d["p99"] = a.p99;
              d["largest"] = a.largest;
              d["worst_run"] = a.worst_run < r.runs.size() ? py::object(py::int_(a.worst_run))
                                                           : py::object(py::none());
              out[py::str(a.node)] = d;
            }
            return out;
          },
          "A mistuned disk's study: per sector response node the amplification factors' "
          "statistics over the runs that completed (runs, mean, p95, p99, largest, and the "
          "index of the run that gave it); empty for any other study.")
      .def_readonly("threads", &core::StudyResult::threads)
      .def_readonly("wall_seconds", &core::StudyResult::wall_seconds);

  m.def(
      "study",
      [](const py::object& scene, const fs::path& folder, const py::dict& set,
         bool allow_scene_plugins, int threads) {
        const core::StopSource source;
        core::StudyRequest request;
        request.scene = scene_input(scene, set, allow_scene_plugins);
        request.threads = threads;
        request.stop = source.token();
        request.write_run = core::write_run_folder;
        return compute_into_folder(
            source, folder, core::study_outputs(),
            [&](const auto& stage) {
              request.stage_runs = [&] { return stage().path("runs"); };
              core::StudyCommunicator serial;
              return core::run_study(request, serial);
            },
            core::write_study);
      },
      py::arg("scene"), py::arg("folder"), py::arg("set") = py::dict(),
      py::arg("allow_scene_plugins") = false, py::arg("threads") = -1,
      "Runs the scene's study: section, as `frichb study SCENE -o folder` does, into `folder`\n"
      "(study.csv, study.json, the plots, runs/NNNN). threads: runs at once (-1: the scene's\n"
      "study.parallel; 0: one per core). Returns a StudyResult; a study that does not validate\n"
      "has status 2 and no rows (the log says why); KeyboardInterrupt on Ctrl-C.");
}

// frichb.convergence and ConvergenceResult.
void bind_convergence(py::module_& m) {
  py::class_<core::ConvergenceResult> convergence_result(
      m, "ConvergenceResult",
      "The peak of a scene against harmonics, samples and oversampling (frichb.convergence), "
      "coarse to fine, the finest the reference.");
  outcome_attributes(convergence_result);
  convergence_result.def_readonly("node", &core::ConvergenceResult::node)
      .def_property_readonly(
          "rows",
          [](const core::ConvergenceResult& r) {
            py::list rows;
            for (const auto& row : r.rows) {
              py::dict d = run_outcome_dict(row.outcome);
              d["setting"] = row.setting.id;
              d["max_harmonic"] = row.setting.max_harmonic;
              d["samples"] = row.setting.samples;
              d["oversampling"] = row.setting.oversampling;
              d["amplitude_m"] = row.amplitude_m;
              d["frequency_hz"] = row.frequency_hz;
              d["amplitude_error"] = row.amplitude_error;
              d["frequency_error"] = row.frequency_error;
              d["amplitude_error_vs_timesim"] = row.amplitude_error_vs_timesim;
              rows.append(d);
            }
            return rows;
          },
          "A dict per setting (convergence.csv's rows): setting, max_harmonic, samples, "
          "oversampling, amplitude_m, frequency_hz, the relative errors against the reference "
          "and the time integration (NaN where there is none), and the run's outcome.")
      .def_property_readonly(
          "timesim",
          [](const core::ConvergenceResult& r) -> py::object {
            if (!r.timesim.run) return py::none();
            py::dict d;
            d["frequency_hz"] = r.timesim.frequency_hz;
            d["amplitude_m"] = r.timesim.amplitude_m;
            d["periodic"] = r.timesim.periodic;
            d["periods"] = r.timesim.periods;
            d["wall_seconds"] = r.timesim.wall_seconds;
            return d;
          },
          "The time-integration reference at the reference's peak frequency, or None.");

  m.def(
      "convergence",
      [](const py::object& scene, const fs::path& folder, const std::vector<int>& harmonics,
         const std::vector<int>& samples, const std::vector<int>& oversampling,
         bool time_integration, const py::dict& set, bool allow_scene_plugins) {
        const core::StopSource source;
        core::ConvergenceRequest request;
        request.scene = scene_input(scene, set, allow_scene_plugins);
        request.harmonics = harmonics;
        request.samples = samples;
        request.oversampling = oversampling;
        request.time_integration = time_integration;
        request.stop = source.token();
        request.write_run = core::write_run_folder;
        return compute_into_folder(
            source, folder, core::convergence_outputs(),
            [&](const auto& stage) {
              request.stage_runs = [&] { return stage().path("runs"); };
              return core::study_convergence(request);
            },
            core::write_convergence);
      },
      py::arg("scene"), py::arg("folder"),
      py::arg("harmonics") = std::vector<int>{1, 3, 5, 7, 10, 15},
      py::arg("samples") = std::vector<int>{64, 128, 256, 512, 1024, 2048},
      py::arg("oversampling") = std::vector<int>{1, 4}, py::arg("time_integration") = true,
      py::arg("set") = py::dict(), py::arg("allow_scene_plugins") = false,
      "Runs the scene at every setting of harmonics, samples and oversampling, as `frichb\n"
      "convergence SCENE -o folder` does, into `folder`. Returns a ConvergenceResult; raises\n"
      "SceneError for a scene or settings it refuses; KeyboardInterrupt on Ctrl-C.");
}

}  // namespace

PYBIND11_MODULE(frichb, m) {
  m.doc() =
      "FricHB: steady-state vibration of structures with dry-friction contacts (harmonic "
      "balance). The verbs of the frichb program as functions returning result objects.";
  m.attr("__version__") = core::version();

  bind_logging(m);
  bind_errors(m);
  bind_run_result(m);
  bind_run(m);
  bind_validate(m);
  bind_timesim(m);
  bind_modes(m);
  bind_peaks(m);
  bind_nma(m);
  bind_loop(m);
  bind_study(m);
  bind_convergence(m);
}
