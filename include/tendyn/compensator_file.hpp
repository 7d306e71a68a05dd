// tendyn — the compensator model file: a transmission model file plus two versioned sections.
//
// Written by Python (`tendyn.control.Compensator.export(path)`, through save_compensator_model below) from
// a device and its identified friction (FRICTION.json), read by C++ (load_compensator_model) and C
// (tendyn_compensator_load in c_api.h). Setup time only: these functions allocate and do file I/O.
//
// Format: the transmission model file (model_file.hpp, `tendyn-transmission-model 1` and one line per
// transmission field), then
//
//     section chain 1
//     device L-EXOS                          (the rest of the line: the device name)
//     n 4
//     gravity 0 0 -9.81                      [m/s²], base frame
//     parent -1 0 1 2                        0-based parent joint, −1 = base
//     placement r00 r01 r02 r10 … r22 px py pz   (12 values per joint: rotation row-major, then origin [m],
//                                                 of the joint frame in the parent joint frame at q = 0)
//     axis 0 0 1 …                           (3 per joint, unit, joint frame)
//     prismatic 0 0 0 0
//     mass 2 2 1.2 0.8                       [kg]
//     com 0.05 0 0 …                         (3 per joint) [m], joint frame
//     ee_joint 3                             0-based joint carrying the end effector
//     ee_point 0.32 0 0                      [m], in that joint frame
//     active_map 1 0 0 …                     (optional, closed-loop trees: n × n_a values row-major, n_a = the
//                                             transmissions; q = L q_a + c, chain.hpp)
//     active_offset 0 0 1.57 …               (with active_map: n values, c [rad or m])
//     section compensator 1
//     underestimation 0.9                    k [-] in [0, 1.5]
//     velocity_band 0.5                      [rad/s], motor side
//     velocity_cutoff_hz 30                  [Hz]
//     rate_hz 1000                           [Hz]
//     section losses 1                       (optional; absent = every loss term from the device file)
//     tau0 identified                        source of each loss term: device, identified or none
//     nu identified
//     beta none
//     bearings none
//     reducer_efficiency identified
//     friction friction.json                 (optional: where the identified friction came from)
//     section passivity 1                    (optional: absent = no passivity controller, passivity.hpp)
//     enabled 1                              0 or 1
//     dissipation_coulomb 0.01 …             c_i [N·m] per motor, certified lower bound of its Coulomb friction
//     dissipation_viscous 1e-4 …             b_i [N·m·s/rad] per motor, the same for its viscous friction
//     reserve 0.005                          [J], most dissipated energy the observer banks per motor
//     damping_max 0.05                       α_max [N·m·s/rad], bound of the controller's damping
//     section tracking 1                     (optional: absent = no online friction tracking, friction_tracking.hpp)
//     enabled 1                              0 or 1
//     forgetting 0.9999                      λ [-] in (0.9, 1]
//     velocity_min 2                         [rad/s], no update below
//     acceleration_max 10                    [rad/s²], no update above
//     scale_min 0.2                          bounds of the tracked scales [-]
//     scale_max 3
//     covariance_max 1                       bound on trace(P) [-]
//
// Section losses records one loss model at a time (CompensatorModel::loss_source): identified and device terms
// never mix, and a term recorded as none must be lossless in the transmission part; a file that breaks this is
// refused. Every field of the chain and compensator sections is required, once (of section losses: the five
// terms; of sections passivity and tracking, when there, every field: files without them still load); unknown sections, versions or fields, wrong counts,
// values that are not numbers (NaN and Inf are refused) and a model that fails validation are errors whose
// message names the file, the line and the field (`lexos.comp: line 31: mass: 3 values, expected 4`).
// A caller may name the device it expects: a file for another device is refused, naming `device`.
#pragma once

