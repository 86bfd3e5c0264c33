/*
 * FricHB plugin ABI: the only contract that crosses a shared-library boundary.
 *
 * A plugin is a shared library exporting ONE entry point,
 *
 *     extern "C" const frichb_plugin_descriptor* frichb_plugin_entry(void);
 *
 * returning a pointer to a static descriptor that lives as long as the library is loaded.
 * It also exports a marker symbol named FRICHB_PLUGIN_NAME_MARKER_PREFIX + <plugin name>
 * so that the host can list plugin names from the symbol table without running any of the
 * library's code (Boost.DLL's library_info).
 *
 * Rules (see docs/plugin-authoring.md):
 *  - Only plain C types, arrays and sizes cross the boundary; no C++ exception may escape
 *    a function of the table: failures return FRICHB_ERROR and write a NUL-terminated
 *    message into the caller's buffer (truncated to its capacity).
 *  - Structs are only ever extended by appending fields; every struct that may grow starts
 *    with its size (struct_size) so both sides can tell what the other knows.
 *  - The host refuses a plugin whose abi_major differs from its own, or whose abi_minor is
 *    newer than its own.
 *  - Units are SI throughout. Angles in radians unless a parameter's unit says otherwise.
 *
 * Do not edit in a way that changes the layout of existing fields: bump FRICHB_ABI_MAJOR.
 */
#ifndef FRICHB_PLUGIN_ABI_H
#define FRICHB_PLUGIN_ABI_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

#ifndef FRICHB_ABI_MAJOR
#define FRICHB_ABI_MAJOR 1
#endif
#ifndef FRICHB_ABI_MINOR
#define FRICHB_ABI_MINOR                                                                 \
  4 /* 1.1: frichb_structure_api.sector_count appended;                                  \
       1.2: steps along the motion (step_along, traces_motion);                          \
       1.3: frichb_force_kinks with struct_size and onsets (the host calls step_along of \
       plugins built for 1.3 or later only, and steps 1.2 plugins by step());            \
       1.4: frichb_structure_api.blade_stiffness appended (mistuned disks) */
#endif

#define FRICHB_PLUGIN_ENTRY_SYMBOL "frichb_plugin_entry"
#define FRICHB_PLUGIN_NAME_MARKER_PREFIX "frichb_plugin_name__"

#if defined(_WIN32)
#define FRICHB_PLUGIN_EXPORT __declspec(dllexport)
#else
#define FRICHB_PLUGIN_EXPORT __attribute__((visibility("default")))
#endif

typedef enum frichb_status { FRICHB_OK = 0, FRICHB_ERROR = 1 } frichb_status;

typedef enum frichb_plugin_kind {
  FRICHB_KIND_CONTACT_LAW = 1,
  FRICHB_KIND_STRUCTURE = 2
} frichb_plugin_kind;

/* ------------------------------------------------------------------------------------ */
/* Parameter schema: the single source of truth for validation, docs and defaults.        */
/* ------------------------------------------------------------------------------------ */

typedef enum frichb_param_type {
  FRICHB_PARAM_REAL = 1,        /* a double */
  FRICHB_PARAM_INTEGER = 2,     /* an integer, stored in `real` of the value */
  FRICHB_PARAM_BOOLEAN = 3,     /* 0 or 1, stored in `real` of the value */
  FRICHB_PARAM_STRING = 4,      /* text */
  FRICHB_PARAM_REAL_LIST = 5,   /* a list of doubles; element range from min/max */
  FRICHB_PARAM_STRING_LIST = 6, /* a list of scalars read as text */
  FRICHB_PARAM_RECORD_LIST = 7, /* a list of maps whose keys are described by `fields` */
  FRICHB_PARAM_PATH = 8         /* ABI 1.1: a file path in `text`; the host resolves a relative
                                   path against the folder of the scene file that gives it */
} frichb_param_type;

