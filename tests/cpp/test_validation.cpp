// The core's validation names the field and the 0-based index of what is wrong (setup time), and the
// model file reader names the line; validate() stays a Status.
#include <cstdio>
#include <functional>
#include <string>

#include "tendyn/model_file.hpp"

namespace {

int failures = 0;

tendyn::TransmissionModel lexos_like() {
  const int n = 4;
  Eigen::MatrixXd idle = Eigen::MatrixXd::Zero(n, n);
  idle(1, 0) = 0.015; idle(2, 0) = 0.015; idle(2, 1) = -0.015;
  idle(3, 0) = 0.015; idle(3, 1) = -0.015; idle(3, 2) = 0.015;
  tendyn::TransmissionModel m(Eigen::VectorXd::Constant(n, 0.008), idle,
                              (Eigen::VectorXd(n) << 0.04, 0.04, 0.09, 0.03).finished(),
                              (Eigen::VectorXd(n) << 8, 8, 1, 8).finished());
  m.beta.setConstant(0.02);
  return m;
}

void expect(const char* what, const std::function<void(tendyn::TransmissionModel&)>& edit, const std::string& message) {
  tendyn::TransmissionModel m = lexos_like();
  edit(m);
  m.update_matrices();  // as every builder does after setting the routing
  tendyn::ValidationIssue issue;
  const bool found = m.first_issue(&issue);
  const std::string got = found ? tendyn::describe(issue) : std::string("(valid)");
  const bool status_ok = m.validate() == (found ? tendyn::Status::InvalidModel : tendyn::Status::Ok);
  if (got != message || !status_ok) {
    std::printf("FAIL %s:\n  want: %s\n  got:  %s\n", what, message.c_str(), got.c_str());
    ++failures;
  }
}

void expect_file(const char* what, const std::string& text, const std::string& message) {
  tendyn::TransmissionModel m;
  std::string error;
  const bool ok = tendyn::parse_transmission_model(text, "test.model", &m, &error);
  const std::string got = ok ? std::string("(valid)") : error;
  if (got != message) {
    std::printf("FAIL %s:\n  want: %s\n  got:  %s\n", what, message.c_str(), got.c_str());
    ++failures;
  }
}

}  // namespace

