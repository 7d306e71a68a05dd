/* tendyn — C ABI of the real-time transmission core (routing + statics with losses).
 *
 * One handle holds an immutable model and its preallocated data; after
 * tendyn_transmission_load / tendyn_transmission_create no call allocates, none throws. Arrays are dense, row-major
 * for matrices, SI units: radii [m], tensions [N], torques [N·m], velocities [rad/s].
 * Indices are 0-based: transmission i drives joint i and crosses joints 0…i−1.
 */
#ifndef TENDYN_C_API_H
#define TENDYN_C_API_H

#ifdef __cplusplus
extern "C" {
#endif

#if defined(TENDYN_BUILDING_C_API)
#define TENDYN_API __attribute__((visibility("default")))
#else
#define TENDYN_API
#endif

typedef enum tendyn_status {
  TENDYN_OK = 0,
  TENDYN_SELF_LOCKED = 1,      /* computed; a self-locking reducer holds a back-driving load */
  TENDYN_NOT_CONVERGED = 2,    /* computed; the iteration of a coupled (differential) block hit its cap */
  TENDYN_NON_FINITE_INPUT = -1,
  TENDYN_SIZE_MISMATCH = -2,
  TENDYN_INVALID_MODEL = -3,
  TENDYN_DIVERGED = -4,        /* a simulation state became NaN or Inf */
  TENDYN_NULL_ARGUMENT = -100, /* a required pointer is NULL (C ABI only) */
  TENDYN_INTERNAL_ERROR = -101 /* an exception inside the library (out of memory, a bug), caught at the C
                                  boundary: no exception ever crosses it; tendyn_last_error() says which (C only) */
} tendyn_status;

typedef struct tendyn_transmission tendyn_transmission;

/* Load a complete transmission model (routing, reducers, pretension, branch losses and bearings) from a
 * model file exported by Python: `Transmission.from_device(load_device("lexos.toml")).export(path)`
 * (format: include/tendyn/model_file.hpp, one line per core field, values that read back exactly, so the
 * loaded model equals the Python one bit for bit). This is the way to embed an identified model in a controller:
 * load it once at start-up, then call the functions below in the loop.
 * On success returns TENDYN_OK and *out owns the handle (free it with tendyn_transmission_destroy).
 * On failure *out is NULL and, if message is not NULL, message[0 .. message_size) receives a
 * NUL-terminated text naming the file, the line and the field, e.g.
 * "lexos.model: line 12: beta[2,1] = 1.5: must be < 1 (no tension passes the branch)" (indices 0-based).
 * Returns TENDYN_INVALID_MODEL for a missing, unreadable or invalid file. Allocates (setup time). */
TENDYN_API tendyn_status tendyn_transmission_load(const char* path, tendyn_transmission** out, char* message,
                                                  unsigned long message_size);

/* Every function returning a status catches every exception inside: none crosses the C boundary (a C caller's
 * process would abort). Sizes read from a file are bounded (n <= 64) before anything is allocated. */

/* Why the last tendyn_transmission_create on this thread failed ("" if it did not): the field and index,
 * e.g. "driven_radius[1] = 0: must be > 0 (a zero driven radius makes the routing singular)". */
TENDYN_API const char* tendyn_last_error(void);

/* Create a transmission model. Required: n >= 1, motor_radius (n), idle (n*n, row-major, signed
 * idle radii in the strict lower part), driven_radius (n), reducer_ratio (n). Optional (NULL =
 * defaults): reducer_efficiency (n, default 1), pretension (n, default 0), tau0, nu, beta
 * (n*n row-major, [i*n + b] = branch b <= i of transmission i; default 0). No bearings: a model with
 * bearings comes from tendyn_transmission_load. On success *out owns the handle; free it with
 * tendyn_transmission_destroy. On TENDYN_INVALID_MODEL, tendyn_last_error() says which field is wrong. */
TENDYN_API tendyn_status tendyn_transmission_create(int n, const double* motor_radius, const double* idle,
                                                    const double* driven_radius, const double* reducer_ratio,
                                                    const double* reducer_efficiency, const double* pretension,
                                                    const double* tau0, const double* nu, const double* beta,
                                                    tendyn_transmission** out);
TENDYN_API void tendyn_transmission_destroy(tendyn_transmission* t);
TENDYN_API int tendyn_transmission_size(const tendyn_transmission* t);

/* q = K^-1 R_m q_m and q_m = R_m^-1 K q (S0 eqs. 1-2, corrected). */
TENDYN_API tendyn_status tendyn_joint_from_motor(tendyn_transmission* t, const double* q_motor, double* q);
TENDYN_API tendyn_status tendyn_motor_from_joint(tendyn_transmission* t, const double* q, double* q_motor);

/* Feedforward: joint torques wanted + joint velocity -> motor torques to command (with losses). */
TENDYN_API tendyn_status tendyn_motor_torque_feedforward(tendyn_transmission* t, const double* torque_joint,
                                                         const double* qd, double* torque_motor);
/* Forward: motor torques + joint velocity -> joint torques delivered (with losses). */
TENDYN_API tendyn_status tendyn_joint_torque_forward(tendyn_transmission* t, const double* torque_motor,
                                                     const double* qd, double* torque_joint);

/* ---- compensator and haptic renderer (include/tendyn/compensator.hpp, render.hpp) ----------------------
 *
 * A compensator turns motor encoder readings and wanted joint torques (or an end-effector force) into the
 * motor torques that also cover gravity and the identified transmission losses (S0 §IV-B: feedforward
 * beta(q) = friction + gravity; C10, C46). Velocity is estimated inside (first-order filtered difference at
 * the control rate of the file). Load it from a compensator model file exported by Python
 * (`tendyn.control.Compensator.from_device(dev, friction=...).export(path)`, format:
 * include/tendyn/compensator_file.hpp). After loading no call allocates, none throws. */
typedef struct tendyn_compensator tendyn_compensator;

/* Load a compensator model file. expected_device must equal the file's `device` field; NULL accepts any device,
 * "" is refused (an empty name is a caller's mistake, not a wish to skip the check).
 * On failure *out is NULL, the status is TENDYN_INVALID_MODEL and message (if not NULL) names the file,
 * the line and the field, e.g. "lexos.comp: line 31: mass: 3 values, expected 4 (n)". Allocates. */
TENDYN_API tendyn_status tendyn_compensator_load(const char* path, const char* expected_device,
                                                 tendyn_compensator** out, char* message,
                                                 unsigned long message_size);
TENDYN_API void tendyn_compensator_destroy(tendyn_compensator* c);
/* Number of motors = joints (0 for NULL). */
TENDYN_API int tendyn_compensator_size(const tendyn_compensator* c);
/* Forget the velocity history: the next cycle starts at rest. */
TENDYN_API tendyn_status tendyn_compensator_reset(tendyn_compensator* c);
/* One cycle at the file's control rate: q_motor (n) [rad] encoder readings, torque_joint (n) [N m] joint
 * torques wanted on top of gravity -> torque_motor (n) [N m] to command. compute_time (may be NULL)
 * receives the wall time of the cycle [s]; with NULL the cycle reads no clock. TENDYN_SELF_LOCKED is a
 * usable result. */
TENDYN_API tendyn_status tendyn_compensator_cycle(tendyn_compensator* c, const double* q_motor,
                                                  const double* torque_joint, double* torque_motor,
                                                  double* compute_time);
/* The same for a wanted end-effector force force_ee (3) [N], base frame: torque_joint = J(q)^T force_ee. */
TENDYN_API tendyn_status tendyn_compensator_cycle_force(tendyn_compensator* c, const double* q_motor,
                                                        const double* force_ee, double* torque_motor,
                                                        double* compute_time);
/* State of the last cycle; any pointer may be NULL: q, qd (n) joint estimates [rad, rad/s], qd_motor (n)
 * filtered motor velocity [rad/s], gravity_torque (n) [N m] at the actuated joints (L^T g(q) on a closed-loop
 * tree, chain.hpp), ee_position (3) [m]. */
TENDYN_API tendyn_status tendyn_compensator_state(const tendyn_compensator* c, double* q, double* qd,
                                                  double* qd_motor, double* gravity_torque, double* ee_position);

/* Passivity observer and controller of the last cycle (include/tendyn/passivity.hpp; on when the model file
 * has `section passivity 1` with `enabled 1`); any pointer may be NULL, each (n): energy [J] the compensator
 * injected beyond the certified dissipation (> 0: the controller is damping), damping [N m s/rad] and
 * torque [N m] the controller adds this cycle, energy_injected and energy_budget [J] since the last reset.
 * Returns TENDYN_INVALID_MODEL when the model has no passivity controller (the outputs are then untouched). */
TENDYN_API tendyn_status tendyn_compensator_passivity(const tendyn_compensator* c, double* energy, double* damping,
                                                      double* torque, double* energy_injected,
                                                      double* energy_budget);

/* Online friction tracking (include/tendyn/friction_tracking.hpp; on when the model file has `section
 * tracking 1` with `enabled 1`). scale_constant, scale_viscous (n) [-] (may be NULL): the tracked scales of the
 * model's constant (tau0: C_m0) and viscous (nu) losses per transmission (1 = as identified; the load-dependent
 * losses beta, eta_d and bearings are held as identified); updates
 * (n) (may be NULL): RLS updates since the last reset. TENDYN_INVALID_MODEL without tracking. */
TENDYN_API tendyn_status tendyn_compensator_tracking(const tendyn_compensator* c, double* scale_constant,
                                                     double* scale_viscous, long* updates);
/* Gate the tracker: active = 0 while an unknown external force acts on the device (a hand on the handle),
 * 1 when the motion is the device's own (a self-test trajectory, a position-controlled task). Default 1. */
TENDYN_API tendyn_status tendyn_compensator_set_tracking_active(tendyn_compensator* c, int active);

/* A haptic renderer on a copy of a compensator (S0 eq. 23, corrected: ERRATA):
 * F_d = (K_st + K_d s)(X_god - X_hat) + F_fr + F_T, god-object proxy against planes and one sphere, torques
 * through the compensator. Create and shape the scene at setup; then one tendyn_renderer_cycle per period. */
typedef struct tendyn_renderer tendyn_renderer;
/* stiffness K_st [N/m], damping K_d [N s/m], surface_friction mu [-] (Coulomb on the proxy). Allocates. */
TENDYN_API tendyn_status tendyn_renderer_create(const tendyn_compensator* c, double stiffness, double damping,
                                                double surface_friction, tendyn_renderer** out);
TENDYN_API void tendyn_renderer_destroy(tendyn_renderer* r);
/* Free space is normal . x >= offset (normal (3), unit, out of the solid; offset [m]); up to 8 planes. */
TENDYN_API tendyn_status tendyn_renderer_add_plane(tendyn_renderer* r, const double* normal, double offset);
/* A solid sphere, center (3) [m], radius [m] (replaces the previous one; radius 0 removes it). */
TENDYN_API tendyn_status tendyn_renderer_set_sphere(tendyn_renderer* r, const double* center, double radius);
/* Texture grating F_T = amplitude |F_n| sin(2 pi X_god . direction / period) n (amplitude [-], period [m]). */
TENDYN_API tendyn_status tendyn_renderer_set_texture(tendyn_renderer* r, double amplitude, double period,
                                                     const double* direction);
/* One rendering cycle: q_motor (n) [rad] -> torque_motor (n) [N m]; force_ee (3) [N] (may be NULL) receives
 * F_d, x_god (3) [m] (may be NULL) the proxy, compute_time (may be NULL) the wall time [s]. */
TENDYN_API tendyn_status tendyn_renderer_cycle(tendyn_renderer* r, const double* q_motor, double* torque_motor,
                                               double* force_ee, double* x_god, double* compute_time);

TENDYN_API const char* tendyn_status_message(tendyn_status s);

#ifdef __cplusplus
}
#endif
#endif /* TENDYN_C_API_H */