typedef struct frichb_param_spec {
  const char* name;         /* key in the scene's params map, a C identifier */
  int type;                 /* frichb_param_type */
  const char* unit;         /* SI unit, "" when dimensionless or not a quantity */
  const char* doc;          /* one line */
  int required;             /* 1: the scene must give it; 0: `default_*` applies (lists: empty) */
  double default_real;      /* default of REAL / INTEGER / BOOLEAN */
  const char* default_text; /* default of STRING (NULL when required) */
  double min_value;         /* lower bound of REAL/INTEGER and REAL_LIST elements */
  double max_value;         /* upper bound; use +-HUGE_VAL for none */
  int min_exclusive;        /* 1: value > min_value is required instead of >= */
  int max_exclusive;        /* 1: value < max_value is required instead of <= */
  size_t min_count;         /* lists: fewest elements (0: no bound) */
  size_t max_count;         /* lists: most elements (0: no bound) */
  const char* choices;      /* STRING: allowed values separated by '|', NULL: any */
  const struct frichb_param_spec* fields; /* RECORD_LIST: the keys of each record */
  size_t n_fields;
} frichb_param_spec;

/*
 * A validated value, aligned index by index with the schema it was validated against.
 * Owned by the host; valid only during the call that receives it (copy what you keep).
 */
typedef struct frichb_param_value {
  int present;      /* 1 when given in the scene, 0 when the default was applied */
  double real;      /* REAL, INTEGER, BOOLEAN */
  const char* text; /* STRING */
  const double* reals;
  size_t n_reals; /* REAL_LIST */
  const char* const* texts;
  size_t n_texts; /* STRING_LIST */
  /* RECORD_LIST: n_records * n_fields values, record-major, fields in schema order. */
  const struct frichb_param_value* records;
  size_t n_records;
} frichb_param_value;

/* ------------------------------------------------------------------------------------ */
/* Contact laws: one time step of one contact point in the local frame (t1, t2, n).      */
/* ------------------------------------------------------------------------------------ */

typedef struct frichb_contact_law_traits {
  size_t struct_size;
  int tangential_dimensions; /* 1 (t1 only) or 2 (t1, t2) */
  int uses_normal;           /* 1 when the normal relative displacement matters */
  int state_size;            /* number of doubles of history state (may be 0) */
  int provides_tangent;      /* 1 when step() fills the tangents it is given */
  /* ABI 1.2: 1 when the law provides step_along (read only when struct_size covers it). */
  int traces_motion;
} frichb_contact_law_traits;

/*
 * Consistent tangents of one step, all row-major, S = state_size. The host passes either all
 * six blocks or none (tangents == NULL: value only), and zeroes them before each call: a law
 * writes its nonzero entries.
 *   dforce_du_now[i*3+j]        = d force_now_i / d u_now_j          (3 x 3)
 *   dforce_du_prev[i*3+j]       = d force_now_i / d u_prev_j         (3 x 3)
 *   dforce_dstate_prev[i*S+k]   = d force_now_i / d state_prev_k     (3 x S)
 *   dstate_du_now[k*3+j]        = d state_now_k / d u_now_j          (S x 3)
 *   dstate_du_prev[k*3+j]       = d state_now_k / d u_prev_j         (S x 3)
 *   dstate_dstate_prev[k*S+l]   = d state_now_k / d state_prev_l     (S x S)
 */
typedef struct frichb_step_tangents {
  double* dforce_du_now;
  double* dforce_du_prev;
  double* dforce_dstate_prev;
  double* dstate_du_now;
  double* dstate_du_prev;
  double* dstate_dstate_prev;
} frichb_step_tangents;

/*
 * ABI 1.2: the motion inside one step, for laws that trace along it (step_along). With s in
 * [0, 1] the step's fraction, the relative displacement over the step is the cubic Hermite
 * u(s) = h00 u_prev + h10 rate_prev + h01 u_now + h11 rate_now, rates du/ds in m per step
 * (a host sampling a harmonic series gives the series' rates: the cubic then matches the
 * motion to fourth order in the step).
 */
typedef struct frichb_step_motion {
  size_t struct_size;
  const double* rate_prev; /* du/ds at the step's start, 3 (t1, t2, n) */
  const double* rate_now;  /* du/ds at its end, 3 */
} frichb_step_motion;

/* ABI 1.2: tangents with respect to the rates, row-major, passed with the six blocks of
 * frichb_step_tangents (all or none) and zeroed by the host before each call. */
typedef struct frichb_motion_tangents {
  double* dforce_drate_prev; /* 3 x 3 */
  double* dforce_drate_now;  /* 3 x 3 */
  double* dstate_drate_prev; /* S x 3 */
  double* dstate_drate_now;  /* S x 3 */
} frichb_motion_tangents;

