// tendyn — C ABI over the header-only core (the only C++ source file of the library).
#include "tendyn/c_api.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <new>
#include <string>

#include "tendyn/losses.hpp"
#include "tendyn/model_file.hpp"
#include "tendyn/compensator_file.hpp"
#include "tendyn/render.hpp"

struct tendyn_transmission {
  tendyn::TransmissionModel model;
  tendyn::TransmissionData data;
  explicit tendyn_transmission(tendyn::TransmissionModel m) : model(std::move(m)), data(model) {}
};

struct tendyn_compensator {
  tendyn::CompensatorModel model;
  tendyn::CompensatorData data;
  explicit tendyn_compensator(tendyn::CompensatorModel m) : model(std::move(m)), data(model) {}
};

struct tendyn_renderer {
  tendyn::CompensatorModel model;
  tendyn::CompensatorData data;
  tendyn::RenderModel render;
  tendyn::RenderData render_data;
  explicit tendyn_renderer(const tendyn::CompensatorModel& m) : model(m), data(model) {}
};

namespace {

using RowMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using CVecMap = Eigen::Map<const Eigen::VectorXd>;

tendyn_status to_c(tendyn::Status s) { return static_cast<tendyn_status>(static_cast<int>(s)); }

thread_local std::string last_error;

/// Copy `text` (NUL-terminated) into the caller's buffer, truncated to fit. Allocates nothing.
void copy_message(const char* text, char* message, unsigned long size) noexcept {
  if (!message || size == 0) return;
  const std::size_t length = std::strlen(text);
  const std::size_t k = length < size - 1 ? length : size - 1;
  std::memcpy(message, text, k);
  message[k] = '\0';
}

/// Set last_error without letting an allocation failure escape (used while handling one).
void set_last_error(const char* text) noexcept {
  try {
    last_error = text;
  } catch (...) {
    last_error.clear();
  }
}

/// Run the body of a C entry point so that no exception crosses the C boundary: a C caller cannot catch one,
/// the process would abort (std::terminate) and take the control loop with it. std::bad_alloc and any other
/// exception become TENDYN_INTERNAL_ERROR; last_error (and `message` of a loader) say which entry point and why.
template <class Body>
tendyn_status guarded(const char* entry, Body&& body, char* message = nullptr, unsigned long message_size = 0) noexcept {
  const char* why = "an unknown exception";
  try {
    return body();
  } catch (const std::bad_alloc&) {
    why = "out of memory";
  } catch (const std::exception& e) {
    why = e.what();
  } catch (...) {
  }
  char text[512];
  std::snprintf(text, sizeof text, "%s: %s (caught at the C boundary)", entry, why);
  set_last_error(text);
  copy_message(text, message, message_size);
  return TENDYN_INTERNAL_ERROR;
}

/// The end of a *_load call: the message (and last_error) from the loader, then the handle owning the model.
template <class Handle, class Model>
tendyn_status finish_load(bool loaded, const std::string& error, Model&& m, Handle** out, char* message,
                          unsigned long message_size) {
  last_error = loaded ? std::string() : error;
  copy_message(last_error.c_str(), message, message_size);
  if (!loaded) return TENDYN_INVALID_MODEL;
  *out = new (std::nothrow) Handle(std::move(m));
  return *out ? TENDYN_OK : TENDYN_INVALID_MODEL;
}

}  // namespace

