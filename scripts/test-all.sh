#!/usr/bin/env bash
# README command (b): set up, build, and pass every test:
#   1. Release build: unit tests, then the vcan suite (inside user-mode Linux when this kernel has no vcan);
#   2. AddressSanitizer + UBSan build: unit tests.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh

echo "== release build =="
scripts/build.sh release
echo "== unit tests (release) =="
ctest --test-dir build -L unit -j "$(nproc)" --output-on-failure

if [ -x scripts/vcan/run_vcan_tests.sh ]; then
  echo "== vcan tests (real SocketCAN on vcan0) =="
  scripts/vcan/run_vcan_tests.sh "$PWD/build"
fi

echo "== the main job (README command (a)), quick counts =="
EMADIAG_MAIN_QUICK=1 scripts/run-main.sh

echo "== AddressSanitizer + UBSan build =="
scripts/build.sh asan
echo "== unit tests (ASan + UBSan) =="
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-asan -L unit -j "$(nproc)" --output-on-failure
echo "test-all: every suite passed"
