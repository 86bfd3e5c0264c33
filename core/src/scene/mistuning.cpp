// The scene's `mistuning` section: the blades' stiffness factors (given, or a seeded random
// pattern) and the tuned sector's scene turned into the whole disk's (MistuningSpec).
#include "scene/mistuning.hpp"

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "frichb/plugin/sdk.hpp"

namespace frichb::core {

namespace {

using sdk::Param;

// A uniform double in [0, 1) from the generator's 64 bits (the same on every platform: the
// standard fixes mt19937_64's sequence, not its distributions').
double unit_uniform(std::mt19937_64& engine) {
  return static_cast<double>(engine() >> 11U) * 0x1.0p-53;
}

std::vector<double> random_deviations(int blades, double sigma, const std::string& distribution,
                                      long long seed) {
  std::mt19937_64 engine(static_cast<std::uint64_t>(seed));
  std::vector<double> out;
  out.reserve(static_cast<std::size_t>(blades));
  for (int j = 0; j < blades; ++j) {
    if (distribution == "uniform") {
      // Uniform on [-sqrt(3) sigma, sqrt(3) sigma]: standard deviation sigma.
      out.push_back(std::sqrt(3.0) * sigma * (2.0 * unit_uniform(engine) - 1.0));
    } else {
      // Box-Muller: a standard normal from two uniforms (1 - u keeps the logarithm finite).
      const double u1 = 1.0 - unit_uniform(engine), u2 = unit_uniform(engine);
      out.push_back(sigma * std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2));
    }
  }
  return out;
}

NodeSpec node_on_blade(const NodeSpec& node, int blade, int sectors) {
  NodeSpec out = node;
  out.name = MistuningSpec::on_blade(node.name, blade);
  for (auto& d : out.dofs)
    d = d * static_cast<std::size_t>(sectors) + static_cast<std::size_t>(blade);
  return out;
}

std::string side_on_blade(const std::string& side, int blade, int offset, int sectors) {
  if (side == "ground") return side;
  return MistuningSpec::on_blade(side, ((blade + offset) % sectors + sectors) % sectors);
}

// A contact not yet bound to its law (its values are set by bind_plugins).
ContactSpec unbound_copy(const ContactSpec& c) {
  ContactSpec copy;
  copy.name = c.name;
  copy.law = c.law;
  copy.side_a = c.side_a;
  copy.side_b = c.side_b;
  copy.sector_a = c.sector_a;
  copy.sector_b = c.sector_b;
  copy.tangent1 = c.tangent1;
  copy.tangent2 = c.tangent2;
  copy.normal = c.normal;
  copy.params = c.params;
  copy.plugin = c.plugin;
  copy.entry = c.entry;
  copy.param_scale = c.param_scale;
  copy.param_overrides = c.param_overrides;
  copy.patch = c.patch;
  return copy;
}

// The sector's nodes, contacts, excitation and response list made the whole disk's.
void expand_to_disk(Scene& scene, const MistuningSpec& m) {
  const int nb = m.sectors;
  std::vector<NodeSpec> nodes;
  std::vector<ContactSpec> contacts;
  std::vector<ExcitationSpec> excitation;
  std::vector<std::string> response;
  for (int j = 0; j < nb; ++j) {
    for (const auto& node : scene.structure.nodes) nodes.push_back(node_on_blade(node, j, nb));
    for (const auto& c : scene.contacts) {
      ContactSpec copy = unbound_copy(c);
      copy.name = MistuningSpec::on_blade(c.name, j);
      copy.side_a = side_on_blade(c.side_a, j, c.sector_a, nb);
      copy.side_b = side_on_blade(c.side_b, j, c.sector_b, nb);
      copy.sector_a = copy.sector_b = 0;
      contacts.push_back(std::move(copy));
    }
    // Blade j moves like blade 0 delayed by j m / nb of a period.
    for (const auto& e : scene.excitation) {
      ExcitationSpec copy = e;
      copy.node = MistuningSpec::on_blade(e.node, j);
      copy.phase = e.phase - 2.0 * std::numbers::pi * e.harmonic * m.engine_order * j / nb;
      excitation.push_back(std::move(copy));
    }
  }
  for (const auto& name : scene.output.response)
    for (int j = 0; j < nb; ++j) response.push_back(MistuningSpec::on_blade(name, j));
  scene.structure.nodes = std::move(nodes);
  scene.contacts = std::move(contacts);
  scene.excitation = std::move(excitation);
  scene.output.response = std::move(response);
  scene.cyclic = CyclicSpec{};
}

}  // namespace