#include "tendyn/compensator.hpp"
#include "tendyn/model_file.hpp"

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace tendyn {

inline constexpr int chain_section_version = 1;
inline constexpr int compensator_section_version = 1;
inline constexpr int losses_section_version = 1;
inline constexpr int passivity_section_version = 1;
inline constexpr int tracking_section_version = 1;

/// Text of the compensator model file of `m` (format above).
inline std::string compensator_model_text(const CompensatorModel& m) {
  std::string out = transmission_model_text(m.transmission);
  const ChainModel& c = m.chain;
  auto line = [&](const char* key, const double* v, int count) {
    out += key;
    for (int k = 0; k < count; ++k) out += " " + format_double(v[k]);
    out += "\n";
  };
  out += "section chain " + std::to_string(chain_section_version) + "\n";
  out += "# kinematics and gravity of the driven chain (include/tendyn/chain.hpp), indices 0-based\n";
  out += "device " + (m.device.empty() ? std::string("unnamed") : m.device) + "\n";
  out += "n " + std::to_string(c.n) + "\n";
  line("gravity", c.gravity.data(), 3);
  std::vector<double> v;
  for (int j = 0; j < c.n; ++j) v.push_back(c.parent(j));
  line("parent", v.data(), c.n);
  v.clear();
  for (int j = 0; j < c.n; ++j) {
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k) v.push_back(c.rotation[j](r, k));
    for (int r = 0; r < 3; ++r) v.push_back(c.translation[j](r));
  }
  line("placement", v.data(), 12 * c.n);
  v.clear();
  for (int j = 0; j < c.n; ++j) v.insert(v.end(), c.axis[j].data(), c.axis[j].data() + 3);
  line("axis", v.data(), 3 * c.n);
  v.clear();
  for (int j = 0; j < c.n; ++j) v.push_back(c.prismatic(j));
  line("prismatic", v.data(), c.n);
  line("mass", c.mass.data(), c.n);
  v.clear();
  for (int j = 0; j < c.n; ++j) v.insert(v.end(), c.com[j].data(), c.com[j].data() + 3);
  line("com", v.data(), 3 * c.n);
  const double ee = c.ee_joint;
  line("ee_joint", &ee, 1);
  line("ee_point", c.ee_point.data(), 3);
  if (c.active_map.size()) {  // written only for closed-loop trees: serial files stay as they were
    v.clear();
    for (int j = 0; j < c.active_map.rows(); ++j)
      for (int k = 0; k < c.active_map.cols(); ++k) v.push_back(c.active_map(j, k));
    line("active_map", v.data(), static_cast<int>(v.size()));
    line("active_offset", c.active_offset.data(), static_cast<int>(c.active_offset.size()));
  }
  out += "section compensator " + std::to_string(compensator_section_version) + "\n";
  out += "# settings: k [-], velocity band [rad/s] motor side, filter cut-off [Hz], control rate [Hz]\n";
  line("underestimation", &m.underestimation, 1);
  line("velocity_band", &m.velocity_band, 1);
  line("velocity_cutoff_hz", &m.velocity_cutoff_hz, 1);
  line("rate_hz", &m.rate_hz, 1);
  out += "section losses " + std::to_string(losses_section_version) + "\n";
  out += "# source of each loss term: device (the device file), identified (FRICTION.json), none (lossless)\n";
  for (int k = 0; k < loss_term_count; ++k)
    out += std::string(loss_terms[k]) + " " + loss_source_names[static_cast<int>(m.loss_source[k])] + "\n";
  if (!m.friction_source.empty()) out += "friction " + m.friction_source + "\n";
  const PassivityModel& p = m.passivity;
  if (p.enabled) {  // written only when on: files of compensators without it stay as they were
    out += "section passivity " + std::to_string(passivity_section_version) + "\n";
    out += "# passivity observer + controller at the motor ports (include/tendyn/passivity.hpp), motor side\n";
    const double on = 1.0;
    line("enabled", &on, 1);
    line("dissipation_coulomb", p.dissipation_coulomb.data(), static_cast<int>(p.dissipation_coulomb.size()));
    line("dissipation_viscous", p.dissipation_viscous.data(), static_cast<int>(p.dissipation_viscous.size()));
    line("reserve", &p.reserve, 1);
    line("damping_max", &p.damping_max, 1);
  }
  const FrictionTrackingModel& t = m.tracking;
  if (t.enabled) {
    out += "section tracking " + std::to_string(tracking_section_version) + "\n";
    out += "# online friction tracking, RLS with forgetting (include/tendyn/friction_tracking.hpp)\n";
    const double on = 1.0;
    line("enabled", &on, 1);
    line("forgetting", &t.forgetting, 1);
    line("velocity_min", &t.velocity_min, 1);
    line("acceleration_max", &t.acceleration_max, 1);
    line("scale_min", &t.scale_min, 1);
    line("scale_max", &t.scale_max, 1);
    line("covariance_max", &t.covariance_max, 1);
  }
  return out;
}

