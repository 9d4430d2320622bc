// The scene file's traversal configuration (accel_options.h).
#include "render/accel_options.h"

namespace oblong {

TraversalConfig traversalConfigOf(const Scene& scene) {
  TraversalConfig c;
  c.range = scene.range.name;
  c.rangeParams = scene.range.params;
  c.inverter = scene.inverter.name;
  c.inverterParams = scene.inverter.params;
  c.splitter = scene.splitter.name;
  c.splitterParams = scene.splitter.params;
  c.baseline = scene.baseline.name;
  c.source = scene.path;
  c.baselineParams = scene.baseline.params;
  c.marchingScale = scene.marchingScale;
  c.inversionInTraversal = scene.inversionInTraversal;
  c.stackDepth = scene.stackDepth;
  c.lodPerRay = scene.lodCone;
  return c;
}

}  // namespace oblong
