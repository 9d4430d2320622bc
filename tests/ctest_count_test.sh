#!/usr/bin/env bash
# CTest must run every test case that oblong_tests lists. catch_discover_tests splits a
# name containing ';' into entries that match nothing; this compares the two lists.
#   tests/ctest_count_test.sh BUILD_DIR
set -euo pipefail
build="${1:?usage: ctest_count_test.sh BUILD_DIR}"
# Catch2 2.x exits with the number of test cases listed: not an error.
"$build/oblong_tests" --list-test-names-only > "$build/ctest_count.raw" || true
sed '/^$/d' "$build/ctest_count.raw" | sort > "$build/ctest_count.listed"
[ -s "$build/ctest_count.listed" ] || { echo "ctest_count_test: oblong_tests listed no test case" >&2; exit 1; }
ctest --test-dir "$build" --show-only=json-v1 | /usr/bin/python3 -c '
import json, sys
for t in json.load(sys.stdin)["tests"]:
    cmd = t.get("command") or []
    if cmd and cmd[0].endswith("/oblong_tests"):
        print(t["name"])
' | sort > "$build/ctest_count.registered"
listed=$(wc -l < "$build/ctest_count.listed")
registered=$(wc -l < "$build/ctest_count.registered")
if ! diff -u "$build/ctest_count.listed" "$build/ctest_count.registered" > "$build/ctest_count.diff"; then
  echo "ctest_count_test: oblong_tests lists $listed test cases, CTest has $registered entries for it:" >&2
  cat "$build/ctest_count.diff" >&2
  exit 1
fi
echo "ctest_count_test: all $listed test cases of oblong_tests are CTest entries"
