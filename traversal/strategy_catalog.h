// What is registered, in one place: the strategy names and traits of each interface,
// every combination the conformance suites run, the choices the CLI help lists and the
// JSON `oblong info --strategies --json` prints for the experiments. Everything here
// reads the registries (core/registry.h), so a strategy that registers itself appears
// in all of them without another edit.
#pragma once

#include "core/registry.h"
#include "traversal/intersector.h"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace oblong {

enum class StrategyKind { Range, Inverter, Splitter };

std::vector<std::string> strategyNames(StrategyKind kind);
const StrategyTraits& strategyTraits(StrategyKind kind, const std::string& name);
// "rmip | minmax_mipmap | safety_zones": the choices as --help lists them.
std::string strategyChoices(StrategyKind kind);

// The registered baselines (BaselineRegistry), as --baseline accepts them: those the
// scene builds (StrategyTraits::builtByScene: "tessellated", registered by render/
// where the program links it) first, then the intersectors, each by name.
std::vector<std::string> baselineNames();
// The registered intersector baselines that claim exactness: every one but the
// approximate ones, those the scene builds and the oracle itself ("bruteforce"), for
// the conformance suites.
std::vector<std::string> exactBaselines();

// One registered range query × inverter × splitter combination with default parameters.
struct StrategyCombination {
  TraversalConfig config;
  bool slowReference = false;  // one of its strategies is a slow reference (e.g. ceres)
};
std::vector<StrategyCombination> allCombinations();

// The Vulkan path's coverage, read from the traits (StrategyTraits::vulkanKernel): the
// strategies of `cfg` (its baseline, else its range query, inverter and splitter) that
// have no Vulkan kernel, each as "NAME (ROLE)"; empty where `cfg` runs there.
std::vector<std::string> missingVulkanKernels(const TraversalConfig& cfg);
// The kernel that chooses `cfg`'s intersection program on Vulkan: its baseline's
// (StrategyTraits::vulkanKernel), else its range query's; render/vulkan/records.cpp maps
// it to the records and the shader.
std::string vulkanIntersectorKernel(const TraversalConfig& cfg);
// The traversal's combinations that run on Vulkan (every kernel present), then the
// baselines that do ("tfdm"), as one line: "rmip+newton+midpoint2d, --baseline tfdm".
std::string vulkanCoverage();

// {"range": [{"name", "summary", "slow_reference", "devices", "vulkan_kernel"}...],
//  "inverter": [...], "splitter": [...], "baselines": [{"name", "summary", "approximate",
//  "devices", "vulkan_kernel"}...], "default": {...}}; "devices" is ["cpu"] or
//  ["cpu", "vulkan"].
nlohmann::json strategiesJson();

}  // namespace oblong
