// Drives the oblong binary as a user would: good runs produce files, bad input gives
// one error line naming the file and a non-zero exit.
#include "test_util.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <sys/wait.h>

namespace {

struct Run {
  int status;
  std::string out, err;
};

Run run(const std::string& args) {
  const auto dir = oblong::test::scratchDir("cli");
  const std::string o = (dir / "stdout.txt").string(), e = (dir / "stderr.txt").string();
  const std::string cmd = std::string(OBLONG_BINARY) + " " + args + " >" + o + " 2>" + e;
  const int raw = std::system(cmd.c_str());
  auto slurp = [](const std::string& p) {
    std::ifstream f(p);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
  };
  return {WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, slurp(o), slurp(e)};
}

size_t lines(const std::string& s) { return size_t(std::count(s.begin(), s.end(), '\n')); }

}  // namespace

TEST_CASE("oblong render writes an image and statistics for the default scene", "[cli]") {
  const auto dir = oblong::test::scratchDir("cli_ok");
  const std::string png = (dir / "default.png").string(), stats = (dir / "stats.json").string();
  std::filesystem::remove(png);
  const Run r = run("render --size 64x48 --threads 2 -o " + png + " --stats " + stats);
  INFO(r.out << r.err);
  REQUIRE(r.status == 0);
  CHECK(std::filesystem::file_size(png) > 100);
  CHECK(r.out.find("Mrays/s") != std::string::npos);
  std::ifstream f(stats);
  const auto j = nlohmann::json::parse(f);
  CHECK(j.at("rays").at("primary") == 64 * 48);
  CHECK(j.at("memory").at("embree/bvh").get<int64_t>() > 0);
  CHECK(j.at("rays").at("hits").get<int64_t>() > 64 * 48 / 4);
}

TEST_CASE("oblong info reports the range-query structures built for the scene", "[cli]") {
  for (const char* name : {"rmip", "minmax_mipmap", "safety_zones"}) {
    const Run r = run(std::string("info --range ") + name);
    INFO(r.out << r.err);
    REQUIRE(r.status == 0);
    CHECK(r.out.find(std::string("range query '") + name + "'") != std::string::npos);
    CHECK(r.out.find("plain (Embree triangles)") != std::string::npos);
  }
}

TEST_CASE("bad command-line input gives one clear error line", "[cli][bad_input]") {
  const auto dir = oblong::test::scratchDir("cli_bad");
  struct Case {
    std::string args, mustContain;
  };
  const std::string badJson = (dir / "bad.json").string();
  std::ofstream(badJson) << "{ \"meshes\": [ }";
  const std::string unknown = (dir / "unknown.json").string();
  std::ofstream(unknown) << R"({"camera": {"from": [0,0,5], "to": [0,0,0]}, "meshez": []})";
  const Case cases[] = {
      {"render /nonexistent/scene.json -o x.png", "/nonexistent/scene.json"},
      {"render " + badJson + " -o x.png", badJson},
      {"render " + unknown + " -o x.png", "meshez"},
      {"render --size 0x5 -o x.png", "--size"},
      {"render --size banana -o x.png", "--size"},
      {"render --size 8x8 -o /nonexistent/dir/x.png", "/nonexistent/dir/x.png"},
      {"info --range nosuch", "nosuch"},
  };
  for (const auto& c : cases) {
    const Run r = run(c.args);
    INFO(c.args << "\nstdout: " << r.out << "\nstderr: " << r.err);
    CHECK(r.status == 1);
    CHECK(lines(r.err) == 1);
    CHECK(r.err.find(c.mustContain) != std::string::npos);
  }
}
