// tendyn — the McGill 2N tendon bench (S1): time-domain twin of one tendon channel.
//
// Units: tendon-linear at the driven-pulley rim, SI (m, N, kg, N/m, N·s/m). All positions are measured
// along ONE load axis x: positive x is the direction in which motor A pulls the load. Motor A's position
// x_a grows when A reels its tendon in; motor B's position x_b grows when B pays its tendon out (so B
// reels in towards −x). At rest everything is at 0 and both tendons carry the pretension T_pre.
//
// Structure (DEVICES.md §2, ERRATA S1). Two motors, each pulling its own tension-only tendon:
//
//   motor A (m1/2, c1/2) ──k1/2── s_a ──k2/2──┐
//                                              load I_c ──k_z── ground
//   motor B (m1/2, c1/2) ──k1/2── s_b ──k2/2──┘
//
// Tendon tension (series k1/2 + k2/2 = k_e/2 per tendon, k_e = k1 k2/(k1 + k2)):
//   T_a = max(0, T_pre + (k_e/2)(x_a − x_load)),   T_b = max(0, T_pre + (k_e/2)(x_load − x_b)).
// A tendon goes slack (T = 0), it never pushes. The sensing points s_a, s_b between the k1 and k2
// sections are massless; force balance (k1/2)(x_a − s_a + 2T_pre/k1) = (k2/2)(s_a − x_load + 2T_pre/k2)
// gives s_a = (k1 x_a + k2 x_load)/(k1 + k2) (the pretension cancels), likewise s_b. A slack tendon keeps
// the same relation (its sensing point is not defined by force balance; this keeps X_t continuous).
// Sensor: F_m = T_a − T_b (differential tendon force), X_t = (s_a + s_b)/2.
//
// Amplifier (class B): one current command u [N at the rim], optionally through a first-order lag,
// split by the clamping diodes: motor A pulls with F_pre + max(u, 0) towards +x, motor B with
// F_pre + max(−u, 0) towards −x; the bias F_pre = T_pre balances the pretension at rest. Net drive: u.
//
// Equations of motion (friction λ_a, λ_b at the motor/tendon nodes, see below):
//   (m1/2) ẍ_a = F_pre + max(u,0)  − T_a − (c1/2) ẋ_a − λ_a
//   (m1/2) ẍ_b = −F_pre − max(−u,0) + T_b − (c1/2) ẋ_b − λ_b
//   I_c ẍ_load = T_a − T_b − k_z x_load
//
// WHY the halves reproduce eq. (2) of S1 exactly. With both tendons taut and no friction, let
// x1 = (x_a + x_b)/2 (differential mode). Adding the two motor equations:
//   (m1/2)(ẍ_a + ẍ_b) = [max(u,0) − max(−u,0)] − (T_a − T_b) − (c1/2)(ẋ_a + ẋ_b)
//   ⇒ m1 ẍ1 = u − c1 ẋ1 − k_e (x1 − x_load)          (T_a − T_b = (k_e/2)(x_a + x_b − 2 x_load))
//   and I_c ẍ_load = k_e (x1 − x_load) − k_z x_load,  F_m = T_a − T_b = k_e (x1 − x_load),
// which is the two-mass chain of eq. (2): mass r²I_M = m1, damper r²B = c1, spring k_e, load I_c, k_z.
// The two tendons (k_e/2 each) act in parallel on the differential motion (k_e/2 + k_e/2 = k_e), and
// each motor's half mass and half damper add up likewise. The common mode (x_a − x_b)/2 is driven by
// 2F_pre + |u| against 2T_pre + (k_e/2)(x_a − x_b) and is decoupled from the differential mode while
// both tendons are taut; it matters only through slack and through tension-dependent friction.
//
// Friction [ASSUMPTION, DEVICES.md §2]: Coulomb at each motor/tendon node, F_c = F_c0 + μ_T T (T the
// tension of that node's tendon at the start of the step), static limit = the same F_c (no stiction
// peak, no Stribeck), and TRUE stick–slip (no smoothing). Velocity-level time stepping (Moreau): per
// node, p = v + (h/m)(F_applied − T) is the velocity the node would reach without friction (damping is
// implicit: v⁺ = (p − (h/m) λ)/(1 + h c/m)). If |p| ≤ (h/m) F_c friction cancels it: the node sticks,
// v⁺ = 0 exactly and its position is bit-for-bit unchanged. Otherwise λ = F_c sign(p) (slip).
// Consequence of the class-B split with Coulomb nodes (not programmed, it follows): each motor sees only
// its half-wave; after the first half-wave a node sticks at an offset and moves again only if the
// half-wave swing exceeds 2 F_c, so a sine of amplitude A gives no AC output below A ≈ 2 F_c (dead-band),
// and just above it the friction-dominated response peaks well below the 30 Hz linear resonance (C22).
// Integrator: semi-implicit (symplectic) Euler: velocities first, then positions x⁺ = x + h v⁺.
//
// Load: if k_z ≥ Model::clamp_stiffness (default 1e7 N/m) the load is treated as CLAMPED
// (x_load ≡ 0): 1e9 N/m on 0.05 kg rings at 22 kHz, above the 20 kHz step rate, and its effect below
// 100 Hz is of relative order k_e/k_z ≤ 2e-3. Otherwise the load is integrated with symplectic Euler
// with n_sub sub-steps chosen so that ω_load h/n_sub ≤ 0.2
// (ω_load = sqrt((k_z + k_e)/I_c)); the motor positions are held at their start-of-step values over the
// sub-steps. With n_sub = 1 every force of the step comes from the start-of-step positions (plain
// symplectic Euler), which keeps the discrete load equation I_c Δ²x_load/h² = F_m − k_z x_load centred,
// so the anti-resonance sqrt(k_z/I_c) of eq. (2) is reproduced to O(h²).
//
// Noise: optional Gaussian noise on F_m and X_t from a seeded xoshiro256** generator (seeded with
// splitmix64) and Box–Muller: same seed ⇒ bit-identical output on the same build and platform.
//
// Model / Data convention: TendonBenchModel is plain data; TendonBenchData(model) holds state, derived
// constants and outputs; step / run (overloads on TendonBenchModel) never allocate and never throw.
#pragma once

