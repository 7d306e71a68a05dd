// tendyn — C ABI over the header-only core (the only C++ source file of the library).
#include "tendyn/c_api.h"

#include <cstring>
#include <new>
#include <string>

#include "tendyn/losses.hpp"
#include "tendyn/model_file.hpp"

struct tendyn_transmission {
  tendyn::TransmissionModel model;
  tendyn::TransmissionData data;
  explicit tendyn_transmission(tendyn::TransmissionModel m) : model(std::move(m)), data(model) {}
};

namespace {

using RowMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using CVecMap = Eigen::Map<const Eigen::VectorXd>;

tendyn_status to_c(tendyn::Status s) { return static_cast<tendyn_status>(static_cast<int>(s)); }

thread_local std::string last_error;

void copy_message(const std::string& text, char* message, unsigned long size) {
  if (!message || size == 0) return;
  const std::size_t k = text.size() < size - 1 ? text.size() : size - 1;
  std::memcpy(message, text.data(), k);
  message[k] = '\0';
}

}  // namespace

extern "C" {

tendyn_status tendyn_transmission_create(int n, const double* motor_radius, const double* idle,
                                         const double* driven_radius, const double* reducer_ratio,
                                         const double* reducer_efficiency, const double* pretension,
                                         const double* tau0, const double* nu, const double* beta,
                                         tendyn_transmission** out) {
  if (!out || !motor_radius || !idle || !driven_radius || !reducer_ratio) return TENDYN_NULL_ARGUMENT;
  *out = nullptr;
  if (n < 1) return TENDYN_SIZE_MISMATCH;
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
}

tendyn_status tendyn_transmission_load(const char* path, tendyn_transmission** out, char* message,
                                       unsigned long message_size) {
  if (!out || !path) return TENDYN_NULL_ARGUMENT;
  *out = nullptr;
  tendyn::TransmissionModel m;
  std::string error;
  if (!tendyn::load_transmission_model(path, &m, &error)) {
    last_error = error;
    copy_message(error, message, message_size);
    return TENDYN_INVALID_MODEL;
  }
  last_error.clear();
  copy_message("", message, message_size);
  *out = new (std::nothrow) tendyn_transmission(std::move(m));
  return *out ? TENDYN_OK : TENDYN_INVALID_MODEL;
}

const char* tendyn_last_error(void) { return last_error.c_str(); }

void tendyn_transmission_destroy(tendyn_transmission* t) { delete t; }

int tendyn_transmission_size(const tendyn_transmission* t) { return t ? t->model.n : 0; }

tendyn_status tendyn_joint_from_motor(tendyn_transmission* t, const double* q_motor, double* q) {
  if (!t || !q_motor || !q) return TENDYN_NULL_ARGUMENT;
  const int n = t->model.n;
  const tendyn::Status s = tendyn::joint_from_motor(t->model, t->data, CVecMap(q_motor, n));
  if (!tendyn::is_error(s)) Eigen::Map<Eigen::VectorXd>(q, n) = t->data.q;
  return to_c(s);
}

tendyn_status tendyn_motor_from_joint(tendyn_transmission* t, const double* q, double* q_motor) {
  if (!t || !q || !q_motor) return TENDYN_NULL_ARGUMENT;
  const int n = t->model.n;
  const tendyn::Status s = tendyn::motor_from_joint(t->model, t->data, CVecMap(q, n));
  if (!tendyn::is_error(s)) Eigen::Map<Eigen::VectorXd>(q_motor, n) = t->data.q_motor;
  return to_c(s);
}

tendyn_status tendyn_motor_torque_feedforward(tendyn_transmission* t, const double* torque_joint,
                                              const double* qd, double* torque_motor) {
  if (!t || !torque_joint || !qd || !torque_motor) return TENDYN_NULL_ARGUMENT;
  const int n = t->model.n;
  const tendyn::Status s =
      tendyn::motor_torque_feedforward(t->model, t->data, CVecMap(torque_joint, n), CVecMap(qd, n));
  if (!tendyn::is_error(s)) Eigen::Map<Eigen::VectorXd>(torque_motor, n) = t->data.torque_motor;
  return to_c(s);
}

tendyn_status tendyn_joint_torque_forward(tendyn_transmission* t, const double* torque_motor,
                                          const double* qd, double* torque_joint) {
  if (!t || !torque_motor || !qd || !torque_joint) return TENDYN_NULL_ARGUMENT;
  const int n = t->model.n;
  const tendyn::Status s =
      tendyn::joint_torque_forward(t->model, t->data, CVecMap(torque_motor, n), CVecMap(qd, n));
  if (!tendyn::is_error(s)) Eigen::Map<Eigen::VectorXd>(torque_joint, n) = t->data.torque_joint;
  return to_c(s);
}

const char* tendyn_status_message(tendyn_status s) {
  if (s == TENDYN_NULL_ARGUMENT) return "a required pointer argument is NULL";
  return tendyn::status_message(static_cast<tendyn::Status>(s));
}

}  // extern "C"
