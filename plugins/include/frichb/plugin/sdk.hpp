// FricHB plugin SDK: the header-only C++ layer over <frichb/plugin/abi.h>.
//
// A plugin author writes a class and one export macro; built-in plugins use the very same
// macro. Everything here compiles into the plugin: nothing of the host's C++ types crosses
// the boundary, only the plain structs of abi.h.
//
//   class MyLaw : public frichb::sdk::ContactLaw {
//    public:
//     explicit MyLaw(const frichb::sdk::Params& p) : kt_(p.real("kt")) {}
//     frichb_contact_law_traits traits() const override;
//     void step(...) const override;
//   };
//   std::vector<frichb_param_spec> my_schema() {
//     using frichb::sdk::Param;
//     return {Param::real("kt", "N/m", "tangential stiffness").greater_than(0)};
//   }
//   FRICHB_CONTACT_LAW_PLUGIN(MyLaw, my_law, "1.0.0", "one line summary", my_schema)
//
// Exceptions thrown by the class (constructor, step, modal_basis) are caught by the
// trampolines below and turned into FRICHB_ERROR with the exception's message.
#pragma once

#include <cmath>
#include <cstring>
#include <exception>
#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "frichb/plugin/abi.h"

namespace frichb::sdk {

inline constexpr double kUnbounded = std::numeric_limits<double>::infinity();

// Fluent builder for one schema entry; converts to the plain frichb_param_spec.
class Param {
 public:
  static Param real(const char* name, const char* unit, const char* doc) {
    return Param(name, FRICHB_PARAM_REAL, unit, doc);
  }
  static Param integer(const char* name, const char* doc) {
    return Param(name, FRICHB_PARAM_INTEGER, "", doc);
  }
  static Param boolean(const char* name, const char* doc) {
    return Param(name, FRICHB_PARAM_BOOLEAN, "", doc);
  }
  static Param text(const char* name, const char* doc) {
    return Param(name, FRICHB_PARAM_STRING, "", doc);
  }
  // A file path; relative paths reach the plugin resolved against the scene file's folder.
  static Param path(const char* name, const char* doc) {
    return Param(name, FRICHB_PARAM_PATH, "", doc);
  }
  static Param real_list(const char* name, const char* unit, const char* doc) {
    return Param(name, FRICHB_PARAM_REAL_LIST, unit, doc);
  }
  static Param text_list(const char* name, const char* doc) {
    return Param(name, FRICHB_PARAM_STRING_LIST, "", doc);
  }
  // `fields` must have static storage duration (it is referenced, not copied).
  static Param records(const char* name, const char* doc, const frichb_param_spec* fields,
                       size_t n_fields) {
    Param p(name, FRICHB_PARAM_RECORD_LIST, "", doc);
    p.spec_.fields = fields;
    p.spec_.n_fields = n_fields;
    return p;
  }

  Param& defaults_to(double value) {
    spec_.required = 0;
    spec_.default_real = value;
    return *this;
  }
  Param& defaults_to_text(const char* value) {
    spec_.required = 0;
    spec_.default_text = value;
    return *this;
  }
  // Lists only: may be omitted, then empty.
  Param& optional() {
    spec_.required = 0;
    return *this;
  }
  Param& at_least(double v) {
    spec_.min_value = v;
    spec_.min_exclusive = 0;
    return *this;
  }
  Param& greater_than(double v) {
    spec_.min_value = v;
    spec_.min_exclusive = 1;
    return *this;
  }
  Param& at_most(double v) {
    spec_.max_value = v;
    spec_.max_exclusive = 0;
    return *this;
  }
  Param& less_than(double v) {
    spec_.max_value = v;
    spec_.max_exclusive = 1;
    return *this;
  }
  Param& count(size_t least, size_t most) {
    spec_.min_count = least;
    spec_.max_count = most;
    return *this;
  }
  // STRING only: allowed values separated by '|', e.g. "constant|variable".
  Param& choices(const char* alternatives) {
    spec_.choices = alternatives;
    return *this;
  }
  operator frichb_param_spec() const { return spec_; }  // NOLINT(google-explicit-constructor)

