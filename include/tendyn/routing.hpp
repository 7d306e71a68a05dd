// tendyn — transmission kinematics and lossless statics of a tendon-driven serial chain.
//
// S0 §II-A/B with the corrections of ERRATA (S0 eqs. 1–2, 5):
//   per transmission i: S_0^i = r_m^i q_m^i; S_j^i = S_{j-1}^i − r_j^i q_j (joints crossed);
//   at its driven joint q_i = S_{i-1}^i / r_i^i.  Compact form  R_m q_m = K q,
//   R_m = diag(r_m^i), K_ij = r_j^i (signed radius of the pulley of joint j the cable wraps) and
//   K_ii = driven pulley radius · reducer ratio (S0 footnote 1: generalised radius).
//   Statics: τ_J = Kᵀ t, C_m = R_m t (t = cable tensions); virtual work q̇ᵀτ_J = q̇_mᵀC_m.
//
// General routing (issue 19): S0's cables are serial (K lower-triangular, a cable crosses only the joints
// before the one it drives). Here a cable may also wrap joints after its driven joint (differentials:
// K_ij ≠ 0 for j > i), radii are signed (winding direction, driven radius included) and a diagonal may be
// zero, as long as K is invertible. The last joint a cable wraps is last_joint(i) ≥ i; the cable has the
// branches b = 0…last_joint(i), in the order it runs from the motor. K is block lower-triangular with the
// finest contiguous blocks [block_begin, block_end] (a differential pair is one 2×2 block); the statics with
// losses solve a block of size 1 in closed form (S0's recursion) and a larger block by a piecewise-linear
// Newton iteration (losses.hpp). A device whose blocks all have size 1 and a positive diagonal is serial:
// it takes S0's recursion unchanged (same operations, same numbers).
//
// Indices are 0-based: transmission i drives joint i and wraps joints 0…last_joint(i). Branch b of
// transmission i (b = 0…last_joint(i)) is the stretch of cable just before joint b: branch 0 runs from the
// motor pulley to joint 0 on the base; in a serial routing branch i ends on the driven pulley of joint i.
//
// Model / Data convention: the model is immutable after construction; every call writes into a
// Data preallocated from it and allocates nothing. Setup-time helpers (set_field, validate_report,
// describe, update_matrices) allocate; the real-time calls and validate() do not.
#pragma once

#include "tendyn/status.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include <limits>

#include <Eigen/Core>
#include <Eigen/LU>

