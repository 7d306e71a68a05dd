// Example 02 in C++: the same compensation cycles as compensation.c, through the installed C ABI with a
// small RAII owner (the header-only C++ core, include/tendyn/compensator.hpp, gives the same numbers).
// Usage: compensation_cpp MODEL.comp [DEVICE_NAME]; n comes from the file.
#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

#include "tendyn/c_api.h"

int main(int argc, char** argv) {
  if (argc < 2 || argc > 3) { std::fprintf(stderr, "usage: %s MODEL.comp [DEVICE_NAME]\n", argv[0]); return 2; }
  char message[512];
  tendyn_compensator* raw = nullptr;
  if (tendyn_compensator_load(argv[1], argc > 2 ? argv[2] : nullptr, &raw, message, sizeof message) != TENDYN_OK) {
    std::fprintf(stderr, "%s\n", message);
    return 1;
  }
  std::unique_ptr<tendyn_compensator, decltype(&tendyn_compensator_destroy)> comp(raw, &tendyn_compensator_destroy);
  const int n = tendyn_compensator_size(comp.get());
  std::vector<double> q_motor(n), torque_joint(n), torque_motor(n), sum(n, 0.0);  // setup time only
  for (int i = 0; i < n; ++i) torque_joint[i] = 0.5 * std::pow(-0.4, i);
  double compute_time = 0.0, worst = 0.0;
  const double rate_hz = 1000.0;
  for (int k = 0; k < 500; ++k) {
    const double t = k / rate_hz;
    for (int i = 0; i < n; ++i) q_motor[i] = 2.0 * std::sin(2.0 * 3.141592653589793 * (0.5 + 0.3 * i) * t) + 0.1 * i;
    const tendyn_status s =
        tendyn_compensator_cycle(comp.get(), q_motor.data(), torque_joint.data(), torque_motor.data(), &compute_time);
    if (s < 0) {
      std::fprintf(stderr, "cycle %d: %s\n", k, tendyn_status_message(s));
      return 1;
    }
    for (int i = 0; i < n; ++i) sum[i] += torque_motor[i];
    worst = std::fmax(worst, compute_time);
  }
  std::printf("torque_motor");
  for (int i = 0; i < n; ++i) std::printf(" %.17g", torque_motor[i]);
  std::printf("\nsum_torque_motor");
  for (int i = 0; i < n; ++i) std::printf(" %.17g", sum[i]);
  std::printf("\n# longest cycle %.3g us\n", 1e6 * worst);
  return 0;
}
