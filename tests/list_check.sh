#!/usr/bin/env bash
# Run after a Catch2 test program is linked (POST_BUILD, after catch_discover_tests's
# discovery, which ignores a program that dies while listing and leaves CTest with fewer
# entries): the program must list its test cases and exit with their count, as Catch2
# 2.x does (capped at 255). A program that throws before main (a strategy registered
# twice) or crashes fails the build here, with its own message.
#   tests/list_check.sh TEST_PROGRAM
set -uo pipefail
bin="${1:?usage: list_check.sh TEST_PROGRAM}"
# In the sanitizer build: listing is checked here, leaks are the tests' business (they
# run with scripts/test.sh's suppressions), so LeakSanitizer's exit status stays out.
export ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0"
err="$(mktemp)"
trap 'rm -f "$err"' EXIT
out="$("$bin" --list-test-names-only 2>"$err")"
rc=$?
n=$(printf '%s\n' "$out" | sed '/^$/d' | wc -l)
expect=$(( n < 255 ? n : 255 ))
if [ "$n" = 0 ] || [ "$rc" != "$expect" ]; then
  echo "list_check: $bin could not list its test cases (exit status $rc, $n listed):" >&2
  cat "$err" >&2
  exit 1
fi
