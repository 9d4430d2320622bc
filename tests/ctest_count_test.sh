#!/usr/bin/env bash
# CTest must run every test case that each test program lists, once. catch_discover_tests
# splits a name containing ';' into entries that match nothing, registers a case twice
# where two of its tag-filtered discoveries overlap, and registers nothing for a program
# that died while listing (tests/list_check.sh fails the build then; this fails the run
# of a build that went on anyway). This compares the lists.
#   tests/ctest_count_test.sh BUILD_DIR PROGRAM...
set -euo pipefail
build="${1:?usage: ctest_count_test.sh BUILD_DIR PROGRAM...}"
shift
[ "$#" -gt 0 ] || { echo "ctest_count_test: no test program named" >&2; exit 1; }
ctest --test-dir "$build" --show-only=json-v1 > "$build/ctest_count.json"
for prog in "$@"; do
  # Catch2 2.x exits with the number of test cases listed: not an error.
  "$build/$prog" --list-test-names-only > "$build/ctest_count.raw" || true
  sed '/^$/d' "$build/ctest_count.raw" | sort > "$build/ctest_count.listed"
  [ -s "$build/ctest_count.listed" ] || { echo "ctest_count_test: $prog listed no test case" >&2; exit 1; }
  /usr/bin/python3 -c '
import json, sys
for t in json.load(open(sys.argv[1]))["tests"]:
    cmd = t.get("command") or []
    if cmd and cmd[0].endswith("/" + sys.argv[2]):
        print(t["name"])
' "$build/ctest_count.json" "$prog" | sort > "$build/ctest_count.registered"
  listed=$(wc -l < "$build/ctest_count.listed")
  registered=$(wc -l < "$build/ctest_count.registered")
  if ! diff -u "$build/ctest_count.listed" "$build/ctest_count.registered" > "$build/ctest_count.diff"; then
    echo "ctest_count_test: $prog lists $listed test cases, CTest has $registered entries for it:" >&2
    cat "$build/ctest_count.diff" >&2
    exit 1
  fi
  echo "ctest_count_test: all $listed test cases of $prog are CTest entries, once each"
done
