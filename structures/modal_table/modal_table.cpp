// modal_table: modal data computed elsewhere (ANSYS, Abaqus, CalculiX, ...) and read from a
// YAML table. For each harmonic index h the table lists modes, each with its natural
// frequency and its mode shape at the DOFs the user exported ({dof, re, im}); DOFs not listed
// are zero. The shapes are taken as they are: mass-normalised for the sector mass matrix
// (phi^H M0 phi = 1) and in FricHB's convention K_h = K0 + e^{-i h phi} K1 + e^{i h phi} K1^T,
// K1 coupling a sector to the next. K_{nb-h} = conj(K_h), so a harmonic index the table does
// not give is derived from its mirror nb - h by complex conjugation of the shapes (same
// frequencies): a commercial cyclic analysis exports only one of the two. Modal damping ratios
// put 2 z_r w_r on the diagonal of the modal damping matrix; no residual flexibility is added.
// The whole table is read and checked when the provider is created.
#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <numeric>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "frichb/plugin/modal_basis.hpp"
#include "frichb/plugin/sdk.hpp"

namespace {

using frichb::sdk::Param;
using cd = std::complex<double>;

std::vector<frichb_param_spec> modal_table_schema() {
  return {
      Param::path("file",
                  "path of the YAML modal table; a relative path is relative to the scene "
                  "file's folder"),
      Param::integer("sectors",
                     "number of sectors nb of the cyclic model (1: no cyclic symmetry); harmonic "
                     "indices run from 0 to nb - 1")
          .at_least(1)
          .at_most(1.0e6)
          .defaults_to(1),
      Param::integer("dof_count", "DOFs per sector of the FE model, as numbered in the table")
          .at_least(1),
      Param::real_list("modal_damping", "",
                       "modal damping ratio: one value for every mode, or one per mode of each "
                       "harmonic index in table order (default: undamped)")
          .at_least(0)
          .optional(),
      Param::text("frequency_unit", "unit of the table's natural frequencies")
          .choices("Hz|rad/s")
          .defaults_to_text("Hz"),
  };
}

// "0-3, 5, 7-8": harmonic indices, short enough for the host's message buffer.
std::string ranges(const std::vector<int>& sorted) {
  std::string out;
  for (std::size_t i = 0; i < sorted.size();) {
    std::size_t j = i;
    while (j + 1 < sorted.size() && sorted[j + 1] == sorted[j] + 1) ++j;
    if (!out.empty()) out += ", ";
    out += std::to_string(sorted[i]);
    if (j > i) out += (j == i + 1 ? ", " : "-") + std::to_string(sorted[j]);
    i = j + 1;
  }
  return out.empty() ? "none" : out;
}

class ModalTable final : public frichb::sdk::StructureProvider {
 public:
  explicit ModalTable(const frichb::sdk::Params& p)
      : file_(p.text("file")),
        sectors_(static_cast<int>(p.integer("sectors"))),
        dofs_(static_cast<std::size_t>(p.integer("dof_count"))),
        to_rad_per_s_(p.text("frequency_unit") == "Hz" ? 2.0 * std::numbers::pi : 1.0),
        ratios_(p.reals("modal_damping")),
        given_(static_cast<std::size_t>(sectors_), -1) {
    read(load());
    // h absent from the table: the conjugate of its mirror nb - h, when the table gives it.
    source_.assign(static_cast<std::size_t>(sectors_), -1);
    conjugate_.assign(static_cast<std::size_t>(sectors_), false);
    for (int h = 0; h < sectors_; ++h) {
      const auto k = static_cast<std::size_t>(h);
      const auto mirror = static_cast<std::size_t>((sectors_ - h) % sectors_);
      if (given_[k] >= 0) {
        source_[k] = given_[k];
      } else if (given_[mirror] >= 0) {
        source_[k] = given_[mirror];
        conjugate_[k] = true;
      }
    }
  }

  size_t dof_count() const override { return dofs_; }
  size_t sector_count() const override { return static_cast<size_t>(sectors_); }