namespace tendyn {

// ---- the parameter table (one declaration per field) ------------------------------------------
//
// X(name, dims, unit, doc) for every input field of TransmissionModel, in this order. dims = 1: (n) per
// transmission; dims = 2: (n, n), [i, j] = joint j (K) or branch j (loss fields) of transmission i.
// The bindings (read-only properties), the model file (save/load, C ABI), set_field and the tests that
// compare it with the Python schema (python/tendyn/device/schema.py: TRANSMISSION_MODEL_FIELDS) all
// derive from this one list. Bearing fields are "bearing_" + the device-file key of `bearings` entries.
#define TENDYN_TRANSMISSION_FIELDS(X)                                                                  \
  X(motor_radius, 1, "m", "motor pulley radius r_m, > 0")                                               \
  X(K, 2, "m", "transmission matrix, invertible: [i, j] signed radius of the pulley of joint j that cable i wraps (after i: differentials), driven_radius * reducer_ratio on the diagonal") \
  X(driven_radius, 1, "m", "driven pulley radius (without reducer), signed (winding direction); 0 = the cable does not wrap its joint (zero diagonal, K must stay invertible)") \
  X(reducer_ratio, 1, "-", "reducer ratio n in the driven pulley, > 0")                                 \
  X(reducer_efficiency, 1, "-", "direct efficiency eta_d in (0, 1]; <= 0.5 is self-locking")             \
  X(pretension, 1, "N", "cable pretension, >= 0 (loads the bearings)")                                  \
  X(tau0, 2, "N", "constant tension loss tau_0 of the branch (S0 eq. 12), >= 0")                        \
  X(nu, 2, "N s/m", "viscous tension loss nu of the branch (S0 eqs. 11-12), >= 0")                      \
  X(beta, 2, "-", "tension-proportional loss beta of the branch (S0 eq. 11), in [0, 1)")                \
  X(bearing_count, 2, "-", "number of identical bearings on the branch pulley, integer >= 0; 0 = none") \
  X(bearing_radius, 2, "m", "pulley radius the cable wraps over the bearings, > 0")                     \
  X(bearing_wrap, 2, "rad", "wrap angle of the cable on that pulley, in (0, 2 pi] where count > 0")     \
  X(bearing_static_coefficient, 2, "m", "bearing static coefficient (torque per radial load at break-away, S0 eq. 7 alpha)") \
  X(bearing_dynamic_coefficient, 2, "m", "bearing dynamic coefficient (torque per radial load while turning, S0 eq. 7 beta)") \
  X(bearing_h0, 2, "N m", "bearing speed term below n0 (S0 eq. 8)")                                     \
  X(bearing_h1, 2, "N m (rad/s)^(-2/3)", "bearing speed coefficient above n0 (S0 eq. 8)")              \
  X(bearing_n0, 2, "rad/s", "bearing speed threshold (S0 eq. 8)")

/// One row of the parameter table.
struct FieldInfo {
  const char* name;  ///< core field name (also the model-file key and the Python routing-array key)
  int dims;          ///< 1: (n); 2: (n, n)
  const char* unit;  ///< SI unit
  const char* doc;   ///< one-line meaning
};

#define TENDYN_FIELD_INFO(name, dims, unit, doc) FieldInfo{#name, dims, unit, doc},
inline constexpr FieldInfo transmission_fields[] = {TENDYN_TRANSMISSION_FIELDS(TENDYN_FIELD_INFO)};
#undef TENDYN_FIELD_INFO
inline constexpr int transmission_field_count =
    static_cast<int>(sizeof(transmission_fields) / sizeof(transmission_fields[0]));

/// Physical bound on the magnitude of each field's entries: the device schema's bounds
/// (python/tendyn/device/schema.py; a test checks they agree), so that a model file or a C caller cannot hand the
/// real-time core a Coulomb level of 1e308 N. The rule text carries the bound into the error message.
struct FieldBound {
  const char* name;  ///< core field name
  double max_abs;    ///< |entry| <= max_abs
  const char* rule;  ///< message, e.g. "must satisfy |value| <= 1e6 [N]"
};
inline constexpr FieldBound transmission_field_bounds[] = {
    {"motor_radius", 1.0, "must be <= 1 [m] (the device schema's bound)"},
    {"K", 1e4, "must satisfy |value| <= 1e4 [m] (driven_radius <= 1 m times reducer_ratio <= 1e4)"},
    {"driven_radius", 1.0, "must satisfy |value| <= 1 [m] (the device schema's bound)"},
    {"reducer_ratio", 1e4, "must be <= 1e4 [-] (the device schema's bound)"},
    {"pretension", 1e6, "must be <= 1e6 [N] (the device schema's bound)"},
    {"tau0", 1e6, "must be <= 1e6 [N] (the device schema's bound)"},
    {"nu", 1e6, "must be <= 1e6 [N s/m] (the device schema's bound)"},
    {"bearing_count", 1e3, "must be <= 1000 (bearings on one pulley)"},
    {"bearing_radius", 1.0, "must be <= 1 [m] (the device schema's bound)"},
    {"bearing_static_coefficient", 1.0, "must be <= 1 [m] (the device schema's bound)"},
    {"bearing_dynamic_coefficient", 1.0, "must be <= 1 [m] (the device schema's bound)"},
    {"bearing_h0", 1e3, "must be <= 1e3 [N m] (the device schema's bound)"},
    {"bearing_h1", 1e3, "must be <= 1e3 [N m (rad/s)^(-2/3)] (the device schema's bound)"},
    {"bearing_n0", 1e6, "must be <= 1e6 [rad/s] (the device schema's bound)"},
};

/// One problem found by TransmissionModel validation (setup time). Indices are 0-based, as in the
/// arrays: [i] transmission, [i, j] transmission i and joint / branch j; -1 = not applicable.
struct ValidationIssue {
  const char* field = "";  ///< core field name (e.g. "beta")
  int i = -1, j = -1;      ///< 0-based index of the offending entry; for a shape issue, the actual shape
  double value = 0.0;      ///< offending value; for a shape issue, the expected n
  const char* rule = "";   ///< what it must satisfy, e.g. "must be < 1"
  bool shape = false;      ///< true: the array has the wrong shape (i, j = rows, cols; value = n)
};

/// Immutable description of n tendon transmissions on an n-joint serial chain.
struct TransmissionModel {
  int n = 0;                          ///< number of transmissions = number of joints
  Eigen::VectorXd motor_radius;       ///< r_m^i [m], motor pulley radius, > 0
  Eigen::MatrixXd K;                  ///< (n, n) transmission matrix [m], invertible (lower-triangular: serial)
  Eigen::VectorXd driven_radius;      ///< driven pulley radius [m] (without reducer), signed
  Eigen::VectorXd reducer_ratio;      ///< n_i [-], 1 when no reducer
  Eigen::VectorXd reducer_efficiency; ///< direct efficiency η_d [-] in (0, 1]
  Eigen::VectorXd pretension;         ///< cable pretension [N], loads the bearings

  // Per-branch loss parameters, (n, n), entry [i, b] for branch b ≤ i of transmission i.
  Eigen::MatrixXd tau0;   ///< constant tension loss τ_0 [N] (S0 eq. 12)
  Eigen::MatrixXd nu;     ///< viscous tension loss ν [N·s/m] (S0 eqs. 11–12)
  Eigen::MatrixXd beta;   ///< tension-proportional loss β [-] (S0 eq. 11), in [0, 1)
  // Bearings of the idle pulleys of a branch (S0 eqs. 7–8); count 0 = none (the other bearing
  // fields of that branch are then ignored).
  Eigen::MatrixXd bearing_count;                ///< number of identical bearings [-]
  Eigen::MatrixXd bearing_radius;               ///< pulley radius the cable wraps [m]
  Eigen::MatrixXd bearing_wrap;                 ///< wrap angle of the cable on that pulley [rad]
  Eigen::MatrixXd bearing_static_coefficient;   ///< static coefficient (S0 eq. 7 α) [m]: torque per radial load
  Eigen::MatrixXd bearing_dynamic_coefficient;  ///< dynamic coefficient (S0 eq. 7 β) [m]
  Eigen::MatrixXd bearing_h0;                   ///< speed term below n0 [N·m]
  Eigen::MatrixXd bearing_h1;                   ///< speed term coefficient above n0 [N·m·(rad/s)^(-2/3)]
  Eigen::MatrixXd bearing_n0;                   ///< speed threshold [rad/s]

