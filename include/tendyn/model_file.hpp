// tendyn — the transmission model file: a complete TransmissionModel (routing, losses, bearings) as text.
//
// Written by Python (`tendyn.transmission.Transmission.export(path)`, the same writer as
// save_transmission_model below) and read by C++ (load_transmission_model) and C
// (tendyn_transmission_load in c_api.h), so a controller loads the identified model instead of copying
// numbers by hand. Setup time only: these functions allocate and do file I/O; nothing here is on the
// real-time path.
//
// Format (version 1), one line per field of the parameter table (TENDYN_TRANSMISSION_FIELDS, routing.hpp):
//
//     tendyn-transmission-model 1
//     n 4
//     motor_radius 0.008 0.008 0.008 0.008
//     K 0.32 0 0 0 0.015 0.32 0 0 ...          (n x n, row-major)
//     ...
//
// A line is a field name followed by its values (n for a per-transmission field, n*n row-major for a
// matrix), separated by spaces; `#` starts a comment; blank lines are ignored. The header line and `n`
// come first. motor_radius, K, driven_radius and reducer_ratio are required; a missing loss or bearing
// field keeps its default (lossless, no bearings). Unknown fields, repeated fields, a wrong number of
// values, a value that is not a number and a model that fails validation are errors whose message names
// the file, the line and the field (`lexos.model: line 9: beta[2,1] = 1.5: must be < 1`). `n` is at most
// model_file_max_n (checked before anything is allocated, so a corrupt size cannot exhaust memory) and a NUL
// byte anywhere is refused (it would cut a number short: `5\0 0` must not read as 5). Values are
// written in the shortest form that reads back to the same double (15 or 17 significant digits), so a
// saved model reads back bit for bit.
//
// A line `section <name> <version>` ends the transmission part: a compensator model file continues with
// its sections there (include/tendyn/compensator_file.hpp); the transmission reader stops at it, so the
// transmission of a compensator file loads with tendyn_transmission_load too.
#pragma once

#include "tendyn/routing.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace tendyn {

inline constexpr const char* model_file_header = "tendyn-transmission-model";
inline constexpr int model_file_version = 1;
/// Largest `n` a model file may declare (transmissions, and joints of a compensator's chain): far above any
/// device of the kind (L-EXOS has 4), small enough that a corrupt size cannot make the loader allocate gigabytes.
inline constexpr int model_file_max_n = 64;

/// Text of the model file of `m` (format above).
inline std::string transmission_model_text(const TransmissionModel& m) {
  std::string out = std::string(model_file_header) + " " + std::to_string(model_file_version) + "\n";
  out += "# units: SI (m, N, N s/m, rad, rad/s, N m); matrices row-major [i, j], indices 0-based\n";
  out += "n " + std::to_string(m.n) + "\n";
  m.for_each_field([&](const FieldInfo& info, const auto& member) {
    out += info.name;
    for (int i = 0; i < member.rows(); ++i)
      for (int j = 0; j < member.cols(); ++j) out += " " + format_double(member(i, j));
    out += "\n";
  });
  return out;
}

/// Write `text` to `path` through `path`.tmp, then rename: a reader never sees a half-written file.
/// Returns false and sets `error` on failure (the temporary file is removed).
inline bool write_text_atomically(const std::string& text, const std::string& path, std::string* error) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) {
      if (error) *error = path + ": cannot open for writing";
      return false;
    }
    f << text;
    if (!f.good()) {
      if (error) *error = path + ": write failed";
      return false;
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    if (error) *error = path + ": cannot rename the temporary file";
    return false;
  }
  return true;
}

/// Write the model file atomically. Returns false and sets `error` on failure.
inline bool save_transmission_model(const TransmissionModel& m, const std::string& path, std::string* error) {
  return write_text_atomically(transmission_model_text(m), path, error);
}

/// Read the remaining whitespace-separated tokens of a model-file line as finite numbers into `values`.
/// Returns an empty string, or what is wrong ("'abc' is not a number", "'nan' is not finite") for the caller
/// to prefix with line and field. Shared by the transmission and compensator sections.
inline std::string read_numbers(std::istringstream& ls, std::vector<double>* values) {
  values->clear();
  std::string tok;
  while (ls >> tok) {
    char* end = nullptr;
    const double v = std::strtod(tok.c_str(), &end);
    if (end == tok.c_str() || *end != '\0') return "'" + tok + "' is not a number";
    if (!std::isfinite(v)) return "'" + tok + "' is not finite";
    values->push_back(v);
  }
  return std::string();
}

/// Read a whole model file into `text`; `name` gets its file name (without folders) for the messages.
/// Returns false and sets `error` ("PATH: cannot open the <what>") if it cannot be opened.
inline bool read_model_file(const std::string& path, const char* what, std::string* text, std::string* name,
                            std::string* error) {
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    if (error) *error = path + ": cannot open the " + what;
    return false;
  }
  std::stringstream ss;
  ss << f.rdbuf();
  *text = ss.str();
  const auto slash = path.find_last_of("/\\");
  *name = slash == std::string::npos ? path : path.substr(slash + 1);
  return true;
}

