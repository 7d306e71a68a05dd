// tendyn — rigid-body model of the chain a transmission drives, on Pinocchio.
//
// The chain is built from explicit joint frames (computed in Python from DH, modified DH or a
// URDF), so the C++ core never parses files. Real-time calls follow Pinocchio's
// f(model, data, inputs) convention and do not allocate.
#pragma once

#include <string>

#include <Eigen/Core>
#include <pinocchio/algorithm/rnea.hpp>
#include <pinocchio/multibody/data.hpp>
#include <pinocchio/multibody/joint/joints.hpp>
#include <pinocchio/multibody/model.hpp>

#include "tendyn/status.hpp"

namespace tendyn {

/// Immutable rigid-body model: a Pinocchio model plus nothing else (kept as a struct so the
/// simulator can add to it without touching callers).
struct RigidBodyModel {
  pinocchio::Model pin;

  RigidBodyModel() = default;

  /// Gravity acceleration in the base frame [m/s²].
  void set_gravity(const Eigen::Vector3d& g) { pin.gravity.linear(g); }

  /// Append a one-DOF joint and the link it moves (setup time; allocates).
  /// @param parent     index of the parent joint (0 = base/universe)
  /// @param placement  (4, 4) homogeneous transform of the joint frame in the parent joint frame
  /// @param axis       unit axis of motion in the joint frame
  /// @param prismatic  false: revolute [rad]; true: prismatic [m]
  /// @param mass       link mass [kg]
  /// @param com        centre of mass in the joint frame [m]
  /// @param inertia    (3, 3) rotational inertia about the COM, joint-frame axes [kg·m²]
  /// @return the new joint index (1-based, Pinocchio's)
  int add_joint(int parent, const Eigen::Matrix4d& placement, const Eigen::Vector3d& axis,
                bool prismatic, double mass, const Eigen::Vector3d& com,
                const Eigen::Matrix3d& inertia, const std::string& name) {
    const pinocchio::SE3 M(placement.topLeftCorner<3, 3>(), placement.topRightCorner<3, 1>());
    const bool along_z = axis.isApprox(Eigen::Vector3d::UnitZ(), 1e-12);
    pinocchio::JointIndex id;
    if (prismatic)
      id = along_z ? pin.addJoint(parent, pinocchio::JointModelPZ(), M, name)
                   : pin.addJoint(parent, pinocchio::JointModelPrismaticUnaligned(axis), M, name);
    else
      id = along_z ? pin.addJoint(parent, pinocchio::JointModelRZ(), M, name)
                   : pin.addJoint(parent, pinocchio::JointModelRevoluteUnaligned(axis), M, name);
    pin.appendBodyToJoint(id, pinocchio::Inertia(mass, com, inertia), pinocchio::SE3::Identity());
    return static_cast<int>(id);
  }

  int nq() const { return pin.nq; }
};

/// Preallocated Pinocchio data and outputs.
struct RigidBodyData {
  pinocchio::Data pin;
  Eigen::VectorXd gravity_torque;  ///< g(q) [N·m or N], generalized gravity

  explicit RigidBodyData(const RigidBodyModel& m)
      : pin(m.pin), gravity_torque(Eigen::VectorXd::Zero(m.pin.nv)) {}
};

/// Generalized gravity g(q) = ∂V/∂q [N·m] (Pinocchio computeGeneralizedGravity).
template <class VecIn>
inline Status gravity_torque(const RigidBodyModel& m, RigidBodyData& d, const VecIn& q) {
  if (q.size() != m.pin.nq) return Status::SizeMismatch;
  if (!all_finite(q)) return Status::NonFiniteInput;
  d.gravity_torque = pinocchio::computeGeneralizedGravity(m.pin, d.pin, q);
  return Status::Ok;
}

}  // namespace tendyn