/*
 * ABI 1.2: kinks of the force inside one step: where its rate dforce/ds jumps (a contact that
 * starts to slip, opens or closes between samples). A host whose quadrature of the force
 * assumes smoothness corrects it there. The law writes at most `capacity` kinks and sets
 * `count`. With tangents, it also writes each kink's derivatives with respect to the step's
 * inputs, in the order [state_prev (S), u_prev (3), u_now (3), rate_prev (3), rate_now (3)],
 * I = S + 12 of them: dfraction[k * I + i], drate_jump[(k * 3 + a) * I + i] and
 * donset[(k * 3 + a) * I + i]; without tangents those pointers are NULL.
 *
 * An onset: a force that starts from a kink like a power of the distance from it,
 * F ~ onset |s - s*|^p on one side only (a Hertz contact closing or opening: N ~ c_n p^1.5),
 * which no rate jump describes (its rate is continuous, 0 at s*) but which bends the
 * trapezoidal sum as h^(p+1). The law sets onset_power[k] = p (> 1) and onset_side[k] = +1 for
 * s > s* (a closing), -1 for s < s* (an opening), or onset_power[k] = 0 for none. This
 * layout is that of ABI 1.3 (a host calls step_along of 1.3 plugins only); struct_size lets
 * later minors append fields.
 */
typedef struct frichb_force_kinks {
  size_t struct_size;
  size_t capacity;
  size_t count;
  double* fraction;  /* s of each kink, in [0, 1] */
  double* rate_jump; /* 3 per kink: (dforce/ds after) - (before), N per step */
  double* dfraction;
  double* drate_jump;
  double* onset;       /* 3 per kink: the coefficient, N per step^p */
  double* onset_power; /* 1 per kink: p, or 0 for no onset */
  double* onset_side;  /* 1 per kink: +1 (after s*) or -1 (before s*) */
  double* donset;
} frichb_force_kinks;

typedef struct frichb_contact_law_api {
  size_t struct_size;
  /* Builds an instance from validated parameters (aligned with the descriptor's schema).
   * The instance is immutable afterwards: step() is const and may run on many threads. */
  frichb_status (*create)(const frichb_param_value* params, size_t n_params, void** instance,
                          char* message, size_t message_capacity);
  void (*destroy)(void* instance);
  void (*traits)(const void* instance, frichb_contact_law_traits* traits);
  /* Fills state[state_size] with the state of an unloaded contact (u = 0, no slip). */
  void (*initial_state)(const void* instance, double* state);
  /*
   * One step from u_prev to u_now (relative displacement in the local frame (t1, t2, n), m;
   * the normal component is positive when the surfaces close). Writes force_now[3]: the
   * interface force in the local frame (N), oriented like a spring force: a stuck tangential
   * contact gives +kt*u, a closed normal contact a positive normal force. Components a law
   * does not use must be written as 0. `tangents` may be NULL (value only).
   */
  frichb_status (*step)(const void* instance, const double* state_prev, const double* u_prev,
                        const double* u_now, double* force_now, double* state_now,
                        const frichb_step_tangents* tangents, char* message,
                        size_t message_capacity);
  /*
   * ABI 1.2, optional (NULL, or past struct_size, for a law that only has step): the same
   * step along the motion `motion` between the samples, reporting the force's kinks inside
   * it into `kinks` (may be NULL). `tangents` is NULL (value only), or has all six blocks
   * (with `motion_tangents` then non-NULL), or only dstate_dstate_prev (the other five NULL,
   * and `motion_tangents` NULL): the host then wants the state's own derivative alone (the
   * monodromy of a pass, for its Newton steps onto the periodic state).
   */
  frichb_status (*step_along)(const void* instance, const double* state_prev, const double* u_prev,
                              const double* u_now, const frichb_step_motion* motion,
                              double* force_now, double* state_now,
                              const frichb_step_tangents* tangents,
                              const frichb_motion_tangents* motion_tangents,
                              frichb_force_kinks* kinks, char* message, size_t message_capacity);
} frichb_contact_law_api;

/* ------------------------------------------------------------------------------------ */
/* Structure providers: modal data at the DOFs the scene keeps.                           */
/* ------------------------------------------------------------------------------------ */

/*
 * Modal basis of one harmonic index at the kept DOFs. All pointers refer to memory owned by
 * the provider instance, valid until the next modal_basis() call on it or its destruction.
 * The receptance the host builds from it is
 *   R(W) = Phi (diag(w_r^2) - W^2 I + i W C)^-1 Phi^H  (+ residual flexibility)
 * with W the circular excitation frequency in rad/s and Phi mass-normalised.
 */
