#!/usr/bin/env bash
# Configures and builds one configuration.
#   scripts/build.sh [release|asan] [TARGET...]   (no target: everything)
# release: build/, GCC, -O3, one baseline x86-64 binary (the SIMD kernels dispatch at run time).
# asan:    build-asan/, clang, AddressSanitizer + UBSan (-O2, line tables only), with the unit tests
#          and the libFuzzer targets (EMADIAG_FUZZ: the whole tree also carries libFuzzer's coverage
#          instrumentation). One sanitizer build serves the fuzzing (scripts/fuzz/run_fuzz.sh), the
#          ASan unit suite and the ASan vcan run, so CI compiles the tree twice, not three times.
set -euo pipefail
cd "$(dirname "$0")/.."
config=${1:-release}
shift || true
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
# Paths below the checkout hash as relative ones, so another clone of the same sources (CI's clean
# clone, a git worktree) reuses the cache.
export CCACHE_BASEDIR="$PWD"
case "$config" in
  release) dir=build; flags=(-DCMAKE_BUILD_TYPE=Release) ;;
  asan)
    command -v clang++ >/dev/null || { echo "build: clang++ missing (scripts/setup.sh installs clang and libclang-rt-14-dev)" >&2; exit 2; }
    dir=build-asan
    flags=(-DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -gline-tables-only -DNDEBUG"
           -DCMAKE_CXX_COMPILER=clang++ -DEMADIAG_FUZZ=ON -DEMADIAG_NATIVE=OFF -DEMADIAG_BUILD_BENCH=OFF) ;;
  *) echo "build: unknown configuration '$config' (release or asan)" >&2; exit 2 ;;
esac
# A build-asan/ configured with GCC by an earlier version of this script: start it afresh.
if [ "$config" = asan ] && [ -f "$dir/CMakeCache.txt" ] && ! grep -q '^CMAKE_CXX_COMPILER:[A-Z]*=.*clang' "$dir/CMakeCache.txt"; then
  echo "build: $dir was configured with another compiler; configuring it afresh with clang"
  rm -rf "$dir"
fi
cmake -S . -B "$dir" -G Ninja "${flags[@]}" "${launcher[@]}" >/dev/null
if [ $# -gt 0 ]; then
  cmake --build "$dir" -j "$(nproc)" --target "$@"
else
  cmake --build "$dir" -j "$(nproc)"
fi
