// Registry by name for one strategy interface (RangeQuery, Inverter, Splitter), with
// self-registration: a strategy's .cpp registers itself with one line,
//
//     OBLONG_REGISTER_RANGE_QUERY("global", makeGlobal);
//
// and everything that lists strategies (the conformance suites, the CLI help,
// `oblong info --strategies`, the experiments) reads the registry. The strategy
// libraries are linked whole-archive (CMakeLists.txt), so a registration object in a
// static library is never dropped by the linker.
#pragma once

#include "core/error.h"
#include "core/params.h"

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace oblong {

// What the registry knows of a strategy besides its factory.
struct StrategyTraits {
  // A reference implementation too slow for every ray of every test (ceres): the
  // conformance suites run it on a subset of the rays instead of leaving it out.
  bool slowReference = false;
  std::string summary;  // one line for --help and `oblong info --strategies`
  // Not exact by design (a baseline such as fixedstep): left out of the exactness tests.
  bool approximate = false;
  // A baseline that takes a level of detail per ray (Ray::lod; docs/lod.md): the
  // traversal does, and so must an oracle checked against it.
  bool perRayLod = false;
  // A baseline that is no Intersector: the scene builds it instead of user geometry
  // (`tessellated`: EmbreeScene builds the micro-triangles as Embree triangles,
  // registered in render/embree_scene.cpp). createIntersector refuses it, and the
  // intersectors' conformance suites leave it out (exactBaselines).
  bool builtByScene = false;
  // Its kernel on the Vulkan path (docs/extending.md, "On the GPU"): the shared source,
  // relative to the source tree, that the intersection shader compiles for it; empty
  // where it runs on the CPU only. `oblong info --strategies` and the Vulkan path's
  // refusal of a combination read it.
  std::string vulkanKernel = {};
};

template <typename Base, typename Ctx>
class Registry {
 public:
  using Factory = std::function<std::unique_ptr<Base>(ParamSet&, const Ctx&)>;

  static Registry& instance() {
    static Registry r;
    return r;
  }
  // A name registered twice is a programming error caught at start-up.
  void add(const std::string& name, Factory f, StrategyTraits traits = {}) {
    if (entries_.count(name)) fail("registry", "strategy '{}' is registered twice", name);
    entries_[name] = Entry{std::move(f), std::move(traits)};
  }
  void remove(const std::string& name) { entries_.erase(name); }
  bool has(const std::string& name) const { return entries_.count(name) != 0; }
  std::vector<std::string> names() const {
    std::vector<std::string> n;
    for (const auto& [k, v] : entries_) n.push_back(k);
    return n;
  }
  const StrategyTraits& traits(const std::string& name) const {
    auto it = entries_.find(name);
    if (it == entries_.end()) fail("registry", "unknown strategy '{}'", name);
    return it->second.traits;
  }
  // Unknown names and unused parameters are errors naming params.where().
  std::unique_ptr<Base> create(const std::string& name, ParamSet& params, const Ctx& ctx) const {
    auto it = entries_.find(name);
    if (it == entries_.end()) fail(params.where(), "unknown strategy '{}' (known: {})", name, list());
    auto obj = it->second.make(params, ctx);
    params.checkUnused();
    return obj;
  }
  std::string list() const {
    std::string s;
    for (const auto& [k, v] : entries_) s += (s.empty() ? "" : ", ") + k;
    return s;
  }

 private:
  struct Entry {
    Factory make;
    StrategyTraits traits;
  };
  std::map<std::string, Entry> entries_;
};

// A static object of this type registers a strategy before main() runs.
template <typename R>
struct AutoRegistration {
  AutoRegistration(const char* name, typename R::Factory f, StrategyTraits traits = {}) {
    R::instance().add(name, std::move(f), std::move(traits));
  }
};

#define OBLONG_REGISTRY_CAT_(a, b) a##b
#define OBLONG_REGISTRY_CAT(a, b) OBLONG_REGISTRY_CAT_(a, b)
// OBLONG_REGISTER(RegistryType, "name", factory[, StrategyTraits{...}]) at namespace scope.
#define OBLONG_REGISTER(R, name, ...) \
  static const ::oblong::AutoRegistration<R> OBLONG_REGISTRY_CAT(oblongRegistration_, __LINE__) { name, __VA_ARGS__ }

}  // namespace oblong
