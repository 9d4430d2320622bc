#!/usr/bin/env bash
# tests/list_check.sh on stand-in test programs: one that dies while listing (as a
# strategy registered twice makes the test program throw before main) fails the check
# with the program's own message; one that lists its cases and exits with their count
# passes it.
set -euo pipefail
check="$(dirname "$0")/list_check.sh"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
cat >"$tmp/dies" <<'PROG'
#!/bin/sh
echo "terminate called after throwing an instance of 'oblong::Error'" >&2
echo "  what():  registry: strategy 'whole_map' is registered twice" >&2
exit 134
PROG
cat >"$tmp/lists" <<'PROG'
#!/bin/sh
printf 'first case\nsecond case\n'
exit 2
PROG
chmod +x "$tmp/dies" "$tmp/lists"
if bash "$check" "$tmp/dies" 2>"$tmp/err"; then
  echo "list_check_test: a program that dies while listing passed the check" >&2
  exit 1
fi
grep -q "registered twice" "$tmp/err" || { echo "list_check_test: the program's message was not shown:" >&2; cat "$tmp/err" >&2; exit 1; }
bash "$check" "$tmp/lists" || { echo "list_check_test: a program that lists two cases failed the check" >&2; exit 1; }
echo "list_check_test: a dying program fails the check, a listing one passes"