#include "tendyn/status.hpp"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

namespace tendyn {

// The parameter table of TendonBenchModel: X(name, default, unit, lower bound kind, doc), in order.
// Bound kind: Positive (> 0) or NonNegative (>= 0); every value must be finite. The struct members,
// the bindings (properties that re-validate on every write), validate() and the test that compares
// the defaults with Python's TendonBench (python/tendyn/device/tendon_bench.py) derive from this list.
// The file fields of [bench] are the rows up to noise_position; dt and clamp_stiffness are simulator
// settings, not device-file fields. The optional file field peak_force (the actuators' limit) is no plant
// parameter: Python's BENCH_OPTIONAL, read by the commands, not mirrored here.
#define TENDYN_TENDON_BENCH_FIELDS(X)                                                                  \
  X(ratio, 15.0, "-", Positive, "pulley ratio r (informational: the values below are at the rim)")       \
  X(k1, 2.566e4, "N/m", Positive, "proximal stiffness of the channel (each tendon k1/2)")              \
  X(k2, 1.0e5, "N/m", Positive, "distal stiffness of the channel (each tendon k2/2)")                  \
  X(mass_motor, 0.575, "kg", Positive, "m1 = r^2 I_M of the channel (each motor m1/2)")                \
  X(damping_motor, 10.8, "N s/m", NonNegative, "c1 = r^2 B of the channel (each motor c1/2)")          \
  X(mass_load, 0.05, "kg", Positive, "load inertia I_c")                                               \
  X(k_z, 1.0e9, "N/m", NonNegative, "load spring to ground")                                           \
  X(pretension, 5.0, "N", NonNegative, "T_pre per tendon at rest (= amplifier bias F_pre)")            \
  X(friction_c0, 0.1, "N", NonNegative, "Coulomb friction F_c0 per motor node at zero tension")        \
  X(friction_mu_tension, 0.005, "-", NonNegative, "friction mu_T per newton of tendon tension")        \
  X(amplifier_lag, 0.0, "s", NonNegative, "first-order lag of the current amplifier, 0 = ideal")       \
  X(noise_force, 0.0, "N", NonNegative, "sensor noise on F_m, rms")                                    \
  X(noise_position, 0.0, "m", NonNegative, "sensor noise on X_t, rms")                                 \
  X(dt, 5.0e-5, "s", Positive, "fixed step (default 20 kHz)")                                          \
  X(clamp_stiffness, 1.0e7, "N/m", Positive, "k_z at or above which the load is clamped")

/// Lower bound of a tendon bench parameter.
enum class Bound { Positive, NonNegative };

/// One row of the tendon bench parameter table.
struct BenchFieldInfo {
  const char* name;
  double default_value;
  const char* unit;
  Bound bound;
  const char* doc;
};

#define TENDYN_BENCH_FIELD_INFO(name, def, unit, bound, doc) BenchFieldInfo{#name, def, unit, Bound::bound, doc},
inline constexpr BenchFieldInfo tendon_bench_fields[] = {TENDYN_TENDON_BENCH_FIELDS(TENDYN_BENCH_FIELD_INFO)};
#undef TENDYN_BENCH_FIELD_INFO

/// Parameters of one 2N tendon channel (channel-equivalent values, rim units). Members, units and
/// defaults: TENDYN_TENDON_BENCH_FIELDS above.
struct TendonBenchModel {
#define TENDYN_BENCH_MEMBER(name, def, unit, bound, doc) double name = def;
  TENDYN_TENDON_BENCH_FIELDS(TENDYN_BENCH_MEMBER)
#undef TENDYN_BENCH_MEMBER