/// Write the compensator model file atomically (temporary file, then rename).
inline bool save_compensator_model(const CompensatorModel& m, const std::string& path, std::string* error) {
  const std::string problem = m.first_issue();
  if (!problem.empty()) {
    if (error) *error = path + ": not written: " + problem;
    return false;
  }
  return write_text_atomically(compensator_model_text(m), path, error);
}

/// Parse compensator-file text. `expected_device` (may be empty) must equal the file's `device`.
inline bool parse_compensator_model(const std::string& text, const std::string& name, const std::string& expected_device,
                                    CompensatorModel* out, std::string* error) {
  auto fail = [&](int line, const std::string& what) {
    if (error) *error = name + (line > 0 ? ": line " + std::to_string(line) : std::string()) + ": " + what;
    return false;
  };
  CompensatorModel m;
  if (!parse_transmission_model(text, name, &m.transmission, error)) return false;

  static const char* chain_keys[] = {"device", "n",  "gravity",  "parent",     "placement",    "axis", "prismatic",
                                     "mass",   "com", "ee_joint", "ee_point", "active_map", "active_offset"};
  static const char* comp_keys[] = {"underestimation", "velocity_band", "velocity_cutoff_hz", "rate_hz"};
  static const char* pass_keys[] = {"enabled", "dissipation_coulomb", "dissipation_viscous", "reserve", "damping_max"};
  static const char* track_keys[] = {"enabled",   "forgetting", "velocity_min", "acceleration_max",
                                     "scale_min", "scale_max",  "covariance_max"};
  constexpr int n_chain = 13, n_chain_required = 11, n_comp = 4, n_pass = 5, n_track = 7;
  int chain_seen[n_chain] = {0}, comp_seen[n_comp] = {0}, pass_seen[n_pass] = {0}, track_seen[n_track] = {0};
  static const char* section_names[] = {"", "chain", "compensator", "losses", "passivity", "tracking"};
  int section = 0;  // 0 transmission part, 1 chain, 2 compensator, 3 losses, 4 passivity, 5 tracking
  int section_line[6] = {0, 0, 0, 0, 0, 0};
  int loss_seen[loss_term_count + 1] = {0};  // the five terms, then `friction`
  int n = -1;
  std::istringstream in(text);
  std::string line;
  int lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    std::istringstream ls(line);
    std::string key;
    if (!(ls >> key)) continue;
    if (key == "section") {
      std::string sname;
      int version = 0;
      if (!(ls >> sname >> version)) return fail(lineno, "section: expected 'section <name> <version>'");
      int which = 0;
      for (int k = 1; k < 6; ++k)
        if (sname == section_names[k]) which = k;
      if (!which)
        return fail(lineno, "section " + sname +
                                ": unknown section (known: chain, compensator, losses, passivity, tracking)");
      static const int versions[] = {0, chain_section_version, compensator_section_version, losses_section_version,
                                     passivity_section_version, tracking_section_version};
      const int want = versions[which];
      if (version != want)
        return fail(lineno, "section " + sname + ": version " + std::to_string(version) +
                                " is not supported (this build reads " + std::to_string(want) + ")");
      if (section_line[which]) return fail(lineno, "section " + sname + ": given twice");
      section = which;
      section_line[which] = lineno;
      continue;
    }
    if (section == 0) continue;  // the transmission part, parsed above
    if (section == 3) {          // loss sources: `<term> device|identified|none`, `friction <origin>`
      std::string rest;
      std::getline(ls, rest);
      const auto b = rest.find_first_not_of(" \t"), e = rest.find_last_not_of(" \t\r");
      rest = b == std::string::npos ? std::string() : rest.substr(b, e - b + 1);
      int idx = -1;
      for (int k = 0; k < loss_term_count; ++k)
        if (key == loss_terms[k]) idx = k;
      if (key == "friction") idx = loss_term_count;
      if (idx < 0)
        return fail(lineno, key + ": unknown field of section losses (known: tau0, nu, beta, bearings, "
                                  "reducer_efficiency, friction)");
      if (loss_seen[idx]) return fail(lineno, key + ": given twice (first on line " + std::to_string(loss_seen[idx]) + ")");
      loss_seen[idx] = lineno;
      if (idx == loss_term_count) {
        m.friction_source = rest;
        continue;
      }
      int src = -1;
      for (int k = 0; k < 3; ++k)
        if (rest == loss_source_names[k]) src = k;
      if (src < 0) return fail(lineno, key + ": '" + rest + "' is not a source (device, identified or none)");
      m.loss_source[idx] = static_cast<LossSource>(src);
      continue;
    }
    const char* const* all_keys[] = {nullptr, chain_keys, comp_keys, nullptr, pass_keys, track_keys};
    const int counts[] = {0, n_chain, n_comp, 0, n_pass, n_track};
    int* all_seen[] = {nullptr, chain_seen, comp_seen, nullptr, pass_seen, track_seen};
    const char* const* keys = all_keys[section];
    const int count = counts[section];
    int* seen = all_seen[section];
    int idx = -1;
    for (int k = 0; k < count; ++k)
      if (key == keys[k]) idx = k;
    if (idx < 0) {
      std::string known;
      for (int k = 0; k < count; ++k) known += std::string(k ? ", " : "") + keys[k];
      return fail(lineno, key + ": unknown field of section " + section_names[section] + " (known: " + known + ")");
    }
    if (seen[idx]) return fail(lineno, key + ": given twice (first on line " + std::to_string(seen[idx]) + ")");
    seen[idx] = lineno;
    if (section == 1 && idx == 0) {
      std::string rest;
      std::getline(ls, rest);
      const auto b = rest.find_first_not_of(" \t"), e = rest.find_last_not_of(" \t\r");
      m.device = b == std::string::npos ? std::string() : rest.substr(b, e - b + 1);
      if (m.device.empty()) return fail(lineno, "device: missing name");
      if (!expected_device.empty() && m.device != expected_device)
        return fail(lineno, "device: the file is for '" + m.device + "', expected '" + expected_device + "'");
      continue;
    }
    std::vector<double> values;
    if (const std::string bad = read_numbers(ls, &values); !bad.empty()) return fail(lineno, key + ": " + bad);
    auto expect = [&](int want, const char* shape) {
      if (static_cast<int>(values.size()) == want) return true;
      fail(lineno, key + ": " + std::to_string(values.size()) + " values, expected " + std::to_string(want) + " (" +
                       shape + ")");
      return false;
    };
    auto integer = [](double v) { return v == std::floor(v) && std::abs(v) < 1e9; };
    if (section == 5) {
      if (!expect(1, "one number")) return false;
      FrictionTrackingModel& t = m.tracking;
      if (idx == 0) {
        if (values[0] != 0.0 && values[0] != 1.0) return fail(lineno, "enabled: must be 0 or 1");
        t.enabled = values[0] == 1.0;
        continue;
      }
      double* dst[] = {nullptr,      &t.forgetting, &t.velocity_min,  &t.acceleration_max,
                       &t.scale_min, &t.scale_max,  &t.covariance_max};
      *dst[idx] = values[0];
      continue;
    }
    if (section == 4) {
      PassivityModel& p = m.passivity;
      const int nt = m.transmission.n;
      if (idx == 1 || idx == 2) {
        if (!expect(nt, "one per motor")) return false;
        (idx == 1 ? p.dissipation_coulomb : p.dissipation_viscous) = Eigen::Map<const Eigen::VectorXd>(values.data(), nt);
        continue;
      }
      if (!expect(1, "one number")) return false;
      if (idx == 0) {
        if (values[0] != 0.0 && values[0] != 1.0) return fail(lineno, "enabled: must be 0 or 1");
        p.enabled = values[0] == 1.0;
      } else {
        (idx == 3 ? p.reserve : p.damping_max) = values[0];
      }
      continue;
    }
    if (section == 2) {
      if (!expect(1, "one number")) return false;
      double* dst[] = {&m.underestimation, &m.velocity_band, &m.velocity_cutoff_hz, &m.rate_hz};
      *dst[idx] = values[0];
      continue;
    }
    if (idx == 1) {
      if (const std::string bad = check_model_size(values); !bad.empty()) return fail(lineno, "n: " + bad);
      n = static_cast<int>(values[0]);
      m.chain = ChainModel(n);
      continue;
    }
    if (n < 0) return fail(lineno, key + ": 'n' must come before it in section chain");
    switch (idx) {
      case 2:
        if (!expect(3, "x y z")) return false;
        m.chain.gravity = Eigen::Vector3d(values[0], values[1], values[2]);
        break;
      case 3:
        if (!expect(n, "n")) return false;
        for (int j = 0; j < n; ++j) {
          if (!integer(values[j])) return fail(lineno, "parent[" + std::to_string(j) + "]: must be an integer");
          m.chain.parent(j) = static_cast<int>(values[j]);
        }
        break;
      case 4:
        if (!expect(12 * n, "12 per joint: rotation row-major, origin")) return false;
        for (int j = 0; j < n; ++j) {
          for (int r = 0; r < 3; ++r)
            for (int k = 0; k < 3; ++k) m.chain.rotation[j](r, k) = values[12 * j + 3 * r + k];
          for (int r = 0; r < 3; ++r) m.chain.translation[j](r) = values[12 * j + 9 + r];
        }
        break;
      case 5:
        if (!expect(3 * n, "3 per joint")) return false;
        for (int j = 0; j < n; ++j) m.chain.axis[j] = Eigen::Vector3d(values[3 * j], values[3 * j + 1], values[3 * j + 2]);
        break;
      case 6:
        if (!expect(n, "n")) return false;
        for (int j = 0; j < n; ++j) {  // exactly 0 or 1: a cast would read 1.5 as 1 (and 1e300 is undefined)
          if (values[j] != 0.0 && values[j] != 1.0)
            return fail(lineno, "prismatic[" + std::to_string(j) + "]: must be 0 or 1");
          m.chain.prismatic(j) = static_cast<int>(values[j]);
        }
        break;
      case 7:
        if (!expect(n, "n")) return false;
        for (int j = 0; j < n; ++j) m.chain.mass(j) = values[j];
        break;
      case 8:
        if (!expect(3 * n, "3 per joint")) return false;
        for (int j = 0; j < n; ++j) m.chain.com[j] = Eigen::Vector3d(values[3 * j], values[3 * j + 1], values[3 * j + 2]);
        break;
      case 9:
        if (!expect(1, "one joint index")) return false;
        if (!integer(values[0])) return fail(lineno, "ee_joint: must be an integer");
        m.chain.ee_joint = static_cast<int>(values[0]);
        break;
      case 10:
        if (!expect(3, "x y z")) return false;
        m.chain.ee_point = Eigen::Vector3d(values[0], values[1], values[2]);
        break;
      case 11: {
        const int na = m.transmission.n;
        if (!expect(n * na, "n × transmissions, row-major")) return false;
        m.chain.active_map = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
            values.data(), n, na);
        break;
      }
      case 12:
        if (!expect(n, "n")) return false;
        m.chain.active_offset = Eigen::Map<const Eigen::VectorXd>(values.data(), n);
        break;
    }
  }
  if (!section_line[1]) return fail(0, "section chain: missing (a compensator file needs the chain and its gravity)");
  if (!section_line[2]) return fail(0, "section compensator: missing (its settings are required)");
  for (int k = 0; k < n_chain_required; ++k)
    if (!chain_seen[k]) return fail(0, std::string("chain.") + chain_keys[k] + ": missing required field");
  if (chain_seen[11] && !chain_seen[12]) return fail(0, "chain.active_offset: missing (active_map is given)");
  if (chain_seen[12] && !chain_seen[11]) return fail(0, "chain.active_map: missing (active_offset is given)");
  for (int k = 0; k < n_comp; ++k)
    if (!comp_seen[k]) return fail(0, std::string(comp_keys[k]) + ": missing required field");
  if (section_line[3])
    for (int k = 0; k < loss_term_count; ++k)
      if (!loss_seen[k]) return fail(0, std::string("losses.") + loss_terms[k] + ": missing required field");
  if (section_line[4])
    for (int k = 0; k < n_pass; ++k)
      if (!pass_seen[k]) return fail(0, std::string("passivity.") + pass_keys[k] + ": missing required field");
  if (section_line[5])
    for (int k = 0; k < n_track; ++k)
      if (!track_seen[k]) return fail(0, std::string("tracking.") + track_keys[k] + ": missing required field");
  const std::string problem = m.first_issue();
  if (!problem.empty()) return fail(0, problem);
  *out = std::move(m);
  return true;
}

/// Read a compensator model file. `expected_device` may be empty (no check). Returns false and sets
/// `error` (file, line, field, what is wrong) on failure.
inline bool load_compensator_model(const std::string& path, const std::string& expected_device, CompensatorModel* m,
                                   std::string* error) {
  std::string text, name;
  if (!read_model_file(path, "compensator model file", &text, &name, error)) return false;
  return parse_compensator_model(text, name, expected_device, m, error);
}

}  // namespace tendyn
