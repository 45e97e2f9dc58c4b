#!/bin/bash
# Runs the vcan test suite (ctest label `vcan`) of BUILD_DIR on a real vcan0.
#   scripts/vcan/run_vcan_tests.sh BUILD_DIR
# scripts/vcan/with_vcan.sh runs ctest directly when the host kernel has vcan, else inside
# user-mode Linux (work folder BUILD_DIR/vcan-uml/), or with EMADIAG_VCAN_VM=qemu inside a QEMU VM
# (scripts/vcan/with_vcan_vm.sh, work folder BUILD_DIR/vcan-qemu/: the AddressSanitizer build,
# scripts/sanitize/run_asan_vcan.sh). These tests are never skipped.
# Environment: as with_vcan.sh, and EMADIAG_VCAN_CTEST_ARGS (extra ctest arguments, e.g. -V).
set -u
if [ $# -ne 1 ] || [ ! -d "$1" ]; then
    echo "usage: $0 BUILD_DIR" >&2
    exit 2
fi
BUILD_DIR=$(cd "$1" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
if [ ! -f "$BUILD_DIR/CTestTestfile.cmake" ]; then
    echo "$0: $BUILD_DIR is not a configured build directory" >&2
    exit 2
fi
# Word splitting of the extra arguments is intended.
# shellcheck disable=SC2086
(cd "$BUILD_DIR" && "$HERE/with_vcan.sh" "$BUILD_DIR/vcan-${EMADIAG_VCAN_VM:-uml}" ctest -L vcan --output-on-failure ${EMADIAG_VCAN_CTEST_ARGS:-})
STATUS=$?
echo "run_vcan_tests: ctest with vcan0 exited with status $STATUS"
exit "$STATUS"