/// The 1-based line of the first NUL byte of `text`, 0 if there is none. A NUL is never part of a model file:
/// strtod would stop at it and read `5\0 0` as 5.
inline int line_of_nul(const std::string& text) {
  const auto at = text.find('\0');
  if (at == std::string::npos) return 0;
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
}

/// Check a size field (`n`) read as one number: an integer in 1 … model_file_max_n. Returns "" or what is wrong.
inline std::string check_model_size(const std::vector<double>& values) {
  if (values.size() != 1 || !(values[0] >= 1.0) || values[0] != std::floor(values[0]))
    return "must be one integer >= 1";
  if (values[0] > model_file_max_n)
    return "must be <= " + std::to_string(model_file_max_n) + " (model_file_max_n; got " + format_double(values[0]) + ")";
  return std::string();
}

/// Parse model-file text into `m` (validated, matrices computed). `name` prefixes the messages.
inline bool parse_transmission_model(const std::string& text, const std::string& name, TransmissionModel* m,
                                     std::string* error) {
  auto fail = [&](int line, const std::string& what) {
    if (error) *error = name + (line > 0 ? ": line " + std::to_string(line) : std::string()) + ": " + what;
    return false;
  };
  if (const int nul = line_of_nul(text)) return fail(nul, "a NUL byte (not a text model file)");
  std::istringstream in(text);
  std::string line;
  int lineno = 0, n = -1;
  bool header = false;
  TransmissionModel model;
  std::vector<int> seen(transmission_field_count, 0);
  while (std::getline(in, line)) {
    ++lineno;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    std::istringstream ls(line);
    std::string key;
    if (!(ls >> key)) continue;
    if (header && key == "section") break;  // a compensator file: its sections follow (compensator_file.hpp)
    if (!header) {
      int version = 0;
      if (key != model_file_header || !(ls >> version))
        return fail(lineno, std::string("not a tendyn model file (the first line must be '") + model_file_header +
                                " " + std::to_string(model_file_version) + "')");
      if (version != model_file_version)
        return fail(lineno, "format version " + std::to_string(version) + " is not supported (this build reads " +
                                std::to_string(model_file_version) + ")");
      header = true;
      continue;
    }
    std::vector<double> values;
    if (const std::string bad = read_numbers(ls, &values); !bad.empty()) return fail(lineno, key + ": " + bad);
    if (n < 0) {
      if (key != "n") return fail(lineno, "the line after the header must be 'n <number of transmissions >= 1>'");
      if (const std::string bad = check_model_size(values); !bad.empty()) return fail(lineno, "n: " + bad);
      n = static_cast<int>(values[0]);
      model = TransmissionModel(n);
      continue;
    }
    int index = -1;
    for (int k = 0; k < transmission_field_count; ++k)
      if (key == transmission_fields[k].name) index = k;
    if (index < 0) {
      std::string known;
      for (const auto& f : transmission_fields) known += std::string(known.empty() ? "" : ", ") + f.name;
      return fail(lineno, key + ": unknown field (known: " + known + ")");
    }
    if (seen[index]) return fail(lineno, key + ": given twice (first on line " + std::to_string(seen[index]) + ")");
    seen[index] = lineno;
    const int cols = transmission_fields[index].dims == 1 ? 1 : n;
    if (static_cast<int>(values.size()) != n * cols)
      return fail(lineno, key + ": " + std::to_string(values.size()) + " values, expected " + std::to_string(n * cols) +
                              (cols == 1 ? " (n)" : " (n*n, row-major)"));
    model.set_field(key.c_str(), values.data(), n, cols);
  }
  if (!header) return fail(0, "empty file (not a tendyn model file)");
  if (n < 0) return fail(0, "missing 'n' line");
  for (const char* req : {"motor_radius", "K", "driven_radius", "reducer_ratio"}) {
    int k = 0;
    while (std::string(transmission_fields[k].name) != req) ++k;
    if (!seen[k]) return fail(0, std::string(req) + ": missing required field");
  }
  model.update_matrices();  // the structure of K (blocks, dependent transmission) is part of the validation
  ValidationIssue issue;
  if (model.first_issue(&issue)) {
    int line_of = 0;
    for (int k = 0; k < transmission_field_count; ++k)
      if (std::string(issue.field).rfind(transmission_fields[k].name, 0) == 0) line_of = seen[k];
    return fail(line_of, describe(issue));
  }
  *m = std::move(model);
  return true;
}

/// Read a model file (format above) into `m`. Returns false and sets `error` (file, line, field, what is
/// wrong) on failure; `m` is unchanged then.
inline bool load_transmission_model(const std::string& path, TransmissionModel* m, std::string* error) {
  std::string text, name;
  if (!read_model_file(path, "model file", &text, &name, error)) return false;
  return parse_transmission_model(text, name, m, error);
}

}  // namespace tendyn
