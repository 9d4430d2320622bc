// Named parameters for strategies (pbrt-style): every strategy reads its own
// parameters with documented defaults; a parameter nobody read is an error that
// names where it came from. Every value read is recorded, so a strategy's resolved
// parameters (defaults included) can be reported (--stats, oblong info).
#pragma once

#include "core/error.h"

#include <nlohmann/json.hpp>

#include <set>
#include <string>

namespace oblong {

class ParamSet {
 public:
  ParamSet() : j_(nlohmann::json::object()) {}
  // `where` names the source in errors, e.g. "scene.json: strategies.range".
  ParamSet(nlohmann::json j, std::string where);

  bool has(const std::string& key) const { return j_.contains(key); }
  const std::string& where() const { return where_; }

  template <typename T>
  T get(const std::string& key, const T& def) {
    used_.insert(key);
    if (!j_.contains(key)) {
      resolved_[key] = def;
      return def;
    }
    try {
      T v = j_.at(key).get<T>();
      resolved_[key] = v;
      return v;
    } catch (const nlohmann::json::exception&) {
      fail(where_, "parameter '{}' has the wrong type ({})", key, j_.at(key).dump());
    }
  }
  // Errors unless the value lies in [lo, hi].
  template <typename T>
  T getInRange(const std::string& key, const T& def, const T& lo, const T& hi) {
    const T v = get<T>(key, def);
    if (!(v >= lo && v <= hi)) fail(where_, "parameter '{}' = {} is outside [{}, {}]", key, v, lo, hi);
    return v;
  }
  // Throws for the first parameter that no strategy read.
  void checkUnused() const;
  // Every parameter read so far with the value used (the default when it was not
  // given): what a run actually ran with.
  const nlohmann::json& resolved() const { return resolved_; }

 private:
  nlohmann::json j_;
  std::string where_;
  std::set<std::string> used_;
  nlohmann::json resolved_ = nlohmann::json::object();
};

}  // namespace oblong
