#include "core/params.h"

namespace oblong {

ParamSet::ParamSet(nlohmann::json j, std::string where) : j_(std::move(j)), where_(std::move(where)) {
  if (j_.is_null()) j_ = nlohmann::json::object();
  if (!j_.is_object()) fail(where_, "parameters must be a JSON object, got {}", j_.dump());
}

void ParamSet::checkUnused() const {
  for (const auto& [key, value] : j_.items())
    if (!used_.count(key)) fail(where_, "unknown parameter '{}'", key);
}

}  // namespace oblong
