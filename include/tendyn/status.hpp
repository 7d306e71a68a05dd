// tendyn — status codes of the real-time core.
//
// The real-time path never throws: every call returns a Status. Python raises on the
// error codes (see bindings/python), a C caller reads them from the C ABI.
#pragma once

#include <cmath>

#include <Eigen/Core>

namespace tendyn {

/// Result of a real-time call. Values >= 0 are usable results (Ok or Ok with a flag);
/// negative values are errors and leave the outputs unspecified but finite-free of side effects.
enum class Status : int {
  Ok = 0,                ///< computed
  SelfLocked = 1,        ///< computed; a self-locking reducer (eta_d <= 0.5) holds a back-driving load
  NotConverged = 2,      ///< computed; the iteration of a coupled block of a general routing hit its cap
  NonFiniteInput = -1,   ///< an input was NaN or Inf
  SizeMismatch = -2,     ///< an input vector does not have the model's size
  InvalidModel = -3,     ///< the model is singular or inconsistent (caught at construction in Python)
  Diverged = -4,         ///< a simulation state became NaN or Inf (step too large for the motion)
};

inline const char* status_message(Status s) {
  switch (s) {
    case Status::Ok: return "ok";
    case Status::SelfLocked: return "a self-locking reducer holds a back-driving load";
    case Status::NotConverged: return "the statics of a coupled (differential) block did not converge";
    case Status::NonFiniteInput: return "an input is NaN or Inf";
    case Status::SizeMismatch: return "an input vector does not have the model's size";
    case Status::InvalidModel: return "the model is singular or inconsistent";
    case Status::Diverged:
      return "the simulation diverged (a state is NaN or Inf): reduce the step or check the inputs";
  }
  return "unknown status";
}

inline bool is_error(Status s) { return static_cast<int>(s) < 0; }

/// Combine two statuses: an error wins, then a flag, then Ok.
inline Status worst(Status a, Status b) {
  if (is_error(a)) return a;
  if (is_error(b)) return b;
  return static_cast<int>(a) >= static_cast<int>(b) ? a : b;
}

template <class Derived>
inline bool all_finite(const Eigen::DenseBase<Derived>& v) {
  return v.allFinite();
}

}  // namespace tendyn