 private:
  Param(const char* name, int type, const char* unit, const char* doc) {
    std::memset(&spec_, 0, sizeof(spec_));
    spec_.name = name;
    spec_.type = type;
    spec_.unit = unit;
    spec_.doc = doc;
    spec_.required = 1;
    spec_.min_value = -kUnbounded;
    spec_.max_value = kUnbounded;
  }
  frichb_param_spec spec_;
};

// Read-only view of validated parameters (host-owned, valid during create()).
class Params {
 public:
  Params(const frichb_param_spec* specs, size_t n, const frichb_param_value* values)
      : specs_(specs), n_(n), values_(values) {}

  bool present(std::string_view name) const { return value(name).present != 0; }
  double real(std::string_view name) const { return value(name).real; }
  long long integer(std::string_view name) const {
    return static_cast<long long>(std::llround(value(name).real));
  }
  bool boolean(std::string_view name) const { return value(name).real != 0.0; }
  std::string text(std::string_view name) const {
    const char* t = value(name).text;
    return t ? std::string(t) : std::string();
  }
  std::vector<double> reals(std::string_view name) const {
    const auto& v = value(name);
    return std::vector<double>(v.reals, v.reals + v.n_reals);
  }
  std::vector<std::string> texts(std::string_view name) const {
    const auto& v = value(name);
    std::vector<std::string> out;
    for (size_t i = 0; i < v.n_texts; ++i) out.emplace_back(v.texts[i]);
    return out;
  }
  size_t record_count(std::string_view name) const { return value(name).n_records; }
  Params record(std::string_view name, size_t i) const {
    const size_t k = index_of(name);
    const auto& v = values_[k];
    if (i >= v.n_records) throw std::out_of_range("record index out of range for " + key(name));
    return Params(specs_[k].fields, specs_[k].n_fields, v.records + i * specs_[k].n_fields);
  }

 private:
  static std::string key(std::string_view name) { return std::string(name); }
  size_t index_of(std::string_view name) const {
    for (size_t i = 0; i < n_; ++i)
      if (name == specs_[i].name) return i;
    throw std::invalid_argument("parameter '" + key(name) + "' is not in the schema");
  }
  const frichb_param_value& value(std::string_view name) const { return values_[index_of(name)]; }

