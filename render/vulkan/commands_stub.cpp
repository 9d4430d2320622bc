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

std::unique_ptr<TraceBackend> makeScene(const Scene&, const AccelOptions&) { noVulkan(); }

int bakeCommand(const Scene&, const AccelOptions&, ivec2, const std::vector<Ray>&, const std::string&,
                const std::string&) {
  noVulkan();
}

}  // namespace oblong::vk