extern "C" {

tendyn_status tendyn_transmission_create(int n, const double* motor_radius, const double* idle,
                                         const double* driven_radius, const double* reducer_ratio,
                                         const double* reducer_efficiency, const double* pretension,
                                         const double* tau0, const double* nu, const double* beta,
                                         tendyn_transmission** out) {
  return guarded("tendyn_transmission_create", [&]() -> tendyn_status {
    if (!out || !motor_radius || !idle || !driven_radius || !reducer_ratio) return TENDYN_NULL_ARGUMENT;
    *out = nullptr;
    if (n < 1 || n > tendyn::model_file_max_n) {
      last_error = "n = " + std::to_string(n) + ": must be in 1 … " + std::to_string(tendyn::model_file_max_n);
      return TENDYN_SIZE_MISMATCH;
    }
    const Eigen::MatrixXd idle_m = Eigen::Map<const RowMat>(idle, n, n);
    tendyn::TransmissionModel m(CVecMap(motor_radius, n), idle_m, CVecMap(driven_radius, n),
                                CVecMap(reducer_ratio, n));
    if (reducer_efficiency) m.reducer_efficiency = CVecMap(reducer_efficiency, n);
    if (pretension) m.pretension = CVecMap(pretension, n);
    if (tau0) m.tau0 = Eigen::Map<const RowMat>(tau0, n, n);
    if (nu) m.nu = Eigen::Map<const RowMat>(nu, n, n);
    if (beta) m.beta = Eigen::Map<const RowMat>(beta, n, n);
    last_error.clear();
    tendyn::ValidationIssue issue;
    if (m.first_issue(&issue)) {
      last_error = tendyn::describe(issue);
      return TENDYN_INVALID_MODEL;
    }
    *out = new (std::nothrow) tendyn_transmission(std::move(m));
    return *out ? TENDYN_OK : TENDYN_INVALID_MODEL;
  });
}

tendyn_status tendyn_transmission_load(const char* path, tendyn_transmission** out, char* message,
                                       unsigned long message_size) {
  return guarded("tendyn_transmission_load", [&]() -> tendyn_status {
    if (!out || !path) return TENDYN_NULL_ARGUMENT;
    *out = nullptr;
    tendyn::TransmissionModel m;
    std::string error;
    const bool loaded = tendyn::load_transmission_model(path, &m, &error);
    return finish_load(loaded, error, std::move(m), out, message, message_size);
  }, message, message_size);
}

const char* tendyn_last_error(void) { return last_error.c_str(); }

void tendyn_transmission_destroy(tendyn_transmission* t) { delete t; }

int tendyn_transmission_size(const tendyn_transmission* t) { return t ? t->model.n : 0; }

tendyn_status tendyn_joint_from_motor(tendyn_transmission* t, const double* q_motor, double* q) {
  return guarded("tendyn_joint_from_motor", [&]() -> tendyn_status {
    if (!t || !q_motor || !q) return TENDYN_NULL_ARGUMENT;
    const int n = t->model.n;
    const tendyn::Status s = tendyn::joint_from_motor(t->model, t->data, CVecMap(q_motor, n));
    if (!tendyn::is_error(s)) Eigen::Map<Eigen::VectorXd>(q, n) = t->data.q;
    return to_c(s);
  });
}

tendyn_status tendyn_motor_from_joint(tendyn_transmission* t, const double* q, double* q_motor) {
  return guarded("tendyn_motor_from_joint", [&]() -> tendyn_status {
    if (!t || !q || !q_motor) return TENDYN_NULL_ARGUMENT;
    const int n = t->model.n;
    const tendyn::Status s = tendyn::motor_from_joint(t->model, t->data, CVecMap(q, n));
    if (!tendyn::is_error(s)) Eigen::Map<Eigen::VectorXd>(q_motor, n) = t->data.q_motor;
    return to_c(s);
  });
}

tendyn_status tendyn_motor_torque_feedforward(tendyn_transmission* t, const double* torque_joint,
                                              const double* qd, double* torque_motor) {
  return guarded("tendyn_motor_torque_feedforward", [&]() -> tendyn_status {
    if (!t || !torque_joint || !qd || !torque_motor) return TENDYN_NULL_ARGUMENT;
    const int n = t->model.n;
    const tendyn::Status s =
        tendyn::motor_torque_feedforward(t->model, t->data, CVecMap(torque_joint, n), CVecMap(qd, n));
    if (!tendyn::is_error(s)) Eigen::Map<Eigen::VectorXd>(torque_motor, n) = t->data.torque_motor;
    return to_c(s);
  });
}

tendyn_status tendyn_joint_torque_forward(tendyn_transmission* t, const double* torque_motor,
                                          const double* qd, double* torque_joint) {
  return guarded("tendyn_joint_torque_forward", [&]() -> tendyn_status {
    if (!t || !torque_motor || !qd || !torque_joint) return TENDYN_NULL_ARGUMENT;
    const int n = t->model.n;
    const tendyn::Status s =
        tendyn::joint_torque_forward(t->model, t->data, CVecMap(torque_motor, n), CVecMap(qd, n));
    if (!tendyn::is_error(s)) Eigen::Map<Eigen::VectorXd>(torque_joint, n) = t->data.torque_joint;
    return to_c(s);
  });
}

tendyn_status tendyn_compensator_load(const char* path, const char* expected_device, tendyn_compensator** out,
                                      char* message, unsigned long message_size) {
  return guarded("tendyn_compensator_load", [&]() -> tendyn_status {
    if (!out || !path) return TENDYN_NULL_ARGUMENT;
    *out = nullptr;
    if (expected_device && !*expected_device) {  // "" would silently accept any device: NULL says so explicitly
      const std::string error = std::string(path) + ": expected_device is empty (pass NULL to accept any device)";
      return finish_load(false, error, tendyn::CompensatorModel(), out, message, message_size);
    }
    tendyn::CompensatorModel m;
    std::string error;
    const bool loaded = tendyn::load_compensator_model(path, expected_device ? expected_device : "", &m, &error);
    return finish_load(loaded, error, std::move(m), out, message, message_size);
  }, message, message_size);
}

void tendyn_compensator_destroy(tendyn_compensator* c) { delete c; }

int tendyn_compensator_size(const tendyn_compensator* c) { return c ? c->model.transmission.n : 0; }

tendyn_status tendyn_compensator_reset(tendyn_compensator* c) {
  return guarded("tendyn_compensator_reset", [&]() -> tendyn_status {
    if (!c) return TENDYN_NULL_ARGUMENT;
    c->data.reset();
    return TENDYN_OK;
  });
}

tendyn_status tendyn_compensator_cycle(tendyn_compensator* c, const double* q_motor, const double* torque_joint,
                                       double* torque_motor, double* compute_time) {
  return guarded("tendyn_compensator_cycle", [&]() -> tendyn_status {
    if (!c || !q_motor || !torque_joint || !torque_motor) return TENDYN_NULL_ARGUMENT;
    const int n = c->model.transmission.n;
    tendyn::Status s;
    if (compute_time) {  // timed cycle (two clock reads)
      s = tendyn::compensator_cycle(c->model, c->data, CVecMap(q_motor, n), CVecMap(torque_joint, n));
      *compute_time = c->data.compute_time;
    } else {             // the caller does not want the time: skip the clock
      s = tendyn::compensator_sense(c->model, c->data, CVecMap(q_motor, n), false);
      if (!tendyn::is_error(s)) s = tendyn::compensator_command(c->model, c->data, CVecMap(torque_joint, n));
    }
    if (!tendyn::is_error(s)) Eigen::Map<Eigen::VectorXd>(torque_motor, n) = c->data.torque_motor;
    return to_c(s);
  });
}

tendyn_status tendyn_compensator_cycle_force(tendyn_compensator* c, const double* q_motor, const double* force_ee,
                                             double* torque_motor, double* compute_time) {
  return guarded("tendyn_compensator_cycle_force", [&]() -> tendyn_status {
    if (!c || !q_motor || !force_ee || !torque_motor) return TENDYN_NULL_ARGUMENT;
    const int n = c->model.transmission.n;
    const tendyn::Status s =
        tendyn::compensator_cycle_force(c->model, c->data, CVecMap(q_motor, n), Eigen::Map<const Eigen::Vector3d>(force_ee));
    if (!tendyn::is_error(s)) Eigen::Map<Eigen::VectorXd>(torque_motor, n) = c->data.torque_motor;
    if (compute_time) *compute_time = c->data.compute_time;
    return to_c(s);
  });
}

tendyn_status tendyn_compensator_state(const tendyn_compensator* c, double* q, double* qd, double* qd_motor,
                                       double* gravity_torque, double* ee_position) {
  return guarded("tendyn_compensator_state", [&]() -> tendyn_status {
    if (!c) return TENDYN_NULL_ARGUMENT;
    const int n = c->model.transmission.n;
    if (q) Eigen::Map<Eigen::VectorXd>(q, n) = c->data.q;
    if (qd) Eigen::Map<Eigen::VectorXd>(qd, n) = c->data.qd;
    if (qd_motor) Eigen::Map<Eigen::VectorXd>(qd_motor, n) = c->data.qd_motor;
    if (gravity_torque) Eigen::Map<Eigen::VectorXd>(gravity_torque, n) = c->data.chain.gravity_active;
    if (ee_position) std::memcpy(ee_position, c->data.chain.ee_position.data(), 3 * sizeof(double));
    return TENDYN_OK;
  });
}

tendyn_status tendyn_compensator_passivity(const tendyn_compensator* c, double* energy, double* damping,
                                           double* torque, double* energy_injected, double* energy_budget) {
  if (!c) return TENDYN_NULL_ARGUMENT;
  if (!c->model.passivity.enabled) return TENDYN_INVALID_MODEL;
  const int n = c->model.transmission.n;
  const tendyn::PassivityData& p = c->data.passivity;
  if (energy) Eigen::Map<Eigen::VectorXd>(energy, n) = p.energy;
  if (damping) Eigen::Map<Eigen::VectorXd>(damping, n) = p.damping;
  if (torque) Eigen::Map<Eigen::VectorXd>(torque, n) = p.torque;
  if (energy_injected) Eigen::Map<Eigen::VectorXd>(energy_injected, n) = p.energy_injected;
  if (energy_budget) Eigen::Map<Eigen::VectorXd>(energy_budget, n) = p.energy_budget;
  return TENDYN_OK;
}

tendyn_status tendyn_compensator_tracking(const tendyn_compensator* c, double* scale_constant, double* scale_viscous,
                                         long* updates) {
  if (!c) return TENDYN_NULL_ARGUMENT;
  if (!c->model.tracking.enabled) return TENDYN_INVALID_MODEL;
  const int n = c->model.transmission.n;
  const tendyn::FrictionTrackingData& t = c->data.tracking;
  if (scale_constant) Eigen::Map<Eigen::VectorXd>(scale_constant, n) = t.scale_constant;
  if (scale_viscous) Eigen::Map<Eigen::VectorXd>(scale_viscous, n) = t.scale_viscous;
  if (updates)
    for (int i = 0; i < n; ++i) updates[i] = t.updates(i);
  return TENDYN_OK;
}

tendyn_status tendyn_compensator_set_tracking_active(tendyn_compensator* c, int active) {
  if (!c) return TENDYN_NULL_ARGUMENT;
  c->data.tracking_active = active != 0;
  return TENDYN_OK;
}

tendyn_status tendyn_renderer_create(const tendyn_compensator* c, double stiffness, double damping,
                                     double surface_friction, tendyn_renderer** out) {
  return guarded("tendyn_renderer_create", [&]() -> tendyn_status {
    if (!c || !out) return TENDYN_NULL_ARGUMENT;
    *out = nullptr;
    tendyn_renderer* r = new (std::nothrow) tendyn_renderer(c->model);
    if (!r) return TENDYN_INVALID_MODEL;
    r->render.stiffness = stiffness;
    r->render.damping = damping;
    r->render.surface_friction = surface_friction;
    if (tendyn::is_error(r->render.validate())) {
      last_error = "renderer: stiffness, damping and surface_friction must be finite and >= 0";
      delete r;
      return TENDYN_INVALID_MODEL;
    }
    *out = r;
    return TENDYN_OK;
  });
}

void tendyn_renderer_destroy(tendyn_renderer* r) { delete r; }

tendyn_status tendyn_renderer_add_plane(tendyn_renderer* r, const double* normal, double offset) {
  return guarded("tendyn_renderer_add_plane", [&]() -> tendyn_status {
    if (!r || !normal) return TENDYN_NULL_ARGUMENT;
    return r->render.add_plane(Eigen::Map<const Eigen::Vector3d>(normal), offset) ? TENDYN_OK : TENDYN_INVALID_MODEL;
  });
}

tendyn_status tendyn_renderer_set_sphere(tendyn_renderer* r, const double* center, double radius) {
  return guarded("tendyn_renderer_set_sphere", [&]() -> tendyn_status {
    if (!r || !center) return TENDYN_NULL_ARGUMENT;
    const Eigen::Vector3d c = Eigen::Map<const Eigen::Vector3d>(center);
    if (!c.allFinite() || !(radius >= 0.0)) return TENDYN_INVALID_MODEL;
    r->render.sphere = radius > 0.0;
    r->render.sphere_center = c;
    r->render.sphere_radius = radius;
    return TENDYN_OK;
  });
}

tendyn_status tendyn_renderer_set_texture(tendyn_renderer* r, double amplitude, double period, const double* direction) {
  return guarded("tendyn_renderer_set_texture", [&]() -> tendyn_status {
    if (!r || !direction) return TENDYN_NULL_ARGUMENT;
    const Eigen::Vector3d e = Eigen::Map<const Eigen::Vector3d>(direction);
    if (!std::isfinite(amplitude) || !(period > 0.0) || !(std::abs(e.norm() - 1.0) < 1e-9)) return TENDYN_INVALID_MODEL;
    r->render.texture_amplitude = amplitude;
    r->render.texture_period = period;
    r->render.texture_direction = e;
    return TENDYN_OK;
  });
}

tendyn_status tendyn_renderer_cycle(tendyn_renderer* r, const double* q_motor, double* torque_motor, double* force_ee,
                                    double* x_god, double* compute_time) {
  return guarded("tendyn_renderer_cycle", [&]() -> tendyn_status {
    if (!r || !q_motor || !torque_motor) return TENDYN_NULL_ARGUMENT;
    const int n = r->model.transmission.n;
    const tendyn::Status s = tendyn::render_cycle(r->render, r->render_data, r->model, r->data, CVecMap(q_motor, n));
    if (!tendyn::is_error(s)) Eigen::Map<Eigen::VectorXd>(torque_motor, n) = r->data.torque_motor;
    if (force_ee) std::memcpy(force_ee, r->render_data.force.data(), 3 * sizeof(double));
    if (x_god) std::memcpy(x_god, r->render_data.x_god.data(), 3 * sizeof(double));
    if (compute_time) *compute_time = r->render_data.compute_time;
    return to_c(s);
  });
}

const char* tendyn_status_message(tendyn_status s) {
  if (s == TENDYN_NULL_ARGUMENT) return "a required pointer argument is NULL";
  if (s == TENDYN_INTERNAL_ERROR) return "an exception inside the library (e.g. out of memory): tendyn_last_error() says which";
  return tendyn::status_message(static_cast<tendyn::Status>(s));
}

}  // extern "C"