  const frichb_param_spec* specs_;
  size_t n_;
  const frichb_param_value* values_;
};

// Base class of a contact law. Implementations are immutable after construction and
// step() is called concurrently from several threads: keep no mutable members.
class ContactLaw {
 public:
  virtual ~ContactLaw() = default;
  virtual frichb_contact_law_traits traits() const = 0;
  // Default: all-zero state (unloaded contact, slider at the origin).
  virtual void initial_state(double* state) const {
    const auto t = traits();
    for (int i = 0; i < t.state_size; ++i) state[i] = 0.0;
  }
  // See frichb_contact_law_api::step for the contract; `tangents` may be null.
  virtual void step(const double* state_prev, const double* u_prev, const double* u_now,
                    double* force_now, double* state_now,
                    const frichb_step_tangents* tangents) const = 0;
  // ABI 1.3 (frichb_contact_law_api::step_along): the step along the motion between the
  // samples. A law that overrides it says so with traits().traces_motion = 1; the host calls
  // it only then. `tangents` is null (value only), or has all six blocks with `motion_tangents`
  // non-null, or only dstate_dstate_prev (the monodromy of a pass; `motion_tangents` null):
  // see frichb_contact_law_api::step_along. `kinks` may be null.
  virtual void step_along(const double* state_prev, const double* u_prev, const double* u_now,
                          const frichb_step_motion& motion, double* force_now, double* state_now,
                          const frichb_step_tangents* tangents,
                          const frichb_motion_tangents* motion_tangents,
                          frichb_force_kinks* kinks) const {
    (void)state_prev, (void)u_prev, (void)u_now, (void)motion, (void)force_now, (void)state_now,
        (void)tangents, (void)motion_tangents, (void)kinks;
    throw std::logic_error("this contact law does not step along the motion");
  }
};

// Base class of a structure provider (see frichb_structure_api).
class StructureProvider {
 public:
  virtual ~StructureProvider() = default;
  virtual size_t dof_count() const = 0;
  // Sectors of a cyclic sector model (harmonic indices 0..sectors-1); 1 for a plain structure.
  virtual size_t sector_count() const { return 1; }
  // The returned pointers must stay valid until the next call or destruction.
  virtual frichb_modal_basis modal_basis(int harmonic_index, const size_t* kept_dofs,
                                         size_t n_kept) = 0;
  // The mistunable part's stiffness projected on the modes of two harmonic indices
  // (frichb_structure_api.blade_stiffness): rows x cols, which must be n_modes(h1) x
  // n_modes(h2) (throw otherwise), row-major into `real` and `imag`. The default refuses: the
  // model has no mistunable part.
  virtual void blade_stiffness(int /*h1*/, int /*h2*/, bool /*conjugate_first*/, size_t /*rows*/,
                               size_t /*cols*/, double* /*real*/, double* /*imag*/) {
    throw std::invalid_argument("this structure provider defines no mistunable (blade) part");
  }
};

inline frichb_contact_law_traits make_traits(int tangential_dimensions, bool uses_normal,
                                             int state_size, bool provides_tangent,
                                             bool traces_motion = false) {
  frichb_contact_law_traits t{};
  t.struct_size = sizeof(t);
  t.tangential_dimensions = tangential_dimensions;
  t.uses_normal = uses_normal ? 1 : 0;
  t.state_size = state_size;
  t.provides_tangent = provides_tangent ? 1 : 0;
  t.traces_motion = traces_motion ? 1 : 0;
  return t;
}

namespace detail {

inline void write_message(char* buffer, size_t capacity, const char* text) {
  if (!buffer || capacity == 0) return;
  std::strncpy(buffer, text, capacity - 1);
  buffer[capacity - 1] = '\0';
}

template <class Fn>
frichb_status guarded(char* message, size_t capacity, Fn&& fn) noexcept {
  try {
    fn();
    return FRICHB_OK;
  } catch (const std::exception& e) {
    write_message(message, capacity, e.what());
  } catch (...) {
    write_message(message, capacity, "unknown exception in plugin");
  }
  return FRICHB_ERROR;
}

inline const char* build_tag() {
#if defined(__clang__)
  return "clang " __clang_version__ ", " __DATE__;
#elif defined(__GNUC__)
  return "gcc " __VERSION__ ", " __DATE__;
#else
  return "unknown compiler, " __DATE__;
#endif
}

// Creation and destruction shared by every plugin kind: Impl derives from Base and is
// constructed from the validated parameters of `schema`.
template <class Base, class Impl>
struct Lifecycle {
  static const std::vector<frichb_param_spec>* schema;
  static frichb_status create(const frichb_param_value* params, size_t n, void** instance,
                              char* message, size_t capacity) {
    return guarded(message, capacity, [&] {
      if (n != schema->size()) throw std::invalid_argument("parameter count differs from schema");
      *instance = static_cast<Base*>(new Impl(Params(schema->data(), n, params)));
    });
  }
  static void destroy(void* instance) { delete static_cast<Base*>(instance); }
};
template <class Base, class Impl>
const std::vector<frichb_param_spec>* Lifecycle<Base, Impl>::schema = nullptr;

template <class Law>
struct ContactLawTrampolines : Lifecycle<ContactLaw, Law> {
  static void traits(const void* instance, frichb_contact_law_traits* out) {
    *out = static_cast<const ContactLaw*>(instance)->traits();
  }
  static void initial_state(const void* instance, double* state) {
    static_cast<const ContactLaw*>(instance)->initial_state(state);
  }
  static frichb_status step(const void* instance, const double* state_prev, const double* u_prev,
                            const double* u_now, double* force_now, double* state_now,
                            const frichb_step_tangents* tangents, char* message, size_t capacity) {
    return guarded(message, capacity, [&] {
      static_cast<const ContactLaw*>(instance)->step(state_prev, u_prev, u_now, force_now,
                                                     state_now, tangents);
    });
  }
  static frichb_status step_along(const void* instance, const double* state_prev,
                                  const double* u_prev, const double* u_now,
                                  const frichb_step_motion* motion, double* force_now,
                                  double* state_now, const frichb_step_tangents* tangents,
                                  const frichb_motion_tangents* motion_tangents,
                                  frichb_force_kinks* kinks, char* message, size_t capacity) {
    return guarded(message, capacity, [&] {
      static_cast<const ContactLaw*>(instance)->step_along(state_prev, u_prev, u_now, *motion,
                                                           force_now, state_now, tangents,
                                                           motion_tangents, kinks);
    });
  }
};

template <class Provider>
struct StructureTrampolines : Lifecycle<StructureProvider, Provider> {
  static size_t dof_count(const void* instance) {
    return static_cast<const StructureProvider*>(instance)->dof_count();
  }
  static size_t sector_count(const void* instance) {
    return static_cast<const StructureProvider*>(instance)->sector_count();
  }
  static frichb_status modal_basis(void* instance, int harmonic_index, const size_t* kept,
                                   size_t n_kept, frichb_modal_basis* basis, char* message,
                                   size_t capacity) {
    return guarded(message, capacity, [&] {
      *basis = static_cast<StructureProvider*>(instance)->modal_basis(harmonic_index, kept, n_kept);
    });
  }
  static frichb_status blade_stiffness(void* instance, int h1, int h2, int conjugate_first,
                                       size_t rows, size_t cols, double* real, double* imag,
                                       char* message, size_t capacity) {
    return guarded(message, capacity, [&] {
      static_cast<StructureProvider*>(instance)->blade_stiffness(h1, h2, conjugate_first != 0, rows,
                                                                 cols, real, imag);
    });
  }
};

template <class Law>
const frichb_plugin_descriptor* contact_law_descriptor(
    const char* name, const char* version, const char* summary,
    std::vector<frichb_param_spec> (*schema_fn)()) {
  using T = ContactLawTrampolines<Law>;
  static const std::vector<frichb_param_spec> schema = schema_fn();
  T::schema = &schema;
  static const frichb_contact_law_api api = {sizeof(frichb_contact_law_api),
                                             &T::create,
                                             &T::destroy,
                                             &T::traits,
                                             &T::initial_state,
                                             &T::step,
                                             &T::step_along};
  static const frichb_plugin_descriptor descriptor = {FRICHB_ABI_MAJOR,
                                                      FRICHB_ABI_MINOR,
                                                      sizeof(frichb_plugin_descriptor),
                                                      FRICHB_KIND_CONTACT_LAW,
                                                      name,
                                                      version,
                                                      build_tag(),
                                                      summary,
                                                      schema.data(),
                                                      schema.size(),
                                                      &api,
                                                      nullptr};
  return &descriptor;
}

template <class Provider>
const frichb_plugin_descriptor* structure_descriptor(
    const char* name, const char* version, const char* summary,
    std::vector<frichb_param_spec> (*schema_fn)()) {
  using T = StructureTrampolines<Provider>;
  static const std::vector<frichb_param_spec> schema = schema_fn();
  T::schema = &schema;
  static const frichb_structure_api api = {sizeof(frichb_structure_api),
                                           &T::create,
                                           &T::destroy,
                                           &T::dof_count,
                                           &T::modal_basis,
                                           &T::sector_count,
                                           &T::blade_stiffness};
  static const frichb_plugin_descriptor descriptor = {FRICHB_ABI_MAJOR,
                                                      FRICHB_ABI_MINOR,
                                                      sizeof(frichb_plugin_descriptor),
                                                      FRICHB_KIND_STRUCTURE,
                                                      name,
                                                      version,
                                                      build_tag(),
                                                      summary,
                                                      schema.data(),
                                                      schema.size(),
                                                      nullptr,
                                                      &api};
  return &descriptor;
}

}  // namespace detail
}  // namespace frichb::sdk