  frichb_modal_basis modal_basis(int harmonic_index, const size_t* kept, size_t n_kept) override {
    if (harmonic_index < 0 || harmonic_index >= sectors_)
      throw std::invalid_argument(
          "harmonic index " + std::to_string(harmonic_index) + " is outside [0, " +
          std::to_string(sectors_) +
          "): the modal table provider has sectors = " + std::to_string(sectors_));
    const auto k = static_cast<std::size_t>(harmonic_index);
    if (source_[k] < 0) throw std::invalid_argument(absent_message(harmonic_index));
    const Basis& basis = bases_[static_cast<std::size_t>(source_[k])];
    const Eigen::Index n_modes = basis.frequencies.size();
    Eigen::MatrixXcd rows = Eigen::MatrixXcd::Zero(static_cast<Eigen::Index>(n_kept), n_modes);
    for (size_t i = 0; i < n_kept; ++i) {
      if (kept[i] >= dofs_)
        throw std::out_of_range("DOF " + std::to_string(kept[i]) +
                                " does not exist (the model has " + std::to_string(dofs_) +
                                " DOFs, parameter 'dof_count')");
      const auto it = std::lower_bound(basis.dofs.begin(), basis.dofs.end(), kept[i]);
      if (it == basis.dofs.end() || *it != kept[i]) continue;  // not exported: zero
      const auto row = basis.rows.row(it - basis.dofs.begin());
      if (conjugate_[k])  // the mirror harmonic index nb - h
        rows.row(static_cast<Eigen::Index>(i)) = row.conjugate();
      else
        rows.row(static_cast<Eigen::Index>(i)) = row;
    }
    basis_.set_frequencies(basis.frequencies);
    basis_.add_damping_ratios(basis.damping_ratios);
    // The table's modes only: no residual flexibility (no static correction).
    if (basis.real)
      basis_.set_mode_rows(rows.real());
    else
      basis_.set_mode_rows(rows);
    return basis_.basis();
  }

 private:
  struct Basis {
    Eigen::VectorXd frequencies;         // rad/s, ascending
    std::vector<double> damping_ratios;  // per mode in that order, or empty (undamped)
    std::vector<size_t> dofs;            // ascending: the DOFs some mode of h lists
    Eigen::MatrixXcd rows;               // dofs.size() x n_modes
    bool real = true;                    // no imaginary part anywhere
  };

  struct Mode {
    double frequency = 0.0;  // rad/s
    std::vector<std::pair<size_t, cd>> shape;
  };

  [[noreturn]] void fail(const YAML::Node& node, const std::string& what) const {
    std::string where = file_;
    if (node.IsDefined() && node.Mark().line >= 0)
      where +=
          ":" + std::to_string(node.Mark().line + 1) + ":" + std::to_string(node.Mark().column + 1);
    throw std::invalid_argument("modal table " + where + ": " + what);
  }

  YAML::Node load() const {
    namespace fs = std::filesystem;
    const fs::path path(file_);
    std::error_code ec;
    if (!fs::is_regular_file(path, ec) || !std::ifstream(path)) {
      std::string where;
      if (path.is_relative()) {
        const fs::path cwd = fs::current_path(ec);
        where = " (a relative path is relative to the current working directory" +
                (ec ? std::string() : ", here '" + cwd.string() + "'") + ")";
      }
      throw std::invalid_argument("cannot open the modal table '" + file_ + "'" + where);
    }
    try {
      return YAML::LoadFile(file_);
    } catch (const YAML::Exception& e) {
      throw std::invalid_argument("modal table " + file_ + ":" + std::to_string(e.mark.line + 1) +
                                  ":" + std::to_string(e.mark.column + 1) +
                                  ": malformed YAML: " + e.msg);
    }
  }