  /// k_e = k1 k2/(k1 + k2) [N/m] (S1 eq. 1).
  double k_e() const { return k1 * k2 / (k1 + k2); }
  /// Whether the load is treated as clamped (k_z ≥ clamp_stiffness).
  bool load_clamped() const { return k_z >= clamp_stiffness; }

  /// The first invalid field (non-finite, or outside its bound), or nullptr. No allocation.
  const BenchFieldInfo* first_issue() const {
    const double values[] = {
#define TENDYN_BENCH_VALUE(name, def, unit, bound, doc) name,
        TENDYN_TENDON_BENCH_FIELDS(TENDYN_BENCH_VALUE)
#undef TENDYN_BENCH_VALUE
    };
    for (std::size_t k = 0; k < sizeof(values) / sizeof(values[0]); ++k) {
      const double v = values[k];
      const bool ok = std::isfinite(v) && (tendon_bench_fields[k].bound == Bound::Positive ? v > 0.0 : v >= 0.0);
      if (!ok) return &tendon_bench_fields[k];
    }
    return nullptr;
  }

  /// InvalidModel if a value is non-finite or out of range (first_issue() names it).
  Status validate() const { return first_issue() ? Status::InvalidModel : Status::Ok; }
};

/// State, derived constants and outputs of one channel. Built from a model; no allocation afterwards.
struct TendonBenchData {
  // --- state (positions [m], velocities [m/s] along the load axis) ---
  double x_a = 0.0, v_a = 0.0;         ///< motor A (+ = reels in)
  double x_b = 0.0, v_b = 0.0;         ///< motor B (+ = pays out)
  double x_load = 0.0, v_load = 0.0;   ///< load
  double u_amp = 0.0;                  ///< [N] amplifier output (after the lag)
  double time = 0.0;                   ///< [s]
  std::uint64_t steps = 0;             ///< steps taken since reset

  // --- outputs of the last step ---
  double tension_a = 0.0, tension_b = 0.0;   ///< [N] tendon tensions (≥ 0)
  double friction_a = 0.0, friction_b = 0.0; ///< [N] friction force on each node (along +x of the node eq.)
  bool stuck_a = true, stuck_b = true;       ///< node stuck during the last step
  double force_true = 0.0;                   ///< [N] T_a − T_b without noise
  double position_true = 0.0;                ///< [m] X_t without noise
  double force_measured = 0.0;               ///< [N] F_m with sensor noise
  double position_measured = 0.0;            ///< [m] X_t with sensor noise

