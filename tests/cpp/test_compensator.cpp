// Compensator and renderer (C10, C46): 0 allocations in 10^5 cycles of each, and bad compensator model
// files refused with a message naming the field. argv[1] = cycles, argv[2] = the L-EXOS compensator file
// exported by Python (examples/02_compensation/lexos.comp).
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "counting_malloc.hpp"
#include "tendyn/compensator_file.hpp"
#include "tendyn/render.hpp"

namespace {

int failures = 0;

void expect(bool ok, const std::string& what) {
  if (!ok) {
    ++failures;
    std::printf("FAIL: %s\n", what.c_str());
  }
}

std::string read(const char* path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

std::string replace_line(const std::string& text, const std::string& key, const std::string& with) {
  std::istringstream in(text);
  std::string line, out;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string k;
    ls >> k;
    if (k == key) {
      if (!with.empty()) out += with + "\n";
    } else {
      out += line + "\n";
    }
  }
  return out;
}

/// The text must be refused with a message containing `needle`.
void refused(const std::string& text, const std::string& expected_device, const std::string& needle,
             const std::string& what) {
  tendyn::CompensatorModel m;
  std::string error;
  const bool ok = tendyn::parse_compensator_model(text, "lexos.comp", expected_device, &m, &error);
  expect(!ok, what + ": accepted");
  expect(error.find(needle) != std::string::npos, what + ": message '" + error + "' does not name '" + needle + "'");
  if (!ok) std::printf("refused (%s): %s\n", what.c_str(), error.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  const long cycles = argc > 1 ? std::atol(argv[1]) : 100000;
  if (argc < 3) {
    std::puts("usage: test_compensator CYCLES LEXOS_COMP_FILE");
    return 2;
  }
  const std::string text = read(argv[2]);
  tendyn::CompensatorModel m;
  std::string error;
  if (!tendyn::parse_compensator_model(text, "lexos.comp", "L-EXOS", &m, &error)) {
    std::printf("cannot load %s: %s\n", argv[2], error.c_str());
    return 1;
  }
  tendyn::CompensatorData d(m);
  tendyn::RenderModel r;
  r.stiffness = 2000.0;
  r.damping = 5.0;
  r.surface_friction = 0.3;
  r.texture_amplitude = 0.1;
  Eigen::VectorXd qm(m.transmission.n), tau(m.transmission.n), q0(m.transmission.n), q(m.transmission.n);
  q0 << 0.3, 1.6, 0.0, 0.5;
  tendyn::ChainData cd0(m.chain);
  tendyn::chain_forward_kinematics(m.chain, cd0, q0);
  const Eigen::Vector3d x0 = cd0.ee_position;
  r.add_plane(Eigen::Vector3d(0.0, 0.0, 1.0), x0.z() - 0.01);  // a floor 1 cm below the handle
  r.sphere = true;                                             // and a ball beside it
  r.sphere_center = x0 + Eigen::Vector3d(0.0, 0.06, 0.0);
  r.sphere_radius = 0.04;
  tendyn::RenderData rd;
  tendyn::CompensatorData rcd(m);
  // The same model with the passivity observer + controller on, over-compensating (k = 1.5): its cycles
  // must not allocate either, and the controller must act (energy observed, damping applied).
  tendyn::CompensatorModel mp = m;
  mp.underestimation = 1.5;
  mp.passivity.enabled = true;
  mp.passivity.dissipation_coulomb = Eigen::VectorXd::Constant(m.transmission.n, 1e-3);
  mp.passivity.dissipation_viscous = Eigen::VectorXd::Constant(m.transmission.n, 1e-5);
  mp.passivity.reserve = 1e-3;
  mp.passivity.damping_max = 0.05;
  mp.tracking.enabled = true;  // and online friction tracking (one more statics evaluation, RLS updates)
  expect(mp.first_issue().empty(), "passivity model valid: " + mp.first_issue());
  tendyn::CompensatorData pd(mp);
  tendyn::RenderData prd;
  tendyn::CompensatorData prcd(mp);
  long damped = 0;

  std::mt19937 rng(4321);
  std::normal_distribution<double> N(0.0, 1.0);
  Eigen::Vector3d f;
  long bad = 0, contacts = 0;
  counting::armed = true;
  { Eigen::VectorXd probe(64); probe.setZero(); }
  const long probe_count = counting::count;
  counting::count = 0;
  if (probe_count == 0) { std::puts("malloc interposition does not work"); return 1; }
  for (long k = 0; k < cycles; ++k) {
    const double t = 1e-3 * static_cast<double>(k);
    for (int i = 0; i < q.size(); ++i) q(i) = q0(i) + 0.1 * std::sin(0.7 * (i + 1) * t);
    qm.noalias() = m.transmission.motor_from_joint_position * q;
    for (int i = 0; i < tau.size(); ++i) tau(i) = N(rng);
    for (int i = 0; i < 3; ++i) f(i) = N(rng);
    if (tendyn::is_error(tendyn::compensator_cycle(m, d, qm, tau))) ++bad;
    if (tendyn::is_error(tendyn::compensator_cycle_force(m, d, qm, f))) ++bad;
    if (tendyn::is_error(tendyn::render_cycle(r, rd, m, rcd, qm))) ++bad;
    if (tendyn::is_error(tendyn::compensator_cycle(mp, pd, qm, tau))) ++bad;
    if (tendyn::is_error(tendyn::render_cycle(r, prd, mp, prcd, qm))) ++bad;
    contacts += rd.in_contact;
    damped += pd.passivity.damping.maxCoeff() > 0.0;
  }
  const long tracked = pd.tracking.updates.sum();
  counting::armed = false;
  std::printf("%ld cycles x (compensator, compensator force, renderer): %ld allocations, %ld error statuses, "
              "%ld cycles in contact\n", cycles, counting::count, bad, contacts);
  expect(counting::count == 0, "allocations in the real-time cycles");
  expect(bad == 0, "error statuses");
  expect(contacts > 0 && contacts < cycles, "the path must touch the scene and leave it");
  std::printf("passivity controller damping in %ld of %ld cycles (k = 1.5)\n", damped, cycles);
  expect(damped > 0, "the passivity controller never acted at k = 1.5");
  std::printf("friction tracker: %ld updates\n", tracked);
  expect(tracked > 0, "the friction tracker never updated");

  // Section passivity: optional (the file without it loads, off), written when on, read back the same.
  {
    tendyn::CompensatorModel back;
    expect(!m.passivity.enabled, "a file without section passivity loads with the controller off");
    const std::string ptext = tendyn::compensator_model_text(mp);
    expect(ptext.find("section passivity 1") != std::string::npos, "section passivity written when on");
    expect(tendyn::compensator_model_text(m).find("section passivity") == std::string::npos,
           "section passivity not written when off (older readers keep working)");
    expect(tendyn::parse_compensator_model(ptext, "p.comp", "", &back, &error), "passivity file read back: " + error);
    expect(back.passivity.enabled && back.passivity.dissipation_coulomb.isApprox(mp.passivity.dissipation_coulomb) &&
               back.passivity.dissipation_viscous.isApprox(mp.passivity.dissipation_viscous) &&
               back.passivity.reserve == mp.passivity.reserve && back.passivity.damping_max == mp.passivity.damping_max,
           "passivity settings round trip");
    expect(back.tracking.enabled && back.tracking.forgetting == mp.tracking.forgetting &&
               back.tracking.acceleration_max == mp.tracking.acceleration_max,
           "tracking settings round trip");
    refused(replace_line(ptext, "covariance_max", ""), "", "tracking.covariance_max", "missing tracking field");
    refused(replace_line(ptext, "scale_max", "scale_max 0.5"), "", "tracking.scale_min / scale_max",
            "tracking bounds exclude the model");
    refused(replace_line(ptext, "damping_max", ""), "", "passivity.damping_max", "missing passivity field");
    refused(replace_line(ptext, "reserve", "reserve -1"), "", "passivity.reserve", "negative reserve");
    refused(replace_line(ptext, "dissipation_coulomb", "dissipation_coulomb 1 2"), "", "dissipation_coulomb",
            "wrong count of dissipation_coulomb");
    refused(replace_line(ptext, "dissipation_coulomb", "dissipation_coulomb 1e308 0.1 0.1 0.1"), "",
            "must be in [0, 1e6]", "a certified Coulomb level of 1e308 N·m");
    refused(replace_line(ptext, "enabled", "enabled 2"), "", "enabled", "enabled not 0/1");
    refused(replace_line(ptext, "reserve", "reserve 1\nspeed 3"), "", "speed", "unknown passivity field");
    std::string v2 = ptext;
    v2.replace(v2.find("section passivity 1"), 19, "section passivity 2");
    refused(v2, "", "section passivity: version 2", "passivity version 2");
  }

  // Bad files: each refused, the message naming the field.
  refused(replace_line(text, "motor_radius", ""), "", "motor_radius", "missing transmission field");
  refused(replace_line(replace_line(replace_line(replace_line(text, "motor_radius", ""), "K", ""), "driven_radius", ""),
                       "reducer_ratio", ""), "", "motor_radius", "missing transmission");
  refused(replace_line(text, "mass", "mass 2 nan 1.2 0.8"), "", "mass", "NaN mass");
  {
    std::string line = "tau0 nan";
    for (int k = 1; k < m.transmission.n * m.transmission.n; ++k) line += " 1";
    refused(replace_line(text, "tau0", line), "", "tau0", "NaN tau0");
    // Physical bounds (issue 34): a Coulomb level of 1e308 N is finite but refused, the bound in the message.
    std::string huge = "tau0 1e308";
    for (int k = 1; k < m.transmission.n * m.transmission.n; ++k) huge += " 1";
    refused(replace_line(text, "tau0", huge), "", "<= 1e6 [N]", "tau0 beyond its bound");
    refused(replace_line(text, "pretension", "pretension 1e7 50 50 50"), "", "pretension[0] = 10000000: must be <= 1e6",
            "pretension beyond its bound");
  }
  refused(replace_line(text, "underestimation", "underestimation 2"), "", "underestimation", "k out of range");
  refused(replace_line(text, "velocity_cutoff_hz", ""), "", "velocity_cutoff_hz", "missing setting");
  refused(text, "CEA branch", "device", "another device (name)");
  refused(replace_line(replace_line(text, "parent", "parent -1 0 1"), "mass", "mass 1 1 1"), "", "parent",
          "wrong count");
  {  // a chain of another device: 3 joints for 4 transmissions
    tendyn::CompensatorModel m3 = m;
    m3.chain = tendyn::ChainModel(3);
    refused(tendyn::compensator_model_text(m3), "", "chain.n", "chain of another device");
  }
  {
    std::string other = text.substr(0, text.find("section chain"));
    refused(other, "", "section chain", "no chain section");
  }
  if (failures) std::printf("%d failures\n", failures);
  return failures ? 1 : 0;
}
