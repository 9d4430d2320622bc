// Named parameters for strategies (pbrt-style): every strategy reads its own
// parameters with documented defaults; a parameter nobody read is an error that
// names where it came from.
#pragma once

#include "core/error.h"

#include <nlohmann/json.hpp>

#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

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
    if (!j_.contains(key)) return def;
    try {
      return j_.at(key).get<T>();
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

 private:
  nlohmann::json j_;
  std::string where_;
  std::set<std::string> used_;
};

// Registry by name for one interface. Ctx carries what construction needs (e.g. the
// displacement map); factories read their ParamSet.
template <typename Base, typename Ctx>
class Registry {
 public:
  using Factory = std::function<std::unique_ptr<Base>(ParamSet&, const Ctx&)>;

  static Registry& instance() {
    static Registry r;
    return r;
  }
  void add(const std::string& name, Factory f) { factories_[name] = std::move(f); }
  bool has(const std::string& name) const { return factories_.count(name) != 0; }
  std::vector<std::string> names() const {
    std::vector<std::string> n;
    for (const auto& [k, v] : factories_) n.push_back(k);
    return n;
  }
  // Unknown names and unused parameters are errors naming params.where().
  std::unique_ptr<Base> create(const std::string& name, ParamSet& params, const Ctx& ctx) const {
    auto it = factories_.find(name);
    if (it == factories_.end()) {
      std::string list;
      for (const auto& [k, v] : factories_) list += (list.empty() ? "" : ", ") + k;
      fail(params.where(), "unknown strategy '{}' (known: {})", name, list);
    }
    auto obj = it->second(params, ctx);
    params.checkUnused();
    return obj;
  }

 private:
  std::map<std::string, Factory> factories_;
};

}  // namespace oblong
