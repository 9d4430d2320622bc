#define CATCH_CONFIG_MAIN
#include <catch2/catch.hpp>

#include "tests/scratch.h"

namespace {

// Every test case's scratch folders go when it ends, passed or failed.
struct ScratchCleanup : Catch::TestEventListenerBase {
  using TestEventListenerBase::TestEventListenerBase;
  void testCaseEnded(const Catch::TestCaseStats& stats) override {
    oblong::test::removeScratchDirs();
    TestEventListenerBase::testCaseEnded(stats);
  }
  void testRunEnded(const Catch::TestRunStats& stats) override {
    oblong::test::removeScratchDirs();
    TestEventListenerBase::testRunEnded(stats);
  }
};

}  // namespace

CATCH_REGISTER_LISTENER(ScratchCleanup)
