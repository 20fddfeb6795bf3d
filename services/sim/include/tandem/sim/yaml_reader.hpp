// Strict walker over one YAML mapping, shared by the scenario and deployment loaders: it remembers which
// keys were read so that the rest can be reported as unknown, and every error names the file, the line,
// the key path and what is accepted.
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "tandem/sim/scenario_yaml.hpp"

namespace tandem::sim::yaml {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kPositive = 1e-12;  // lower bound standing for "strictly positive"

/// Walks one YAML mapping, remembering which keys were read so that the rest can be reported as unknown.
class MapReader {
 public:
  MapReader(const YAML::Node& node, std::string path, const std::string& file)
      : node_(node), path_(std::move(path)), file_(file) {
    if (!node_.IsMap()) fail(node_, path_, "expected a mapping (key: value pairs)");
  }

  [[noreturn]] void fail(const YAML::Node& n, const std::string& key, const std::string& what) const {
    std::ostringstream os;
    os << file_;
    if (n.IsDefined() && n.Mark().line >= 0) os << ":" << n.Mark().line + 1;
    os << ": '" << key << "': " << what;
    throw ConfigError(os.str());
  }

  std::string key_path(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

  bool has(const std::string& key) const { return static_cast<bool>(node_[key]); }

  YAML::Node take(const std::string& key, bool required) {
    accepted_.insert(key);
    YAML::Node n = node_[key];
    if (!n && required) fail(node_, key_path(key), "missing required field");
    return n;
  }

  double number(const YAML::Node& n, const std::string& key, double lo, double hi) const {
    if (!n.IsScalar()) fail(n, key, "expected a number" + range(lo, hi));
    double v = 0.0;
    try {
      v = n.as<double>();
    } catch (const YAML::Exception&) {
      fail(n, key, "expected a number" + range(lo, hi) + ", got '" + n.Scalar() + "'");
    }
    if (!std::isfinite(v) || v < lo || v > hi) {
      fail(n, key, "value " + n.Scalar() + " is out of range: accepted" + range(lo, hi));
    }
    return v;
  }

  void num(const std::string& key, double& out, double lo, double hi, bool required = false) {
    if (YAML::Node n = take(key, required)) out = number(n, key_path(key), lo, hi);
  }

  void integer(const std::string& key, int& out, int lo, int hi, bool required = false) {
    if (YAML::Node n = take(key, required)) {
      const double v = number(n, key_path(key), lo, hi);
      if (v != std::floor(v)) fail(n, key_path(key), "expected an integer, got '" + n.Scalar() + "'");
      out = static_cast<int>(v);
    }
  }

  void boolean(const std::string& key, bool& out, bool required = false) {
    if (YAML::Node n = take(key, required)) {
      try {
        if (!n.IsScalar()) throw YAML::Exception(n.Mark(), "");
        out = n.as<bool>();
      } catch (const YAML::Exception&) {
        fail(n, key_path(key), "expected true or false");
      }
    }
  }

  void text(const std::string& key, std::string& out, bool required = false) {
    if (YAML::Node n = take(key, required)) {
      if (!n.IsScalar()) fail(n, key_path(key), "expected a string");
      out = n.Scalar();
    }
  }

  void choice(const std::string& key, std::string& out, const std::vector<std::string>& allowed,
              bool required = false) {
    if (YAML::Node n = take(key, required)) {
      if (n.IsScalar()) {
        for (const auto& a : allowed) {
          if (a == n.Scalar()) {
            out = a;
            return;
          }
        }
      }
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      fail(n, key_path(key), "expected one of: " + list + (n.IsScalar() ? ", got '" + n.Scalar() + "'" : ""));
    }
  }

  template <int N>
  void vec(const std::string& key, Eigen::Matrix<double, N, 1>& out, double lo, double hi,
           bool required = false) {
    if (YAML::Node n = take(key, required)) out = vector_of<N>(n, key_path(key), lo, hi);
  }

  /// A number or a list of N numbers (a number is broadcast).
  template <int N>
  void vec_or_scalar(const std::string& key, Eigen::Matrix<double, N, 1>& out, double lo, double hi) {
    if (YAML::Node n = take(key, false)) {
      if (n.IsScalar()) {
        out.setConstant(number(n, key_path(key), lo, hi));
      } else {
        out = vector_of<N>(n, key_path(key), lo, hi);
      }
    }
  }

  template <int N>
  Eigen::Matrix<double, N, 1> vector_of(const YAML::Node& n, const std::string& key, double lo, double hi) const {
    if (!n.IsSequence() || n.size() != N) {
      fail(n, key, "expected a list of " + std::to_string(N) + " numbers" + range(lo, hi));
    }
    Eigen::Matrix<double, N, 1> v;
    for (int i = 0; i < N; ++i) v(i) = number(n[i], key + "[" + std::to_string(i) + "]", lo, hi);
    return v;
  }

  MapReader child(const std::string& key, bool required = false) {
    YAML::Node n = take(key, required);
    if (!n) n = YAML::Node(YAML::NodeType::Map);
    return MapReader(n, key_path(key), file_);
  }

  YAML::Node sequence(const std::string& key, bool required) {
    YAML::Node n = take(key, required);
    if (n && !n.IsSequence()) fail(n, key_path(key), "expected a list");
    return n;
  }

  const std::string& path() const { return path_; }
  const std::string& file() const { return file_; }

  /// Reports a key given twice, or the first key that was never read (with the accepted keys).
  void finish() const {
    std::set<std::string> seen;
    for (const auto& kv : node_) {
      if (!seen.insert(kv.first.Scalar()).second) fail(kv.first, key_path(kv.first.Scalar()), "key given twice");
    }
    for (const auto& kv : node_) {
      const std::string k = kv.first.Scalar();
      if (accepted_.count(k) == 0) {
        std::string list;
        for (const auto& a : accepted_) list += (list.empty() ? "" : ", ") + a;
        fail(kv.first, key_path(k), "unknown key; accepted keys here: " + list);
      }
    }
  }

 private:
  static std::string range(double lo, double hi) {
    std::ostringstream os;
    if (lo == kPositive) {
      os << " > 0";
      if (hi < kInf) os << " and <= " << hi;
    } else if (lo > -kInf && hi < kInf) {
      os << " in [" << lo << ", " << hi << "]";
    } else if (lo > -kInf) {
      os << " >= " << lo;
    } else if (hi < kInf) {
      os << " <= " << hi;
    }
    return os.str();
  }

  YAML::Node node_;
  std::string path_;
  const std::string& file_;
  std::set<std::string> accepted_;
};


}  // namespace tandem::sim::yaml