  // Matrices a controller needs, computed once at construction.
  Eigen::MatrixXd joint_from_motor_position;  ///< q = K⁻¹ R_m q_m
  Eigen::MatrixXd motor_from_joint_position;  ///< q_m = R_m⁻¹ K q
  Eigen::MatrixXd motor_from_joint_torque;    ///< C_m = R_m K⁻ᵀ τ_J
  Eigen::MatrixXd joint_from_motor_torque;    ///< τ_J = Kᵀ R_m⁻¹ C_m
  // Structure of the routing, computed with the matrices (validate() checks they match K).
  Eigen::VectorXi last_joint;   ///< last joint cable i wraps (≥ i; > i for a differential)
  Eigen::VectorXi block_begin;  ///< first index of the diagonal block of K holding index i
  Eigen::VectorXi block_end;    ///< last index of that block (block_begin = block_end: a 1×1 block)
  int dependent_transmission = -1;  ///< first i whose row of K depends on rows 0…i−1 (singular K), or −1
  bool serial = false;          ///< K lower-triangular with a positive diagonal (S0's recursion applies)

  TransmissionModel() = default;

  /// n transmissions with the defaults of every field: lossless, no bearings (count 0, radius 1 m,
  /// wrap 0), η_d = 1, no pretension, reducer ratio 1; motor_radius, K and driven_radius zero (set them
  /// with set_field, then call update_matrices()). Setup time (allocates).
  explicit TransmissionModel(int n_) : n(n_ > 0 ? n_ : 0) {
    motor_radius.setZero(n);
    driven_radius.setZero(n);
    K.setZero(n, n);
    reducer_ratio.setOnes(n);
    reducer_efficiency.setOnes(n);
    pretension.setZero(n);
    for (auto* m : {&tau0, &nu, &beta, &bearing_count, &bearing_wrap, &bearing_static_coefficient,
                    &bearing_dynamic_coefficient, &bearing_h0, &bearing_h1, &bearing_n0})
      m->setZero(n, n);
    bearing_radius.setOnes(n, n);
  }

  /// Lossless routing: `idle` holds the signed idle radii in its strict lower part [m]
  /// (entries on and above the diagonal are ignored). Loss parameters start at their defaults.
  TransmissionModel(const Eigen::VectorXd& motor_radius_, const Eigen::MatrixXd& idle,
                    const Eigen::VectorXd& driven_radius_, const Eigen::VectorXd& reducer_ratio_)
      : TransmissionModel(static_cast<int>(motor_radius_.size())) {
    motor_radius = motor_radius_;
    driven_radius = driven_radius_;
    reducer_ratio = reducer_ratio_;
    if (idle.rows() != n || idle.cols() != n || driven_radius.size() != n ||
        reducer_ratio.size() != n)
      return;  // validate() reports the shape
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < i; ++j) K(i, j) = idle(i, j);
      K(i, i) = driven_radius(i) * reducer_ratio(i);  // S0 footnote 1
    }
    update_matrices();
  }

  /// Call f(info, member) for every field of the parameter table, in table order.
  template <class F>
  void for_each_field(F&& f) {
#define TENDYN_VISIT(name, dims, unit, doc) f(FieldInfo{#name, dims, unit, doc}, name);
    TENDYN_TRANSMISSION_FIELDS(TENDYN_VISIT)
#undef TENDYN_VISIT
  }
  template <class F>
  void for_each_field(F&& f) const {
#define TENDYN_VISIT(name, dims, unit, doc) f(FieldInfo{#name, dims, unit, doc}, name);
    TENDYN_TRANSMISSION_FIELDS(TENDYN_VISIT)
#undef TENDYN_VISIT
  }

  /// Set field `name` from `rows * cols` values, row-major (a (n) field takes rows = n, cols = 1).
  /// Setup time (allocates). Returns false, and changes nothing, for an unknown name or a wrong shape.
  /// Call update_matrices() after the routing fields and validate() before use.
  bool set_field(const char* name, const double* values, int rows, int cols) {
    bool done = false;
    for_each_field([&](const FieldInfo& info, auto& member) {
      if (done || std::string_view(info.name) != name) return;
      done = true;
      const int want_cols = info.dims == 1 ? 1 : n;
      if (rows != n || cols != want_cols || (!values && n > 0)) { done = false; return; }
      for (int r = 0; r < rows; ++r)
        for (int c = 0; c < cols; ++c) assign(member, r, c, values[r * cols + c]);
    });
    return done;
  }

  /// Last joint row i of K wraps (≥ i), read from K itself (no allocation).
  int last_joint_of(int i) const {
    int last = i;
    for (int j = i + 1; j < K.cols(); ++j)
      if (K(i, j) != 0.0) last = j;
    return last;
  }

  /// Recompute the four matrices and the structure (last_joint, blocks, serial, dependent_transmission) after
  /// K or motor_radius changed (setup time; allocates). A singular K gives NaN matrices (validate() says which
  /// transmission depends on the earlier ones).
  void update_matrices() {
    last_joint.setZero(n);
    block_begin.setZero(n);
    block_end.setZero(n);
    serial = true;
    for (int begin = 0, end = 0, i = 0; i < n; ++i) {  // finest contiguous block lower-triangular partition
      last_joint(i) = last_joint_of(i);
      end = std::max(end, last_joint(i));
      serial = serial && last_joint(i) == i && K(i, i) > 0.0;
      if (i == end) {
        for (int k = begin; k <= end; ++k) { block_begin(k) = begin; block_end(k) = end; }
        begin = end = i + 1;
      }
    }
    dependent_transmission = -1;
    for (int i = 0; i < n && dependent_transmission < 0; ++i) {
      Eigen::FullPivLU<Eigen::MatrixXd> lu(K.topRows(i + 1));
      lu.setThreshold(1e-12);
      if (lu.rank() < i + 1) dependent_transmission = i;
    }
    if (dependent_transmission >= 0) {
      const double nan = std::numeric_limits<double>::quiet_NaN();
      for (auto* M : {&joint_from_motor_position, &motor_from_joint_torque})
        M->setConstant(n, n, nan);
      motor_from_joint_position = motor_radius.cwiseInverse().asDiagonal() * K;
      joint_from_motor_torque = K.transpose() * motor_radius.cwiseInverse().asDiagonal();
      return;
    }
    const Eigen::MatrixXd Kinv = serial ? Eigen::MatrixXd(K.triangularView<Eigen::Lower>().solve(Eigen::MatrixXd::Identity(n, n)))
                                        : Eigen::MatrixXd(K.fullPivLu().inverse());
    joint_from_motor_position = Kinv * motor_radius.asDiagonal();
    motor_from_joint_position = motor_radius.cwiseInverse().asDiagonal() * K;
    motor_from_joint_torque = motor_radius.asDiagonal() * Kinv.transpose();
    joint_from_motor_torque = K.transpose() * motor_radius.cwiseInverse().asDiagonal();
  }

  /// Visit every problem of the model in a fixed order; `sink(issue)` returns false to stop.
  /// Returns the number of issues visited. Allocates nothing.
  template <class Sink>
  int check(Sink&& sink) const;

  /// The first problem, if any (no allocation; usable anywhere). Returns true when one was found.
  bool first_issue(ValidationIssue* issue) const {
    ValidationIssue found;
    const int k = check([&](const ValidationIssue& is) { found = is; return false; });
    if (k > 0 && issue) *issue = found;
    return k > 0;
  }

  /// Ok when the routing is usable: shapes agree, K lower-triangular with a non-zero diagonal equal
  /// to driven_radius · reducer_ratio, positive radii, η_d in (0, 1], losses ≥ 0, β + bearing load
  /// terms < 1 (otherwise no tension can pass). InvalidModel otherwise; first_issue() or
  /// validate_report() (setup time) say which field and index. Allocates nothing.
  Status validate() const { return first_issue(nullptr) ? Status::InvalidModel : Status::Ok; }

 private:
  static void assign(Eigen::VectorXd& v, int r, int, double x) { v(r) = x; }
  static void assign(Eigen::MatrixXd& m, int r, int c, double x) { m(r, c) = x; }
};

