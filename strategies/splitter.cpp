// Splitter registry access (see splitter.h); the strategies register themselves.
#include "strategies/splitter.h"

namespace oblong {

std::unique_ptr<Splitter> createSplitter(const std::string& name, ParamSet& params) {
  return SplitterRegistry::instance().create(name, params, {});
}

std::unique_ptr<Splitter> createSplitter(const std::string& name) {
  ParamSet ps;
  return createSplitter(name, ps);
}

std::vector<std::string> splitterNames() { return SplitterRegistry::instance().names(); }
const StrategyTraits& splitterTraits(const std::string& name) { return SplitterRegistry::instance().traits(name); }

}  // namespace oblong
