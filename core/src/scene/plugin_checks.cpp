// The checks of a bound scene against its plugins' instances (plugin_checks.hpp).
#include "frichb/core/scene/plugin_checks.hpp"

#include <string>

namespace frichb::core {

namespace {

void check_dofs_exist(const Scene& scene, std::size_t n_dofs) {
  for (const auto& node : scene.structure.nodes)
    for (std::size_t d : node.dofs)
      if (d >= n_dofs && node.from_mesh)
        throw SceneError(node.defined_in, node.line, 0, "",
                         "FE node " + node.name + ": row " + std::to_string(d) +
                             " does not exist: provider '" + scene.structure.provider + "' has " +
                             std::to_string(n_dofs) + " DOFs (0.." + std::to_string(n_dofs - 1) +
                             ")");
      else if (d >= n_dofs)
        YamlContext{node.defined_in.empty() ? scene.file.string() : node.defined_in}.fail(
            node.definition, "structure.dofs." + node.name,
            "DOF " + std::to_string(d) + " does not exist: provider '" + scene.structure.provider +
                "' has " + std::to_string(n_dofs) + " DOFs (0.." + std::to_string(n_dofs - 1) +
                ")");
}

void check_sector_count(const Scene& scene, int sectors) {
  if (sectors == scene.cyclic.sectors) return;
  YAML::Node root = scene.root;  // non-const: a missing key then gives an undefined node
  const std::string why =
      scene.cyclic.enabled()
          ? "the scene has cyclic.sectors = " + std::to_string(scene.cyclic.sectors) +
                " but provider '" + scene.structure.provider + "' models " +
                (sectors > 1 ? std::to_string(sectors) + " sectors" : "no cyclic symmetry")
          : "provider '" + scene.structure.provider + "' models one sector of " +
                std::to_string(sectors) + ": add `cyclic: {sectors: " + std::to_string(sectors) +
                ", engine_order: m}`";
  YamlContext{scene.file.string()}.fail(scene.cyclic.enabled() ? root["cyclic"] : root["structure"],
                                        "cyclic", why);
}

// The contact's law accepts its params, and the contact gives every frame direction the law
// uses (its tangential dimensions, then the normal when it uses one).
void check_contact(const Scene& scene, std::size_t index) {
  const auto& spec = scene.contacts[index];
  YAML::Node root = scene.root;
  const YamlContext ctx{scene.file.string()};
  frichb_contact_law_traits traits{};
  try {
    const ContactLawInstance law(spec.plugin, spec.values);
    traits = law.traits();
  } catch (const PluginError& e) {
    fail_plugin_refusal(ctx, root["contacts"][spec.entry],
                        "contacts[" + std::to_string(spec.entry) + "].params",
                        spec.plugin->schema(), e.what());
  }
  static const char* const kNames[] = {"tangent1", "tangent2", "normal"};
  const std::vector<double>* directions[] = {&spec.tangent1, &spec.tangent2, &spec.normal};
  for (int a = 0; a < 3; ++a) {
    const bool used = a < 2 ? a < traits.tangential_dimensions : traits.uses_normal != 0;
    if (used && directions[a]->empty())
      ctx.fail(root["contacts"][spec.entry], "contacts[" + std::to_string(spec.entry) + "].frame",
               "law '" + spec.law + "' with these params uses the " + kNames[a] +
                   " direction: give frame." + kNames[a]);
  }
}

}  // namespace

void check_scene_against_plugins(const Scene& scene, const StructureModel& structure) {
  check_dofs_exist(scene, structure.dof_count());
  check_sector_count(scene, static_cast<int>(structure.sector_count()));
  for (std::size_t i = 0; i < scene.contacts.size(); ++i) check_contact(scene, i);
}

}  // namespace frichb::core