  void check_keys(const YAML::Node& map, const std::string& what,
                  const std::set<std::string>& allowed) const {
    if (!map.IsMap()) fail(map, what + " must be a map");
    for (const auto& kv : map) {
      const auto key = kv.first.Scalar();
      if (!allowed.count(key)) {
        std::string message = "unknown key '";
        message.append(key).append("' in ").append(what).append(" (expected");
        for (const auto& a : allowed)
          message.append(a == *allowed.begin() ? " '" : ", '").append(a) += "'";
        fail(kv.first, message + ")");
      }
    }
  }

  // The value of `key` in `map`: a finite number, or `fallback` when absent and optional.
  double real_at(const YAML::Node& map, const char* key, const std::string& what,
                 const double* fallback = nullptr) const {
    const YAML::Node n = map[key];
    if (!n) {
      if (fallback) return *fallback;
      fail(map, what + ": '" + key + "' is missing");
    }
    double v = 0.0;
    if (!n.IsScalar() || !YAML::convert<double>::decode(n, v) || !std::isfinite(v))
      fail(n, what + ": '" + key + "' must be a finite number");
    return v;
  }

  long long integer_at(const YAML::Node& map, const char* key, const std::string& what) const {
    const YAML::Node n = map[key];
    if (!n) fail(map, what + ": '" + key + "' is missing");
    long long v = 0;
    if (!n.IsScalar() || !YAML::convert<long long>::decode(n, v))
      fail(n, what + ": '" + key + "' must be an integer");
    return v;
  }

  void read(const YAML::Node& root) {
    if (!root.IsMap()) fail(root, "expected a map with the key 'harmonic_indices'");
    check_keys(root, "the table", {"harmonic_indices"});
    const YAML::Node list = root["harmonic_indices"];
    if (!list || !list.IsSequence() || list.size() == 0)
      fail(list ? list : root, "'harmonic_indices' must be a non-empty list of {h, modes}");
    std::vector<int> lines(static_cast<std::size_t>(sectors_), 0);
    for (std::size_t e = 0; e < list.size(); ++e) {
      const YAML::Node entry = list[e];
      const std::string what = "harmonic_indices[" + std::to_string(e) + "]";
      check_keys(entry, what, {"h", "modes"});
      const long long h = integer_at(entry, "h", what);
      if (h < 0 || h >= sectors_)
        fail(entry["h"], what + ": h = " + std::to_string(h) + " is outside [0, " +
                             std::to_string(sectors_) +
                             ") (parameter 'sectors' = " + std::to_string(sectors_) + ")");
      const auto k = static_cast<std::size_t>(h);
      if (given_[k] >= 0)
        fail(entry["h"], what + ": h = " + std::to_string(h) + " is given twice (first at line " +
                             std::to_string(lines[k]) + ")");
      lines[k] = entry["h"].Mark().line + 1;
      given_[k] = static_cast<int>(bases_.size());
      bases_.push_back(read_modes(entry, what, static_cast<int>(h)));
    }
  }