typedef struct frichb_modal_basis {
  size_t struct_size;
  size_t n_modes;
  const double* natural_frequencies;  /* w_r in rad/s, n_modes */
  const double* modal_damping;        /* C, n_modes x n_modes row-major, 1/s; modal damping
                                         ratio z_r is C_rr = 2 z_r w_r */
  const double* mode_rows_real;       /* Phi, n_kept x n_modes row-major, m/sqrt(kg) */
  const double* mode_rows_imag;       /* imaginary part of Phi, or NULL when real */
  const double* residual_flexibility; /* n_kept x n_kept real (m/N), or NULL */
  /* ABI 1.1: imaginary part of the (Hermitian) residual flexibility of a complex harmonic
   * index, n_kept x n_kept row-major, or NULL (real). Read only when struct_size covers it. */
  const double* residual_flexibility_imag;
} frichb_modal_basis;

typedef struct frichb_structure_api {
  size_t struct_size;
  frichb_status (*create)(const frichb_param_value* params, size_t n_params, void** instance,
                          char* message, size_t message_capacity);
  void (*destroy)(void* instance);
  /* Number of DOFs of the (sector) model; DOF indices in the scene run from 0 to this - 1. */
  size_t (*dof_count)(const void* instance);
  /* Harmonic index h (0 for a structure without cyclic symmetry; 0 <= h < sector_count for a
   * cyclic sector model: the basis of K0 + e^{-i h phi} K1 + e^{i h phi} K1^T and likewise
   * for M, phi = 2 pi / sectors, K1 coupling a sector's DOFs to the next sector's). Not
   * thread-safe. */
  frichb_status (*modal_basis)(void* instance, int harmonic_index, const size_t* kept_dofs,
                               size_t n_kept, frichb_modal_basis* basis, char* message,
                               size_t message_capacity);
  /* ABI 1.1: number of sectors nb of a cyclic sector model, 1 for a plain structure. The host
   * reads it only when struct_size covers it (a 1.0 plugin is a plain structure). */
  size_t (*sector_count)(const void* instance);
  /* ABI 1.4, optional (NULL, or past struct_size: the structure cannot be mistuned). For a
   * cyclic sector model: the stiffness K_b of the sector's mistunable part (its blade: the
   * part whose stiffness a mistuning factor scales, blade by blade) projected on the modes of
   * harmonic indices h1 and h2, all of them and over all DOFs, as modal_basis gives them:
   *   S = Phi_h1^H K_b Phi_h2 (conjugate_first = 1)  or  Phi_h1^T K_b Phi_h2 (0),
   * rows x cols = n_modes(h1) x n_modes(h2) row-major into the caller's `real` and `imag`
   * (rows * cols doubles each), in 1/s^2 (K_b in N/m, modes mass-normalised). K_b is real
   * symmetric and within one sector: a spring between sectors is not part of a blade.
   * FRICHB_ERROR with a message when the model has no mistunable part defined, or when rows
   * and cols are not the two indices' mode counts. Not thread-safe. */
  frichb_status (*blade_stiffness)(void* instance, int h1, int h2, int conjugate_first, size_t rows,
                                   size_t cols, double* real, double* imag, char* message,
                                   size_t message_capacity);
} frichb_structure_api;

/* ------------------------------------------------------------------------------------ */
/* The descriptor.                                                                        */
/* ------------------------------------------------------------------------------------ */

typedef struct frichb_plugin_descriptor {
  unsigned abi_major;
  unsigned abi_minor;
  size_t struct_size;
  int kind;              /* frichb_plugin_kind */
  const char* name;      /* registry name, a C identifier, unique on the search path */
  const char* version;   /* the plugin's own version, e.g. "1.0.0" */
  const char* build_tag; /* compiler and build date, informational */
  const char* summary;   /* one line */
  const frichb_param_spec* params;
  size_t n_params;
  const frichb_contact_law_api* contact_law; /* non-NULL iff kind == CONTACT_LAW */
  const frichb_structure_api* structure;     /* non-NULL iff kind == STRUCTURE */
} frichb_plugin_descriptor;

typedef const frichb_plugin_descriptor* (*frichb_plugin_entry_fn)(void);

#ifdef __cplusplus
}
#endif

#endif /* FRICHB_PLUGIN_ABI_H */