// Export macros: NAME is the registry name written as a C identifier (no quotes). CLASS is a
// template argument and NAME is pasted, so neither can be parenthesised.
// NOLINTBEGIN(bugprone-macro-parentheses)
#define FRICHB_CONTACT_LAW_PLUGIN(CLASS, NAME, VERSION, SUMMARY, SCHEMA_FN)               \
  extern "C" FRICHB_PLUGIN_EXPORT const char frichb_plugin_name__##NAME = 0;              \
  extern "C" FRICHB_PLUGIN_EXPORT const frichb_plugin_descriptor* frichb_plugin_entry() { \
    return ::frichb::sdk::detail::contact_law_descriptor<CLASS>(#NAME, VERSION, SUMMARY,  \
                                                                &SCHEMA_FN);              \
  }

#define FRICHB_STRUCTURE_PLUGIN(CLASS, NAME, VERSION, SUMMARY, SCHEMA_FN)                 \
  extern "C" FRICHB_PLUGIN_EXPORT const char frichb_plugin_name__##NAME = 0;              \
  extern "C" FRICHB_PLUGIN_EXPORT const frichb_plugin_descriptor* frichb_plugin_entry() { \
    return ::frichb::sdk::detail::structure_descriptor<CLASS>(#NAME, VERSION, SUMMARY,    \
                                                              &SCHEMA_FN);                \
  }
// NOLINTEND(bugprone-macro-parentheses)