  Basis read_modes(const YAML::Node& entry, const std::string& where, int h) const {
    const YAML::Node modes = entry["modes"];
    if (!modes || !modes.IsSequence() || modes.size() == 0)
      fail(modes ? modes : entry,
           where + ": 'modes' must be a non-empty list of {frequency, shape}");
    const std::size_t n = modes.size();
    if (ratios_.size() > 1 && ratios_.size() != n)
      fail(modes, "parameter 'modal_damping' has " + std::to_string(ratios_.size()) +
                      " values but h = " + std::to_string(h) + " has " + std::to_string(n) +
                      (n == 1 ? " mode" : " modes") + "; give 1 value or one per mode");
    std::vector<Mode> table(n);
    for (std::size_t r = 0; r < n; ++r) {
      const YAML::Node mode = modes[r];
      const std::string what = where + ".modes[" + std::to_string(r) + "]";
      check_keys(mode, what, {"frequency", "shape"});
      const double f = real_at(mode, "frequency", what);
      if (f < 0)
        fail(mode["frequency"], what + ": negative frequency " + mode["frequency"].Scalar());
      table[r].frequency = f * to_rad_per_s_;
      const YAML::Node shape = mode["shape"];
      if (!shape || !shape.IsSequence())
        fail(shape ? shape : mode, what + ": 'shape' must be a list of {dof, re, im}");
      std::set<size_t> seen;
      for (std::size_t q = 0; q < shape.size(); ++q) {
        const YAML::Node item = shape[q];
        const std::string at = what + ".shape[" + std::to_string(q) + "]";
        check_keys(item, at, {"dof", "re", "im"});
        const long long dof = integer_at(item, "dof", at);
        if (dof < 0 || static_cast<unsigned long long>(dof) >= dofs_)
          fail(item["dof"], at + ": dof " + std::to_string(dof) + " is outside [0, " +
                                std::to_string(dofs_) + ") (parameter 'dof_count')");
        if (!seen.insert(static_cast<size_t>(dof)).second)
          fail(item["dof"], at + ": dof " + std::to_string(dof) + " is listed twice in this mode");
        const double zero = 0.0;
        const double re = real_at(item, "re", at);
        const double im = real_at(item, "im", at, &zero);
        table[r].shape.emplace_back(static_cast<size_t>(dof), cd(re, im));
      }
    }

    // Ascending frequencies; a mode keeps its damping ratio (given in table order).
    std::vector<std::size_t> order(n);
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
      return table[a].frequency < table[b].frequency;
    });
    Basis basis;
    std::set<size_t> all;
    for (const Mode& m : table)
      for (const auto& entry_value : m.shape) all.insert(entry_value.first);
    basis.dofs.assign(all.begin(), all.end());
    const auto n_modes = static_cast<Eigen::Index>(n);
    basis.frequencies.resize(n_modes);
    if (!ratios_.empty()) basis.damping_ratios.resize(n);
    basis.rows = Eigen::MatrixXcd::Zero(static_cast<Eigen::Index>(basis.dofs.size()), n_modes);
    for (Eigen::Index c = 0; c < n_modes; ++c) {
      const std::size_t r = order[static_cast<std::size_t>(c)];
      const double w = table[r].frequency;
      basis.frequencies(c) = w;
      if (!ratios_.empty())
        basis.damping_ratios[static_cast<std::size_t>(c)] = ratios_[ratios_.size() == 1 ? 0 : r];
      for (const auto& [dof, value] : table[r].shape) {
        const auto it = std::lower_bound(basis.dofs.begin(), basis.dofs.end(), dof);
        basis.rows(it - basis.dofs.begin(), c) = value;
        if (value.imag() != 0.0) basis.real = false;
      }
    }
    return basis;
  }

  std::string absent_message(int h) const {
    std::vector<int> given, available;
    for (int k = 0; k < sectors_; ++k) {
      if (given_[static_cast<std::size_t>(k)] >= 0) given.push_back(k);
      if (source_[static_cast<std::size_t>(k)] >= 0) available.push_back(k);
    }
    const int mirror = (sectors_ - h) % sectors_;
    return "harmonic index " + std::to_string(h) + " is not in the modal table '" + file_ + "'" +
           (mirror == h ? std::string()
                        : ", nor its mirror " + std::to_string(mirror) + " = sectors - h") +
           ": the table gives h = " + ranges(given) +
           " (with their mirrors by complex conjugation: " + ranges(available) + ")";
  }

  std::string file_;
  int sectors_;
  size_t dofs_;
  double to_rad_per_s_;
  std::vector<double> ratios_;
  std::vector<int> given_;   // per h: index in bases_ of the table's entry, or -1
  std::vector<int> source_;  // per h: index in bases_ it is served from, or -1
  std::vector<bool> conjugate_;
  std::vector<Basis> bases_;
  frichb::sdk::ModalBasisBuilder basis_;
};

}  // namespace

FRICHB_STRUCTURE_PLUGIN(ModalTable, modal_table, "1.0.0",
                        "modal data read from a YAML table exported from an FE code's (cyclic) "
                        "modal analysis (file, sectors, dof_count, modal damping)",
                        modal_table_schema)
