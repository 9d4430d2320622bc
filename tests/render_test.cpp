// The renderer: deterministic for a seed whatever the thread count, AOVs in one EXR,
// the heat map, and the integrators' basic behaviour.
#include "core/procedural.h"
#include "render/embree_scene.h"
#include "render/renderer.h"
#include "test_util.h"

#include <OpenImageIO/imageio.h>
#include <catch2/catch.hpp>

using namespace oblong;

namespace {
const EmbreeScene& defaultAccel() {
  static const Scene s = defaultScene();
  static const EmbreeScene a(s, AccelOptions{});
  return a;
}
}  // namespace

TEST_CASE("render: the same seed gives the same image with 1 or 2 threads", "[render]") {
  const Scene s = defaultScene();
  for (Integrator integ : {Integrator::Primary, Integrator::AO, Integrator::Path}) {
    RenderOptions o;
    o.size = {48, 36};
    o.spp = 2;
    o.integrator = integ;
    o.seed = 7;
    o.progress = false;
    o.threads = 1;
    const RenderResult a = render(s, defaultAccel(), o);
    o.threads = 2;
    const RenderResult b = render(s, defaultAccel(), o);
    INFO(integratorName(integ));
    REQUIRE(a.aov.color.pixels == b.aov.color.pixels);
    CHECK(a.aov.steps == b.aov.steps);
    CHECK(a.counters.steps() == b.counters.steps());
    o.seed = 8;
    const RenderResult c = render(s, defaultAccel(), o);
    if (integ != Integrator::Primary) CHECK(c.aov.color.pixels != a.aov.color.pixels);
  }
}

TEST_CASE("render: AOVs go to one multi-channel EXR, steps to a heat map", "[render]") {
  const Scene s = defaultScene();
  RenderOptions o;
  o.size = {40, 30};
  o.integrator = Integrator::Primary;
  o.progress = false;
  const RenderResult r = render(s, defaultAccel(), o);
  // Primary: colour is the shading normal, 0.5 n + 0.5, on every hit pixel.
  size_t hitPixels = 0, traversed = 0;
  for (size_t i = 0; i < r.aov.depth.size(); ++i) {
    if (!std::isfinite(r.aov.depth[i])) {
      CHECK(r.aov.normal[i] == vec3(0.0f));
      continue;
    }
    ++hitPixels;
    traversed += r.aov.steps[i] > 0;  // the ground is a plain triangle: no steps there
    CHECK(glm::length(r.aov.normal[i]) == Approx(1.0f).margin(1e-4));
    CHECK(r.aov.color.pixels[i].x == Approx(0.5f * r.aov.normal[i].x + 0.5f));
  }
  CHECK(hitPixels > r.aov.depth.size() / 3);
  CHECK(traversed > hitPixels / 3);
  const auto dir = test::scratchDir("render");
  const std::string exr = (dir / "aovs.exr").string(), png = (dir / "steps.png").string();
  writeAOVs(r.aov, exr);
  writeHeatMap(r.aov, png);
  auto in = OIIO::ImageInput::open(exr);
  REQUIRE(in);
  const OIIO::ImageSpec& spec = in->spec();
  CHECK(spec.nchannels == 11);
  CHECK(spec.channelnames.at(3) == "Z");
  CHECK(spec.channelnames.at(7) == "steps");
  std::vector<float> px(size_t(spec.width) * spec.height * spec.nchannels);
  REQUIRE(in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, px.data()));
  CHECK(px[size_t(15 * 40 + 20) * 11 + 7] == r.aov.steps[15 * 40 + 20]);
  in->close();
  auto hm = OIIO::ImageInput::open(png);
  REQUIRE(hm);
  CHECK(hm->spec().width == 40);
  CHECK(hm->spec().height > 30);  // with the colour bar
}