int main() {
  expect("valid", [](auto&) {}, "(valid)");
  expect("beta", [](auto& m) { m.beta(2, 1) = 1.5; }, "beta[2,1] = 1.5: must be < 1 (no tension passes the branch)");
  expect("negative tau0", [](auto& m) { m.tau0(3, 0) = -0.5; }, "tau0[3,0] = -0.5: must be >= 0");
  expect("driven radius", [](auto& m) { m.driven_radius(1) = 0.0; m.K(1, 1) = 0.0; },
         "driven_radius[1] = 0: must be nonzero here (a zero driven radius makes the routing singular: the row of K "
         "of this transmission depends on the rows before it)");
  // issue 19: rows 2 and 3 equal (a differential that couples nothing new): transmission 3 is named
  expect("dependent rows", [](auto& m) { m.K(2, 3) = 0.24; m.K(3, 2) = 0.09; },
         "K[3] = 0.24: the row of K of this transmission depends on the rows before it (singular routing: K has no "
         "inverse)");
  // a differential: cable 2 goes on to wrap joint 3 (no reducer on it): valid, and K stays consistent only
  // through update_matrices()
  expect("differential", [](auto& m) { m.K(2, 3) = 0.03; }, "(valid)");
  {
    tendyn::TransmissionModel m = lexos_like();
    m.K(3, 0) = 0.02;  // changed without update_matrices(): the stale inverse is caught
    tendyn::ValidationIssue issue;
    const std::string got = m.first_issue(&issue) ? tendyn::describe(issue) : "(valid)";
    if (got.find("changed after update_matrices()") == std::string::npos) {
      std::printf("FAIL stale K:\n  got: %s\n", got.c_str());
      ++failures;
    }
  }
  expect("efficiency", [](auto& m) { m.reducer_efficiency(0) = 1.2; }, "reducer_efficiency[0] = 1.2: must be in (0, 1]");
  expect("upper K", [](auto& m) { m.K(0, 2) = 0.01; },
         "reducer_ratio[0] = 8: must be 1: the cable wraps joints after its driven joint (a differential), so its "
         "driven pulley holds no reducer");
  expect("K diagonal", [](auto& m) { m.K(3, 3) = 0.5; }, "K[3,3] = 0.5: must equal driven_radius[i] * reducer_ratio[i]");
  expect("nan", [](auto& m) { m.nu(2, 2) = std::nan(""); }, "nu[2,2] = nan: must be finite");
  expect("shape", [](auto& m) { m.tau0.resize(3, 3); m.tau0.setZero(); }, "tau0: shape (3, 3): must be (n, n) (n = 4)");
  expect("bearing wrap", [](auto& m) { m.bearing_count(3, 2) = 2; m.bearing_wrap(3, 2) = 0.0; },
         "bearing_wrap[3,2] = 0: must be in (0, 2*pi]");
  expect("bearing count", [](auto& m) { m.bearing_count(1, 1) = 1.5; }, "bearing_count[1,1] = 1.5: must be an integer >= 0");
  expect("bearing load", [](auto& m) {
           m.bearing_count(3, 2) = 2; m.bearing_wrap(3, 2) = 3.141592653589793; m.bearing_radius(3, 2) = 0.001;
           m.bearing_dynamic_coefficient(3, 2) = 1e-3;
         },
         "beta+bearing[3,2] = 4.02: beta + bearing_count * max(static, dynamic coefficient) * "
         "2 sin(wrap/2) / radius must be < 1");

  // The model file: a round trip is exact, and errors name the line.
  tendyn::TransmissionModel m = lexos_like();
  m.bearing_count(3, 2) = 2; m.bearing_wrap(3, 2) = 3.0; m.bearing_radius(3, 2) = 0.01;
  m.bearing_static_coefficient(3, 2) = 2e-4; m.bearing_dynamic_coefficient(3, 2) = 1.0 / 7.0;
  m.bearing_dynamic_coefficient(3, 2) = 1.5e-4;
  m.pretension.setConstant(0.1 + 0.2);
  const std::string text = tendyn::transmission_model_text(m);
  tendyn::TransmissionModel back;
  std::string error;
  if (!tendyn::parse_transmission_model(text, "x", &back, &error)) {
    std::printf("FAIL round trip: %s\n", error.c_str());
    ++failures;
  } else {
    bool same = true;
    m.for_each_field([&](const tendyn::FieldInfo& info, const auto& member) {
      back.for_each_field([&](const tendyn::FieldInfo& info2, const auto& member2) {
        if (std::string(info.name) == info2.name && !(member.rows() == member2.rows() && member.cols() == member2.cols() &&
                                                       (member.array() == member2.array()).all()))
          same = false;
      });
    });
    if (!same) { std::puts("FAIL round trip is not exact"); ++failures; }
  }
  std::string bad = text;
  const auto at = bad.find("\nbeta ");
  bad.replace(at, 10, "\nbeta 1.50");  // beta[0,0] = 1.5
  expect_file("file beta", bad, "test.model: line 12: beta[0,0] = 1.5: must be < 1 (no tension passes the branch)");
  expect_file("file header", "n 4\n", "test.model: line 1: not a tendyn model file (the first line must be 'tendyn-transmission-model 1')");
  expect_file("file unknown", "tendyn-transmission-model 1\nn 1\nbearing_alpha 0\n",
              "test.model: line 3: bearing_alpha: unknown field (known: motor_radius, K, driven_radius, reducer_ratio, "
              "reducer_efficiency, pretension, tau0, nu, beta, bearing_count, bearing_radius, bearing_wrap, "
              "bearing_static_coefficient, bearing_dynamic_coefficient, bearing_h0, bearing_h1, bearing_n0)");
  expect_file("file count", "tendyn-transmission-model 1\nn 2\nmotor_radius 0.01\n",
              "test.model: line 3: motor_radius: 1 values, expected 2 (n)");
  expect_file("file number", "tendyn-transmission-model 1\nn 1\nmotor_radius abc\n",
              "test.model: line 3: motor_radius: 'abc' is not a number");
  expect_file("file missing", "tendyn-transmission-model 1\nn 1\nmotor_radius 0.01\n",
              "test.model: K: missing required field");
  std::printf("validation messages: %d failure(s)\n", failures);
  return failures == 0 ? 0 : 1;
}