/// Every problem of the model (setup time; allocates).
inline std::vector<ValidationIssue> validate_report(const TransmissionModel& m) {
  std::vector<ValidationIssue> out;
  m.check([&](const ValidationIssue& is) { out.push_back(is); return true; });
  return out;
}

/// Shortest of %.15g / %.17g that reads back to x (1.5 prints as 1.5, not 1.5000000000000000).
inline std::string format_double(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.15g", x);
  if (std::strtod(buf, nullptr) != x) std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

/// "beta[2,1] = 1.5: must be < 1" (0-based indices [transmission, joint or branch]), or
/// "tau0: shape (3, 3): must be (n, n) (n = 4)". Setup time (allocates).
inline std::string describe(const ValidationIssue& is) {
  std::string s = is.field;
  if (is.shape) {
    s += is.j < 0 ? ": " + std::to_string(is.i) + " entries: "
                  : ": shape (" + std::to_string(is.i) + ", " + std::to_string(is.j) + "): ";
    return s + is.rule + " (n = " + std::to_string(static_cast<int>(is.value)) + ")";
  }
  if (is.i >= 0) s += "[" + std::to_string(is.i) + (is.j >= 0 ? "," + std::to_string(is.j) : "") + "]";
  return s + " = " + format_double(is.value) + ": " + is.rule;
}

/// Preallocated workspace and outputs of the transmission calls.
struct TransmissionData {
  Eigen::VectorXd q, qd;            ///< joint position [rad], velocity [rad/s]
  Eigen::VectorXd q_motor, qd_motor;///< motor position [rad], velocity [rad/s]
  Eigen::MatrixXd S, Sdot;            ///< branch displacement [m] / velocity [m/s], [i, b]
  Eigen::MatrixXd tension;            ///< tension at joint b after branch b [N], [i, b]
  Eigen::VectorXd tension_motor;      ///< tension leaving the motor pulley [N]
  Eigen::VectorXd torque_motor;       ///< motor torque C_m [N·m]
  Eigen::VectorXd torque_joint;       ///< joint torque τ_J [N·m]
  Eigen::MatrixXi stuck;              ///< 1 where a branch does not slide (Ṡ = 0) [i, b]
  Eigen::VectorXi self_locked;        ///< 1 where a self-locking reducer holds the load
  // Workspace of the coupled blocks of a general routing (losses.hpp): slope[i, b] = ∂tension[i, b]/∂t_i
  // (t_i the tension at the last joint cable i wraps), the block's Jacobian, residual and step.
  Eigen::MatrixXd slope, block_jacobian;
  Eigen::VectorXd block_residual, block_step;
  int block_iterations = 0;           ///< Newton iterations of the last feedforward (all coupled blocks)
  /// 2×2 blocks (differential pairs) of the last feedforward whose pattern from the lossless start was wrong (or
  /// undecided: a branch at rest, no power at a driven joint): solved by the Newton iteration instead (losses.hpp)
  int pair_fallbacks = 0;

  /// Constants motor_torque_feedforward derives from the model, so that the call divides nothing (losses.hpp):
  /// taken by the first call with a model object and again whenever a call gets another one (sized here, no
  /// allocation). Models are not changed once built (bindings, C ABI, model files); code that changes one in
  /// place after it ran calls forget_model().
  struct StaticsConstants {
    const TransmissionModel* model = nullptr;  ///< the model they were taken from (nullptr: none yet)
    Eigen::VectorXd gain_driving;              ///< 1/(η_d n r_d) [1/m]: tension per joint torque, joint driven
    Eigen::VectorXd gain_backdriven;           ///< (2η_d − 1)/(η_d n r_d) [1/m], 0 when self-locking
    Eigen::MatrixXd inv_one_plus_beta, inv_one_minus_beta;  ///< 1/(1 + β), 1/(1 − β) [-], [i, b]
    /// Inverse of each coupled diagonal block of Kᵀ [1/m], [i, j] for i, j in one block (general routings): the
    /// lossless end tensions t_B = (K_Bᵀ)⁻¹ τ_B start the block's Newton iteration.
    Eigen::MatrixXd block_inverse;
    Eigen::VectorXd back_factor;  ///< η_d/(2η_d − 1) [-]: the reducer's back-driven factor (general routings)
    /// Slot of the 2×2 block (differential pair) that begins at joint a in pair_table, −1 for none, [a].
    Eigen::VectorXi pair_slot;
    /// Per 2×2 block, its linear solve for each of its 64 patterns (the pieces of the two branch laws inside the
    /// block × the direction of power at the two driven joints), one column of 8 per pattern: the inverse of the
    /// pattern's 2×2 matrix (4 entries, [1/m]), the two gains of the branch laws' constant terms in joint a's
    /// equation [m], a valid flag (0: singular pattern); column 64 slot + pattern (losses.hpp, solve_pair_direct).
    Eigen::MatrixXd pair_table;
    bool bearings = false;                     ///< some branch has bearings (speed-dependent terms)
  } statics;

  /// The model changed in place: take the constants again at the next call.
  void forget_model() { statics.model = nullptr; }

  explicit TransmissionData(const TransmissionModel& m)
      : q(Eigen::VectorXd::Zero(m.n)), qd(Eigen::VectorXd::Zero(m.n)),
        q_motor(Eigen::VectorXd::Zero(m.n)), qd_motor(Eigen::VectorXd::Zero(m.n)),
        S(Eigen::MatrixXd::Zero(m.n, m.n)), Sdot(Eigen::MatrixXd::Zero(m.n, m.n)),
        tension(Eigen::MatrixXd::Zero(m.n, m.n)), tension_motor(Eigen::VectorXd::Zero(m.n)),
        torque_motor(Eigen::VectorXd::Zero(m.n)), torque_joint(Eigen::VectorXd::Zero(m.n)),
        stuck(Eigen::MatrixXi::Zero(m.n, m.n)), self_locked(Eigen::VectorXi::Zero(m.n)),
        slope(Eigen::MatrixXd::Zero(m.n, m.n)), block_jacobian(Eigen::MatrixXd::Zero(m.n, m.n)),
        block_residual(Eigen::VectorXd::Zero(m.n)), block_step(Eigen::VectorXd::Zero(m.n)) {
    statics.gain_driving.setZero(m.n);
    statics.gain_backdriven.setZero(m.n);
    statics.inv_one_plus_beta.setZero(m.n, m.n);
    statics.inv_one_minus_beta.setZero(m.n, m.n);
    statics.block_inverse.setZero(m.n, m.n);
    statics.back_factor.setZero(m.n);
    statics.pair_slot.setConstant(m.n, -1);
    statics.pair_table.setZero(8, 64 * (m.n / 2));  // at most n/2 pairs
  }
};

template <class Sink>
inline int TransmissionModel::check(Sink&& sink) const {
  int count = 0;
  auto report = [&](const char* field, int i, int j, double value, const char* rule, bool shape = false) {
    ++count;
    ValidationIssue is;
    is.field = field; is.i = i; is.j = j; is.value = value; is.rule = rule; is.shape = shape;
    return sink(is);
  };
  if (n <= 0) { report("n", -1, -1, n, "must be >= 1"); return count; }
  // Shapes first: nothing else can be checked on a wrong shape.
  bool shapes_ok = true;
  for_each_field([&](const FieldInfo& info, const auto& member) {
    if (!shapes_ok) return;
    const bool ok = info.dims == 1 ? (member.rows() == n && member.cols() == 1)
                                   : (member.rows() == n && member.cols() == n);
    if (!ok) {
      shapes_ok = false;
      if (info.dims == 1)
        report(info.name, static_cast<int>(member.size()), -1, n, "must have n entries", true);
      else
        report(info.name, static_cast<int>(member.rows()), static_cast<int>(member.cols()), n,
               "must be (n, n)", true);
    }
  });
  if (!shapes_ok) return count;
  // Every entry finite (above the diagonal too: nothing undefined hides in the model).
  bool go = true;
  for_each_field([&](const FieldInfo& info, const auto& member) {
    for (int i = 0; go && i < member.rows(); ++i)
      for (int j = 0; go && j < member.cols(); ++j)
        if (!std::isfinite(member(i, j))) go = report(info.name, i, info.dims == 1 ? -1 : j, member(i, j), "must be finite");
  });
  if (!go) return count;
  // Every entry within its physical bound (transmission_field_bounds: the device schema's).
  for_each_field([&](const FieldInfo& info, const auto& member) {
    for (const auto& b : transmission_field_bounds) {
      if (!go || std::string_view(b.name) != info.name) continue;
      for (int i = 0; go && i < member.rows(); ++i)
        for (int j = 0; go && j < member.cols(); ++j)
          if (std::abs(member(i, j)) > b.max_abs) go = report(info.name, i, info.dims == 1 ? -1 : j, member(i, j), b.rule);
    }
  });
  if (!go) return count;
  for (int i = 0; i < n && go; ++i) {
    if (!(motor_radius(i) > 0.0)) go = report("motor_radius", i, -1, motor_radius(i), "must be > 0");
    if (go && !(reducer_ratio(i) > 0.0)) go = report("reducer_ratio", i, -1, reducer_ratio(i), "must be > 0");
    if (go && !(reducer_efficiency(i) > 0.0 && reducer_efficiency(i) <= 1.0))
      go = report("reducer_efficiency", i, -1, reducer_efficiency(i), "must be in (0, 1]");
    if (go && !(pretension(i) >= 0.0)) go = report("pretension", i, -1, pretension(i), "must be >= 0");
    const double gen = driven_radius(i) * reducer_ratio(i);
    if (go && !(std::abs(K(i, i) - gen) <= 1e-12 * std::abs(gen)))
      go = report("K", i, i, K(i, i), "must equal driven_radius[i] * reducer_ratio[i]");
  }
  if (!go) return count;
  // The structure computed by update_matrices() must be that of this K (nothing stale reaches the statics).
  if (last_joint.size() != n || block_begin.size() != n || block_end.size() != n)
    return report("K", -1, -1, 0.0, "update_matrices() was not called after K was set"), count;
  for (int i = 0; i < n && go; ++i)
    if (last_joint(i) != last_joint_of(i))
      go = report("K", i, last_joint_of(i), K(i, last_joint_of(i)), "changed after update_matrices(): call it again");
  if (!go) return count;
  if (dependent_transmission >= 0) {
    const int i = dependent_transmission;
    if (driven_radius(i) == 0.0)
      return report("driven_radius", i, -1, 0.0, "must be nonzero here (a zero driven radius makes the routing "
                    "singular: the row of K of this transmission depends on the rows before it)"), count;
    return report("K", i, -1, K(i, i), "the row of K of this transmission depends on the rows before it (singular "
                  "routing: K has no inverse)"), count;
  }
  // K (R_m⁻¹ ... ) taken at update_matrices(): K · joint_from_motor_position = R_m, or K changed since.
  for (int i = 0; i < n && go; ++i)
    for (int j = 0; j < n && go; ++j) {
      double s = 0.0, mag = 0.0;
      for (int k = 0; k < n; ++k) {
        s += K(i, k) * joint_from_motor_position(k, j);
        mag += std::abs(K(i, k) * joint_from_motor_position(k, j));
      }
      const double want = i == j ? motor_radius(i) : 0.0;
      if (!(std::abs(s - want) <= 1e-9 * (mag + std::abs(want))))
        go = report("K", i, j, K(i, j), "changed after update_matrices() (or motor_radius did): call it again");
    }
  if (!go) return count;
  for (int i = 0; i < n && go; ++i) {
    // A reducer sits in the driven pulley, where the cable ends: a cable that goes on to later joints has none.
    if (last_joint(i) > i && (reducer_ratio(i) != 1.0 || reducer_efficiency(i) != 1.0))
      go = report(reducer_ratio(i) != 1.0 ? "reducer_ratio" : "reducer_efficiency", i, -1,
                  reducer_ratio(i) != 1.0 ? reducer_ratio(i) : reducer_efficiency(i),
                  "must be 1: the cable wraps joints after its driven joint (a differential), so its driven pulley "
                  "holds no reducer");
    if (go && !serial && reducer_efficiency(i) <= 0.5)
      go = report("reducer_efficiency", i, -1, reducer_efficiency(i),
                  "must be > 0.5 in a routing that is not serial (self-locking reducers are modelled for serial "
                  "routings only)");
  }
  for (int i = 0; i < n && go; ++i)
    for (int b = 0; b <= last_joint(i) && go; ++b) {
      if (!(tau0(i, b) >= 0.0)) go = report("tau0", i, b, tau0(i, b), "must be >= 0");
      if (go && !(nu(i, b) >= 0.0)) go = report("nu", i, b, nu(i, b), "must be >= 0");
      if (go && !(beta(i, b) >= 0.0)) go = report("beta", i, b, beta(i, b), "must be >= 0");
      if (go && !(beta(i, b) < 1.0)) go = report("beta", i, b, beta(i, b), "must be < 1 (no tension passes the branch)");
      const double count_b = bearing_count(i, b);
      if (go && !(count_b >= 0.0 && count_b == std::floor(count_b)))
        go = report("bearing_count", i, b, count_b, "must be an integer >= 0");
      if (!go || count_b == 0.0) continue;
      if (!(bearing_radius(i, b) > 0.0)) go = report("bearing_radius", i, b, bearing_radius(i, b), "must be > 0");
      if (go && !(bearing_wrap(i, b) > 0.0 && bearing_wrap(i, b) <= 6.283185307179586))
        go = report("bearing_wrap", i, b, bearing_wrap(i, b), "must be in (0, 2*pi]");
      if (go && !(bearing_static_coefficient(i, b) >= 0.0))
        go = report("bearing_static_coefficient", i, b, bearing_static_coefficient(i, b), "must be >= 0");
      if (go && !(bearing_dynamic_coefficient(i, b) >= 0.0))
        go = report("bearing_dynamic_coefficient", i, b, bearing_dynamic_coefficient(i, b), "must be >= 0");
      if (go && !(bearing_h0(i, b) >= 0.0)) go = report("bearing_h0", i, b, bearing_h0(i, b), "must be >= 0");
      if (go && !(bearing_h1(i, b) >= 0.0)) go = report("bearing_h1", i, b, bearing_h1(i, b), "must be >= 0");
      if (go && !(bearing_n0(i, b) >= 0.0)) go = report("bearing_n0", i, b, bearing_n0(i, b), "must be >= 0");
      if (!go) break;
      // Tension-proportional friction must stay below 1, or no tension passes the branch.
      const double k = 2.0 * std::sin(0.5 * bearing_wrap(i, b)) / bearing_radius(i, b);
      const double coef = std::max(bearing_static_coefficient(i, b), bearing_dynamic_coefficient(i, b));
      const double total = beta(i, b) + count_b * coef * k;
      if (!(total < 1.0))
        go = report("beta+bearing", i, b, total,
                    "beta + bearing_count * max(static, dynamic coefficient) * 2 sin(wrap/2) / radius must be < 1");
    }
  return count;
}

// ---- kinematics (S0 eqs. 1–2, corrected) ---------------------------------------------------

/// q = K⁻¹ R_m q_m by forward substitution (the recursion of S0 eq. 2, driven joint by driven joint).
/// Writes data.q_motor (copy of the input) and data.q.
template <class VecIn>
inline Status joint_from_motor(const TransmissionModel& m, TransmissionData& d, const VecIn& q_motor) {
  if (q_motor.size() != m.n) return Status::SizeMismatch;
  if (!all_finite(q_motor)) return Status::NonFiniteInput;
  if (!m.serial) {  // general routing: q = K⁻¹ R_m q_m with the inverse taken at setup
    for (int i = 0; i < m.n; ++i) d.q_motor(i) = q_motor(i);
    for (int i = 0; i < m.n; ++i) {
      double s = 0.0;
      for (int j = 0; j < m.n; ++j) s += m.joint_from_motor_position(i, j) * q_motor(j);
      d.q(i) = s;
    }
    return Status::Ok;
  }
  for (int i = 0; i < m.n; ++i) {
    double s = m.motor_radius(i) * q_motor(i);  // S_0^i
    for (int j = 0; j < i; ++j) s -= m.K(i, j) * d.q(j);
    d.q_motor(i) = q_motor(i);
    d.q(i) = s / m.K(i, i);
  }
  return Status::Ok;
}

/// q_m = R_m⁻¹ K q. Writes data.q (copy) and data.q_motor.
template <class VecIn>
inline Status motor_from_joint(const TransmissionModel& m, TransmissionData& d, const VecIn& q) {
  if (q.size() != m.n) return Status::SizeMismatch;
  if (!all_finite(q)) return Status::NonFiniteInput;
  for (int i = 0; i < m.n; ++i) d.q(i) = q(i);
  for (int i = 0; i < m.n; ++i) {
    double s = 0.0;
    for (int j = 0; j <= m.last_joint(i); ++j) s += m.K(i, j) * q(j);
    d.q_motor(i) = s / m.motor_radius(i);
  }
  return Status::Ok;
}

/// Branch displacements S[i, b] [m] from data.q_motor and data.q (call a position map first):
/// S[i,0] = r_m q_m, S[i,b] = S[i,b−1] − K(i,b−1) q_{b−1}; consistency S[i,i] = K(i,i) q_i.
inline void branch_displacements(const TransmissionModel& m, TransmissionData& d) {
  for (int i = 0; i < m.n; ++i) {
    d.S(i, 0) = m.motor_radius(i) * d.q_motor(i);
    for (int b = 1; b <= m.last_joint(i); ++b) d.S(i, b) = d.S(i, b - 1) - m.K(i, b - 1) * d.q(b - 1);
  }
}

/// Sizes the real-time calls are compiled for with a fixed n (loops unrolled, no loop-bound branches);
/// any other n takes the same code with a run-time n. Same operations in the same order either way.
constexpr int kMaxFixedTransmissions = 6;

/// Call f(std::integral_constant<int, N>) with N = m.n when 1 ≤ n ≤ kMaxFixedTransmissions, N = 0 (run-time n)
/// otherwise.
template <class F>
inline auto dispatch_size(int n, F&& f) {
  switch (n) {
    case 1: return f(std::integral_constant<int, 1>{});
    case 2: return f(std::integral_constant<int, 2>{});
    case 3: return f(std::integral_constant<int, 3>{});
    case 4: return f(std::integral_constant<int, 4>{});
    case 5: return f(std::integral_constant<int, 5>{});
    case 6: return f(std::integral_constant<int, 6>{});
    default: return f(std::integral_constant<int, 0>{});
  }
}

/// dispatch_size for a serial routing; N = 0 (run-time n, general routing) otherwise.
template <class F>
inline auto dispatch_routing(const TransmissionModel& m, F&& f) {
  if (!m.serial) return f(std::integral_constant<int, 0>{});
  return dispatch_size(m.n, std::forward<F>(f));
}

namespace detail {
/// velocities_from_joint for N transmissions (N = 0: m.n at run time); inputs already checked.
template <int N, class VecIn>
inline void velocities_from_joint_n(const TransmissionModel& m, TransmissionData& d, const VecIn& qd) {
  const int n = N > 0 ? N : m.n;
  const double* K = m.K.data();  // column-major, leading dimension n, as Sdot
  double* Sdot = d.Sdot.data();
#pragma GCC unroll 8
  for (int i = 0; i < n; ++i) d.qd(i) = qd(i);
#pragma GCC unroll 8
  for (int i = 0; i < n; ++i) {
    // Ṡ_b = Σ_{l≥b} K_il q̇_l, summed from the driven joint toward the motor (Ṡ_b = K_ib q̇_b + Ṡ_{b+1}), not
    // Ṡ_{b−1} − K_i,b−1 q̇_{b−1} from the motor: a branch beyond every moving joint comes out exactly 0, or the
    // statics would treat it as sliding (stuck test Ṡ = 0). Ṡ_0 = r_m q̇_m (S0 eq. 1).
    double s = 0.0;
    const int last = N > 0 ? i : m.last_joint(i);  // a fixed N is a serial routing (dispatch_routing)
#pragma GCC unroll 8
    for (int b = last; b >= 0; --b) {
      s += K[i + b * n] * qd(b);
      Sdot[i + b * n] = s;
    }
    d.qd_motor(i) = s / m.motor_radius(i);
  }
}
}  // namespace detail

/// Joint velocities → motor and branch velocities (same linear maps as positions).
/// Writes data.qd, data.qd_motor, data.Sdot.
template <class VecIn>
inline Status velocities_from_joint(const TransmissionModel& m, TransmissionData& d, const VecIn& qd) {
  if (qd.size() != m.n) return Status::SizeMismatch;
  if (!all_finite(qd)) return Status::NonFiniteInput;
  dispatch_routing(m, [&](auto N) { detail::velocities_from_joint_n<decltype(N)::value>(m, d, qd); });
  return Status::Ok;
}

// ---- lossless statics (S0 eqs. 4–5, corrected) ------------------------------------------------

/// Lossless: joint torques wanted → tensions t = K⁻ᵀ τ_J (back substitution from the distal joint)
/// → motor torques C_m = R_m t. Writes data.tension_motor (= t), data.torque_joint, data.torque_motor.
template <class VecIn>
inline Status motor_torque_lossless(const TransmissionModel& m, TransmissionData& d, const VecIn& torque_joint) {
  if (torque_joint.size() != m.n) return Status::SizeMismatch;
  if (!all_finite(torque_joint)) return Status::NonFiniteInput;
  if (!m.serial) {  // general routing: t = K⁻ᵀ τ_J = R_m⁻¹ (R_m K⁻ᵀ) τ_J
    for (int i = 0; i < m.n; ++i) {
      double s = 0.0;
      for (int j = 0; j < m.n; ++j) s += m.motor_from_joint_torque(i, j) * torque_joint(j);
      d.torque_motor(i) = s;
      d.tension_motor(i) = s / m.motor_radius(i);
      d.torque_joint(i) = torque_joint(i);
    }
    return Status::Ok;
  }
  for (int j = m.n - 1; j >= 0; --j) {
    double s = torque_joint(j);  // S0 eq. 4: C_j = Σ_{k≥j} τ_k r_j^k
    for (int k = j + 1; k < m.n; ++k) s -= m.K(k, j) * d.tension_motor(k);
    d.tension_motor(j) = s / m.K(j, j);
  }
  for (int i = 0; i < m.n; ++i) {
    d.torque_joint(i) = torque_joint(i);
    d.torque_motor(i) = m.motor_radius(i) * d.tension_motor(i);
  }
  return Status::Ok;
}

/// Lossless: motor torques → tensions t = R_m⁻¹ C_m → joint torques τ_J = Kᵀ t.
template <class VecIn>
inline Status joint_torque_lossless(const TransmissionModel& m, TransmissionData& d, const VecIn& torque_motor) {
  if (torque_motor.size() != m.n) return Status::SizeMismatch;
  if (!all_finite(torque_motor)) return Status::NonFiniteInput;
  for (int i = 0; i < m.n; ++i) {
    d.torque_motor(i) = torque_motor(i);
    d.tension_motor(i) = torque_motor(i) / m.motor_radius(i);
  }
  for (int j = 0; j < m.n; ++j) {
    double s = 0.0;
    for (int k = 0; k < m.n; ++k)
      if (k >= j || m.last_joint(k) >= j) s += m.K(k, j) * d.tension_motor(k);  // serial: k ≥ j only
    d.torque_joint(j) = s;
  }
  return Status::Ok;
}

}  // namespace tendyn
