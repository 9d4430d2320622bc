#include "traversal/strategy_catalog.h"

#include "inversion/inverter.h"
#include "strategies/range_query.h"
#include "strategies/splitter.h"

#include <algorithm>
#include <tuple>

namespace oblong {

std::vector<std::string> strategyNames(StrategyKind kind) {
  switch (kind) {
    case StrategyKind::Range: return rangeQueryNames();
    case StrategyKind::Inverter: return inverterNames();
    case StrategyKind::Splitter: return splitterNames();
  }
  return {};
}

const StrategyTraits& strategyTraits(StrategyKind kind, const std::string& name) {
  switch (kind) {
    case StrategyKind::Range: return rangeQueryTraits(name);
    case StrategyKind::Inverter: return inverterTraits(name);
    case StrategyKind::Splitter: break;
  }
  return splitterTraits(name);
}

std::string strategyChoices(StrategyKind kind) {
  std::string s;
  for (const std::string& n : strategyNames(kind)) s += (s.empty() ? "" : " | ") + n;
  return s;
}

std::vector<std::string> baselineNames() {
  const BaselineRegistry& reg = BaselineRegistry::instance();
  std::vector<std::string> n = reg.names();
  std::stable_partition(n.begin(), n.end(), [&](const std::string& b) { return reg.traits(b).builtByScene; });
  return n;
}

std::vector<std::string> exactBaselines() {
  std::vector<std::string> out;
  const BaselineRegistry& reg = BaselineRegistry::instance();
  for (const std::string& n : reg.names())
    if (n != "bruteforce" && !reg.traits(n).approximate && !reg.traits(n).builtByScene) out.push_back(n);
  return out;
}

std::vector<StrategyCombination> allCombinations() {
  std::vector<StrategyCombination> out;
  for (const std::string& r : strategyNames(StrategyKind::Range))
    for (const std::string& i : strategyNames(StrategyKind::Inverter))
      for (const std::string& s : strategyNames(StrategyKind::Splitter)) {
        StrategyCombination c;
        c.config.range = r, c.config.inverter = i, c.config.splitter = s;
        c.slowReference = strategyTraits(StrategyKind::Range, r).slowReference ||
                          strategyTraits(StrategyKind::Inverter, i).slowReference ||
                          strategyTraits(StrategyKind::Splitter, s).slowReference;
        out.push_back(std::move(c));
      }
  return out;
}

std::vector<std::string> missingVulkanKernels(const TraversalConfig& cfg) {
  std::vector<std::string> missing;
  if (!cfg.baseline.empty()) {
    if (BaselineRegistry::instance().traits(cfg.baseline).vulkanKernel.empty())
      missing.push_back(cfg.baseline + " (baseline)");
    return missing;
  }
  const std::tuple<StrategyKind, const std::string&, const char*> parts[] = {
      {StrategyKind::Range, cfg.range, "range"},
      {StrategyKind::Inverter, cfg.inverter, "inverter"},
      {StrategyKind::Splitter, cfg.splitter, "splitter"}};
  for (const auto& [kind, name, role] : parts)
    if (strategyTraits(kind, name).vulkanKernel.empty()) missing.push_back(name + " (" + role + ")");
  return missing;
}

std::string vulkanIntersectorKernel(const TraversalConfig& cfg) {
  return cfg.baseline.empty() ? strategyTraits(StrategyKind::Range, cfg.range).vulkanKernel
                              : BaselineRegistry::instance().traits(cfg.baseline).vulkanKernel;
}

std::string vulkanCoverage() {
  std::vector<std::string> runs;
  for (const StrategyCombination& c : allCombinations())
    if (missingVulkanKernels(c.config).empty())
      runs.push_back(c.config.range + "+" + c.config.inverter + "+" + c.config.splitter);
  for (const std::string& b : baselineNames()) {
    TraversalConfig cfg;
    cfg.baseline = b;
    if (missingVulkanKernels(cfg).empty()) runs.push_back("--baseline " + b);
  }
  std::string s;
  for (const std::string& r : runs) s += (s.empty() ? "" : ", ") + r;
  return s;
}

namespace {
nlohmann::json devicesOf(const StrategyTraits& t) {
  return t.vulkanKernel.empty() ? nlohmann::json{"cpu"} : nlohmann::json{"cpu", "vulkan"};
}
}  // namespace

nlohmann::json strategiesJson() {
  nlohmann::json j;
  const std::pair<const char*, StrategyKind> kinds[] = {
      {"range", StrategyKind::Range}, {"inverter", StrategyKind::Inverter}, {"splitter", StrategyKind::Splitter}};
  for (const auto& [key, kind] : kinds) {
    j[key] = nlohmann::json::array();
    for (const std::string& n : strategyNames(kind)) {
      const StrategyTraits& t = strategyTraits(kind, n);
      j[key].push_back({{"name", n},
                        {"summary", t.summary},
                        {"slow_reference", t.slowReference},
                        {"devices", devicesOf(t)},
                        {"vulkan_kernel", t.vulkanKernel}});
    }
  }
  j["baselines"] = nlohmann::json::array();
  const BaselineRegistry& reg = BaselineRegistry::instance();
  for (const std::string& n : baselineNames())
    j["baselines"].push_back({{"name", n},
                              {"summary", reg.traits(n).summary},
                              {"approximate", reg.traits(n).approximate},
                              {"devices", devicesOf(reg.traits(n))},
                              {"vulkan_kernel", reg.traits(n).vulkanKernel}});
  j["vulkan"] = vulkanCoverage();
  const TraversalConfig d;
  j["default"] = {{"range", d.range}, {"inverter", d.inverter}, {"splitter", d.splitter},
                  {"marching_scale", d.marchingScale}, {"inversion_in_traversal", d.inversionInTraversal}};
  return j;
}

}  // namespace oblong