std::string MistuningSpec::on_blade(const std::string& name, int blade) {
  return name + "@" + std::to_string(blade);
}

const std::vector<frichb_param_spec>& mistuning_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::real_list("deviations", "",
                       "blade j's stiffness factor is 1 + deviations[j], one per sector "
                       "(instead of a random pattern)")
          .greater_than(-1)
          .optional(),
      Param::real("sigma", "",
                  "a random pattern's standard deviation of the stiffness deviations (instead "
                  "of `deviations`)")
          .defaults_to(0)
          .at_least(0)
          .less_than(0.3),
      Param::text("distribution", "a random pattern's distribution: normal or uniform")
          .defaults_to_text("normal")
          .choices("normal|uniform"),
      Param::integer("seed", "a random pattern's seed (the pattern is the same on every machine)")
          .defaults_to(1)
          .at_least(0),
  };
  return s;
}

void read_mistuning(Scene& scene, YAML::Node root, const YamlContext& ctx) {
  YAML::Node node = root["mistuning"];
  if (!node) return;
  const auto values = validate_params(node, mistuning_schema(), "mistuning", ctx);
  const sdk::Params v(mistuning_schema().data(), mistuning_schema().size(), values.data());
  if (!scene.cyclic.enabled())
    ctx.fail(node, "mistuning",
             "a mistuned disk is built from a tuned sector: the scene needs a `cyclic: {sectors, "
             "engine_order}` section and a cyclic structure provider");
  MistuningSpec m;
  m.sectors = scene.cyclic.sectors;
  m.engine_order = scene.cyclic.engine_order;
  const bool given = node.IsMap() && node["deviations"];
  const bool random = node.IsMap() && node["sigma"];
  if (given == random)
    ctx.fail(node, "mistuning",
             "give either `deviations` (one per blade) or a random pattern's `sigma`, not " +
                 std::string(given ? "both" : "neither"));
  if (given) {
    m.deviations = v.reals("deviations");
    if (static_cast<int>(m.deviations.size()) != m.sectors)
      ctx.fail(node["deviations"], "mistuning.deviations",
               std::to_string(m.deviations.size()) + " deviations for a disk of " +
                   std::to_string(m.sectors) + " blades: give one per blade");
  } else {
    m.source = v.text("distribution");
    m.sigma = v.real("sigma");
    m.seed = v.integer("seed");
    m.deviations = random_deviations(m.sectors, m.sigma, m.source, m.seed);
    for (int j = 0; j < m.sectors; ++j)
      if (m.deviations[static_cast<std::size_t>(j)] <= -1.0)
        ctx.fail(node["sigma"], "mistuning.sigma",
                 "the pattern gives blade " + std::to_string(j) +
                     " a stiffness factor <= 0: lower sigma or change the seed");
  }
  for (const auto& n : scene.structure.nodes) m.sector_nodes.push_back(n.name);
  for (const auto& c : scene.contacts) m.sector_contacts.push_back(c.name);
  auto json = values.to_json(mistuning_schema());
  json["deviations"] = m.deviations;
  scene.core_values["mistuning"] = json;
  expand_to_disk(scene, m);
  scene.mistuning = std::move(m);
}

}  // namespace frichb::core
