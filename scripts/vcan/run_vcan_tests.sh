#!/bin/bash
# Runs the vcan test suite (ctest label `vcan`) of BUILD_DIR on a real vcan0.
#   scripts/vcan/run_vcan_tests.sh BUILD_DIR
# When the host kernel has vcan (vcan0 exists, or can be created), ctest runs directly. Otherwise
# the script boots user-mode Linux (linux.uml, Debian package user-mode-linux) with the host's /
# as root (hostfs), loads can, can-raw, can-dev and vcan, creates vcan0, runs the same ctest inside
# and powers off. The guest's exit status does not come back from linux.uml, so the guest writes
# ctest's output and status into BUILD_DIR/vcan-uml/, and this script prints them and exits with
# ctest's status.
# Environment: EMADIAG_VCAN_TIME_SCALE (telemetry pacing for the suite, default 2),
#              EMADIAG_UML_MEM (guest memory, default 512M), EMADIAG_UML_TIMEOUT_S (default 600),
#              EMADIAG_VCAN_CTEST_ARGS (extra ctest arguments, e.g. -V).
set -u
if [ $# -ne 1 ] || [ ! -d "$1" ]; then
    echo "usage: $0 BUILD_DIR" >&2
    exit 2
fi
BUILD_DIR=$(cd "$1" && pwd)
IFACE=vcan0
if [ ! -f "$BUILD_DIR/CTestTestfile.cmake" ]; then
    echo "$0: $BUILD_DIR is not a configured build directory" >&2
    exit 2
fi

run_ctest() {
    cd "$BUILD_DIR" && ctest -L vcan --output-on-failure ${EMADIAG_VCAN_CTEST_ARGS:-}
}

host_has_vcan() {
    [ -d /sys/class/net/$IFACE ] && return 0
    # Try to create it (root with the vcan module available).
    { modprobe vcan && ip link add dev $IFACE type vcan && ip link set $IFACE up; } >/dev/null 2>&1
}

if host_has_vcan; then
    echo "run_vcan_tests: host kernel has $IFACE; running ctest -L vcan directly"
    ip link set $IFACE up >/dev/null 2>&1 || true
    run_ctest
    exit $?
fi

UML=$(command -v linux.uml || true)
if [ -z "$UML" ]; then
    echo "$0: the host has no vcan and linux.uml is not installed (Debian package user-mode-linux)" >&2
    exit 2
fi
WORK="$BUILD_DIR/vcan-uml"
rm -rf "$WORK"
mkdir -p "$WORK"
INIT="$WORK/init.sh"
cat > "$INIT" <<INIT_EOF
#!/bin/sh
# PID 1 of the user-mode Linux guest (written by run_vcan_tests.sh).
export PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin
# Scratch space is a tmpfs of its own inside the work folder, not over /tmp: the build (and so this
# work folder) may itself live under the host's /tmp, which the guest sees through hostfs.
mkdir -p "$WORK/scratch"
export HOME="$WORK/scratch" TMPDIR="$WORK/scratch" EMADIAG_VCAN_TIME_SCALE=${EMADIAG_VCAN_TIME_SCALE:-2}
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mount -t tmpfs -o size=256m tmpfs "$WORK/scratch"
{
    echo "guest kernel \$(uname -r), \$(nproc) cpu"
    M=/usr/lib/uml/modules/\$(uname -r)/kernel
    for m in net/can/can.ko net/can/can-raw.ko drivers/net/can/dev/can-dev.ko drivers/net/can/vcan.ko; do
        insmod "\$M/\$m" || echo "insmod \$m failed"
    done
    ip link add dev $IFACE type vcan && ip link set $IFACE up && ip -brief link show $IFACE
} > "$WORK/guest-setup.log" 2>&1
cd "$BUILD_DIR" && ctest -L vcan --output-on-failure ${EMADIAG_VCAN_CTEST_ARGS:-} > "$WORK/ctest.log" 2>&1
echo \$? > "$WORK/ctest.status"
sync
poweroff -f
INIT_EOF
chmod +x "$INIT"
echo "run_vcan_tests: host has no $IFACE; booting user-mode Linux ($UML) to run ctest -L vcan"
timeout "${EMADIAG_UML_TIMEOUT_S:-600}" "$UML" mem="${EMADIAG_UML_MEM:-512M}" root=/dev/root rootfstype=hostfs rootflags=/ rw \
    init="$INIT" con=null con0=fd:0,fd:1 </dev/null >"$WORK/uml-console.log" 2>&1
UML_RC=$?
cat "$WORK/guest-setup.log" 2>/dev/null
if [ ! -f "$WORK/ctest.status" ]; then
    echo "run_vcan_tests: the guest wrote no ctest status (linux.uml exit $UML_RC); console:" >&2
    tail -n 40 "$WORK/uml-console.log" >&2
    cat "$WORK/ctest.log" 2>/dev/null
    exit 1
fi
cat "$WORK/ctest.log"
STATUS=$(cat "$WORK/ctest.status")
echo "run_vcan_tests: ctest inside user-mode Linux exited with status $STATUS"
exit "$STATUS"