  // --- derived constants (set by reset) ---
  double h = 0.0;            ///< [s] step
  double m_node = 0.0;       ///< [kg] mass of one motor node (m1/2)
  double c_node = 0.0;       ///< [N·s/m] damping of one motor node (c1/2)
  double k_tendon = 0.0;     ///< [N/m] series stiffness of one tendon (k_e/2)
  double w_prox = 0.0;       ///< k1/(k1 + k2): weight of the motor in the sensing-point position
  double lag_alpha = 1.0;    ///< amplifier update factor 1 − exp(−h/τ) (1 = ideal)
  double lag_mean = 0.0;     ///< (τ/h)(1 − exp(−h/τ)): weight of the old output in the step mean (0 = ideal)
  int n_sub = 1;             ///< load sub-steps per step
  bool clamped = true;       ///< load clamped

  // --- noise generator (xoshiro256**) ---
  std::uint64_t rng[4] = {0, 0, 0, 0};
  bool has_spare = false;
  double spare = 0.0;

  TendonBenchData() = default;
  explicit TendonBenchData(const TendonBenchModel& model, std::uint64_t seed = 0);
};

namespace detail {

inline std::uint64_t splitmix64(std::uint64_t& s) {
  std::uint64_t z = (s += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

inline std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

inline std::uint64_t xoshiro_next(std::uint64_t* s) {
  const std::uint64_t result = rotl(s[1] * 5, 7) * 9;
  const std::uint64_t t = s[1] << 17;
  s[2] ^= s[0];
  s[3] ^= s[1];
  s[1] ^= s[2];
  s[0] ^= s[3];
  s[2] ^= t;
  s[3] = rotl(s[3], 45);
  return result;
}

/// Uniform in (0, 1): 53 random bits, never 0.
inline double uniform_open(std::uint64_t* s) {
  return (static_cast<double>(xoshiro_next(s) >> 11) + 0.5) * (1.0 / 9007199254740992.0);
}

/// Standard normal (Box–Muller, polar-free form; the second value is kept for the next call).
inline double standard_normal(TendonBenchData& d) {
  if (d.has_spare) {
    d.has_spare = false;
    return d.spare;
  }
  const double u1 = uniform_open(d.rng);
  const double u2 = uniform_open(d.rng);
  const double rad = std::sqrt(-2.0 * std::log(u1));
  const double ang = 6.283185307179586 * u2;
  d.spare = rad * std::sin(ang);
  d.has_spare = true;
  return rad * std::cos(ang);
}

inline double tension(double pre, double k, double stretch) {
  const double t = pre + k * stretch;
  return t > 0.0 ? t : 0.0;
}

/// One motor node, velocity-level Coulomb stick/slip with implicit damping.
/// `f` is the applied force along the node axis minus the tendon force; returns v⁺, writes friction.
inline double node_velocity(double v, double f, double fc, double m, double c, double h,
                            double& friction, bool& stuck) {
  const double p = v + (h / m) * f;  // velocity reached without friction (before damping)
  const double pc = (h / m) * fc;    // velocity friction can remove in one step
  if (std::fabs(p) <= pc) {
    friction = (m / h) * p;  // friction cancels p exactly: stick
    stuck = true;
    return 0.0;
  }
  const double lam = p > 0.0 ? fc : -fc;
  friction = lam;
  stuck = false;
  return (p - (h / m) * lam) / (1.0 + h * c / m);
}

inline void update_outputs(const TendonBenchModel& m, TendonBenchData& d) {
  d.tension_a = tension(m.pretension, d.k_tendon, d.x_a - d.x_load);
  d.tension_b = tension(m.pretension, d.k_tendon, d.x_load - d.x_b);
  d.force_true = d.tension_a - d.tension_b;
  const double s_a = d.w_prox * d.x_a + (1.0 - d.w_prox) * d.x_load;
  const double s_b = d.w_prox * d.x_b + (1.0 - d.w_prox) * d.x_load;
  d.position_true = 0.5 * (s_a + s_b);
  d.force_measured = d.force_true;
  d.position_measured = d.position_true;
  if (m.noise_force > 0.0) d.force_measured += m.noise_force * standard_normal(d);
  if (m.noise_position > 0.0) d.position_measured += m.noise_position * standard_normal(d);
}

}  // namespace detail

/// Reset the state to rest (both tendons at T_pre), recompute the derived constants and reseed.
inline Status reset(const TendonBenchModel& m, TendonBenchData& d, std::uint64_t seed) {
  const Status s = m.validate();
  if (is_error(s)) return s;
  d.x_a = d.v_a = d.x_b = d.v_b = d.x_load = d.v_load = 0.0;
  d.u_amp = 0.0;
  d.time = 0.0;
  d.steps = 0;
  d.friction_a = d.friction_b = 0.0;
  d.stuck_a = d.stuck_b = true;
  d.h = m.dt;
  d.m_node = 0.5 * m.mass_motor;
  d.c_node = 0.5 * m.damping_motor;
  d.k_tendon = 0.5 * m.k_e();
  d.w_prox = m.k1 / (m.k1 + m.k2);
  d.lag_alpha = m.amplifier_lag > 0.0 ? -std::expm1(-m.dt / m.amplifier_lag) : 1.0;
  d.lag_mean = m.amplifier_lag > 0.0 ? (m.amplifier_lag / m.dt) * d.lag_alpha : 0.0;
  d.clamped = m.load_clamped();
  if (d.clamped) {
    d.n_sub = 1;
  } else {
    const double w = std::sqrt((m.k_z + m.k_e()) / m.mass_load);
    const double n = std::ceil(w * m.dt / 0.2);
    d.n_sub = n < 1.0 ? 1 : static_cast<int>(n);
  }
  std::uint64_t sm = seed;
  for (auto& r : d.rng) r = detail::splitmix64(sm);
  d.has_spare = false;
  d.spare = 0.0;
  detail::update_outputs(m, d);
  return Status::Ok;
}

inline TendonBenchData::TendonBenchData(const TendonBenchModel& model, std::uint64_t seed) {
  reset(model, *this, seed);
}

/// Advance one step of length model.dt with the current command u [N at the rim]. Writes the state and
/// the outputs (tensions, F_m, X_t with noise) of the end of the step into d. No allocation.
inline Status step(const TendonBenchModel& m, TendonBenchData& d, double u) {
  if (!std::isfinite(u)) return Status::NonFiniteInput;
  const double h = d.h;
  // Amplifier: exact first-order lag for a command held over the step; the motors get the MEAN of the
  // lag output over the step (no half-step bias), u_amp keeps its end-of-step value. Then the class-B split.
  const double u_step = u + (d.u_amp - u) * d.lag_mean;
  d.u_amp += d.lag_alpha * (u - d.u_amp);
  const double ua = u_step > 0.0 ? u_step : 0.0;
  const double ub = u_step < 0.0 ? -u_step : 0.0;
  const double f_a = m.pretension + ua;   // motor A pulls towards +x
  const double f_b = m.pretension + ub;   // motor B pulls towards −x

  // Tensions at the start of the step.
  const double t_a = detail::tension(m.pretension, d.k_tendon, d.x_a - d.x_load);
  const double t_b = detail::tension(m.pretension, d.k_tendon, d.x_load - d.x_b);

  // Motor nodes: velocity-level stick/slip with the forces of the start of the step.
  const double fc_a = m.friction_c0 + m.friction_mu_tension * t_a;
  const double fc_b = m.friction_c0 + m.friction_mu_tension * t_b;
  d.v_a = detail::node_velocity(d.v_a, f_a - t_a, fc_a, d.m_node, d.c_node, h, d.friction_a, d.stuck_a);
  d.v_b = detail::node_velocity(d.v_b, t_b - f_b, fc_b, d.m_node, d.c_node, h, d.friction_b, d.stuck_b);

  // Load: clamped, or symplectic Euler with the motors at their start-of-step positions (so that with
  // n_sub = 1 the whole step is plain symplectic Euler: every force from the start-of-step positions).
  if (!d.clamped) {
    const double hs = h / d.n_sub;
    for (int i = 0; i < d.n_sub; ++i) {
      const double ta = detail::tension(m.pretension, d.k_tendon, d.x_a - d.x_load);
      const double tb = detail::tension(m.pretension, d.k_tendon, d.x_load - d.x_b);
      d.v_load += (hs / m.mass_load) * (ta - tb - m.k_z * d.x_load);
      d.x_load += hs * d.v_load;
    }
  }
  // Motor positions last (a stuck node keeps its position bit for bit: v = 0 exactly).
  d.x_a += h * d.v_a;
  d.x_b += h * d.v_b;

  d.steps += 1;
  d.time = static_cast<double>(d.steps) * h;
  detail::update_outputs(m, d);
  return Status::Ok;
}

/// Run a whole command sequence u[0..n) (one value per step) from the current state and write, per step,
/// the end-of-step outputs. Any output pointer may be null (not written). No allocation.
/// Stops at the first non-finite command and returns NonFiniteInput (earlier samples are written).
inline Status run(const TendonBenchModel& m, TendonBenchData& d, const double* u, std::int64_t n,
                               double* force_measured, double* position_measured, double* x_a,
                               double* x_b, double* x_load, double* tension_a, double* tension_b) {
  if (n < 0) return Status::SizeMismatch;
  for (std::int64_t i = 0; i < n; ++i) {
    const Status s = step(m, d, u[i]);
    if (is_error(s)) return s;
    if (force_measured) force_measured[i] = d.force_measured;
    if (position_measured) position_measured[i] = d.position_measured;
    if (x_a) x_a[i] = d.x_a;
    if (x_b) x_b[i] = d.x_b;
    if (x_load) x_load[i] = d.x_load;
    if (tension_a) tension_a[i] = d.tension_a;
    if (tension_b) tension_b[i] = d.tension_b;
  }
  return Status::Ok;
}


// ---- discrete-time controller in the bench loop (S1 §4: proportional, C = L/P̂) ---------------------
//
// Any proper C(z) of order ≤ BenchControllerModel::max_order as a state-space realisation
//   x[j+1] = A x[j] + B e[j],   u[j] = C x[j] + D e[j],   e[j] = r[j] − F_m,measured[j]
// (unity negative feedback on the SENSED tendon force, noise included). It runs every `decimation`
// bench steps (control rate = 1/(decimation · dt)); u is held in between (zero-order hold). F_m is the
// sensor output at the end of the previous bench step, i.e. sampled at the control instant; r is the
// reference of the step that starts the control period. The command is limited to ±u_limit [N]
// (amplifier saturation, inf = none). Fixed storage: no allocation, no exception.

/// A discrete-time LTI controller C(z) in state-space form (fixed storage, row-major A).
struct BenchControllerModel {
  static constexpr int max_order = 16;
  int order = 0;                      ///< number of states n (0 = static gain D)
  double A[max_order * max_order] = {};  ///< [-] n × n, row-major (A[i*max_order + j])
  double B[max_order] = {};           ///< [1/N·state] n
  double C[max_order] = {};           ///< [N/state] n
  double D = 0.0;                     ///< [-] feed-through (N of command per N of force error)
  int decimation = 1;                 ///< bench steps per control period (≥ 1)
  double u_limit = std::numeric_limits<double>::infinity();  ///< [N] |u| ≤ u_limit (> 0)

  /// InvalidModel if the order or decimation is out of range, a matrix entry is non-finite or
  /// u_limit ≤ 0 / NaN. No allocation.
  Status validate() const {
    if (order < 0 || order > max_order || decimation < 1) return Status::InvalidModel;
    if (!std::isfinite(D) || !(u_limit > 0.0)) return Status::InvalidModel;
    for (int i = 0; i < order; ++i) {
      if (!std::isfinite(B[i]) || !std::isfinite(C[i])) return Status::InvalidModel;
      for (int j = 0; j < order; ++j)
        if (!std::isfinite(A[i * max_order + j])) return Status::InvalidModel;
    }
    return Status::Ok;
  }
};

/// State of a BenchControllerModel: controller state, held command, last error.
struct BenchControllerData {
  double x[BenchControllerModel::max_order] = {};   ///< controller state
  double x_next[BenchControllerModel::max_order] = {};  ///< scratch of the update
  double u = 0.0;       ///< [N] command held over the current control period
  double error = 0.0;   ///< [N] r − F_m,measured at the last control instant
  int phase = 0;        ///< bench steps since the last control instant (0 = update now)
  bool saturated = false;  ///< the last update hit ±u_limit

  BenchControllerData() = default;
  explicit BenchControllerData(const BenchControllerModel&) {}
};

/// Zero the controller state and the held command.
inline Status reset(const BenchControllerModel& c, BenchControllerData& cd) {
  const Status s = c.validate();
  if (is_error(s)) return s;
  for (int i = 0; i < BenchControllerModel::max_order; ++i) cd.x[i] = cd.x_next[i] = 0.0;
  cd.u = cd.error = 0.0;
  cd.phase = 0;
  cd.saturated = false;
  return Status::Ok;
}

/// One control update with the error e [N]: u = C x + D e (limited), x ← A x + B e. No allocation.
inline Status controller_update(const BenchControllerModel& c, BenchControllerData& cd, double e) {
  if (!std::isfinite(e)) return Status::NonFiniteInput;
  const int n = c.order;
  double u = c.D * e;
  for (int i = 0; i < n; ++i) u += c.C[i] * cd.x[i];
  for (int i = 0; i < n; ++i) {
    double v = c.B[i] * e;
    const double* row = c.A + i * BenchControllerModel::max_order;
    for (int j = 0; j < n; ++j) v += row[j] * cd.x[j];
    cd.x_next[i] = v;
  }
  for (int i = 0; i < n; ++i) cd.x[i] = cd.x_next[i];
  cd.saturated = std::fabs(u) > c.u_limit;
  if (cd.saturated) u = u > 0.0 ? c.u_limit : -c.u_limit;
  if (!std::isfinite(u)) return Status::Diverged;
  cd.u = u;
  cd.error = e;
  return Status::Ok;
}

/// One bench step in closed loop with reference r [N]: at a control instant the controller reads the
/// sensed force F_m (with noise) and updates the held command; then the bench steps with it.
inline Status step_closed_loop(const TendonBenchModel& m, TendonBenchData& d, const BenchControllerModel& c,
                               BenchControllerData& cd, double r) {
  if (!std::isfinite(r)) return Status::NonFiniteInput;
  if (cd.phase == 0) {
    const Status s = controller_update(c, cd, r - d.force_measured);
    if (is_error(s)) return s;
  }
  cd.phase = (cd.phase + 1) % c.decimation;
  const Status s = step(m, d, cd.u);
  if (is_error(s)) return s;
  if (!std::isfinite(d.x_a) || !std::isfinite(d.x_b) || !std::isfinite(d.x_load)) return Status::Diverged;
  return Status::Ok;
}

/// Run a reference sequence r[0..n) in closed loop from the current states; per step, write the sensed
/// force F_m and the command u applied during the step. Output pointers may be null. No allocation.
inline Status run_closed_loop(const TendonBenchModel& m, TendonBenchData& d, const BenchControllerModel& c,
                              BenchControllerData& cd, const double* r, std::int64_t n, double* force_measured,
                              double* u_cmd, double* force_true) {
  if (n < 0) return Status::SizeMismatch;
  const Status v = c.validate();
  if (is_error(v)) return v;
  for (std::int64_t i = 0; i < n; ++i) {
    const Status s = step_closed_loop(m, d, c, cd, r[i]);
    if (is_error(s)) return s;
    if (force_measured) force_measured[i] = d.force_measured;
    if (u_cmd) u_cmd[i] = cd.u;
    if (force_true) force_true[i] = d.force_true;
  }
  return Status::Ok;
}

}  // namespace tendyn
