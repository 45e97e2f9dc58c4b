#!/usr/bin/env bash
# README command (b): set up, build, and pass every test:
#   1. Release build: unit tests, the HTML report in headless Chromium, the storage faults, the
#      vcan suite (inside user-mode Linux when this kernel has no vcan), the main job (quick counts)
#      and a small fleet-scale run;
#   2. libFuzzer targets (clang), 30 s each;
#   3. ThreadSanitizer on the tests with threads;
#   4. AddressSanitizer + UBSan build: unit tests.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh

echo "== release build =="
scripts/build.sh release
echo "== unit tests (release) =="
ctest --test-dir build -L unit -j "$(nproc)" --output-on-failure

echo "== the HTML report in a real browser (headless Chromium) =="
ctest --test-dir build -L browser --output-on-failure
echo "== storage under faults (kill -9 x 50, two writers, full tmpfs) =="
scripts/storage/run_storage_faults.sh build 50

if [ -x scripts/vcan/run_vcan_tests.sh ]; then
  echo "== vcan tests (real SocketCAN on vcan0) =="
  scripts/vcan/run_vcan_tests.sh "$PWD/build"
fi

echo "== the main job (README command (a)), quick counts =="
EMADIAG_MAIN_QUICK=1 scripts/run-main.sh

echo "== fleet scale, CI size (bench/fleet_scale_bench: 5 tails x 30 days) =="
./build/bench/fleet_scale_bench 5 30 build/fleet_scale_ci.db

echo "== libFuzzer targets, 30 s each =="
scripts/fuzz/run_fuzz.sh 30
echo "== ThreadSanitizer: the tests with threads =="
scripts/sanitize/run_tsan.sh

echo "== AddressSanitizer + UBSan build =="
scripts/build.sh asan
echo "== unit tests (ASan + UBSan) =="
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-asan -L unit -j "$(nproc)" --output-on-failure
echo "test-all: every suite passed"
