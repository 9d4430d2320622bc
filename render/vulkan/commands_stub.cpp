// Built instead of commands.cpp when the Vulkan target is not (see commands.h).
#include "render/vulkan/commands.h"

#include "core/error.h"

namespace oblong::vk {

namespace {
[[noreturn]] void noVulkan() {
  fail("--device vulkan", "this oblong was built without Vulkan (install libvulkan-dev, glslc and spirv-tools: "
                          "scripts/setup.sh; CMake option OBLONG_VULKAN)");
}
}  // namespace

int traceCommand(const Scene&, const AccelOptions&, const std::vector<Ray>&, const std::string&, const std::string&,
                 const std::string&, const std::atomic<bool>*) {
  noVulkan();
}

int renderCommand(const Scene&, const AccelOptions&, const RenderOptions&, const std::string&, const std::string&,
                  const std::string&, const std::string&) {
  noVulkan();
}

int bakeCommand(const Scene&, const AccelOptions&, ivec2, const std::vector<Ray>&, const std::string&,
                const std::string&) {
  noVulkan();
}

}  // namespace oblong::vk
