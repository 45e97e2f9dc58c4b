#!/usr/bin/env bash
# Installs every Debian 12 package emadiag needs to build, test and run its vcan suite.
# Safe to run twice: it installs only what is missing. Run as root (or with sudo available).
set -euo pipefail

PACKAGES=(
  g++ cmake ninja-build pkg-config ccache  # ccache: a rebuild, or a second clone, compiles only what changed
  libeigen3-dev libsqlite3-dev sqlite3 libcli11-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev googletest libbenchmark-dev
  libhwy-dev
  user-mode-linux kmod iproute2 can-utils
  chromium fonts-dejavu-core python3
  clang libclang-rt-14-dev  # libFuzzer targets (fuzz/, scripts/fuzz/run_fuzz.sh)
  libpq-dev postgresql postgresql-client  # fleet server: libpq for sync/--db postgresql://, a real server in scripts/pg/run_pg_tests.sh
  lintian bash-completion  # the Debian package: its checks (scripts/package/build_deb.sh) and the loader of its completion (a Recommends), issue 26
  qemu-system-x86 linux-image-amd64 busybox-static  # the ASan vcan run in a QEMU VM (scripts/vcan/with_vcan_vm.sh): UML cannot hold ASan's address space
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} packages already installed"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "setup: need root to install: ${missing[*]}" >&2; exit 1; }
  SUDO=sudo
fi
echo "setup: installing ${missing[*]}"
$SUDO apt-get update -qq
# INITRD=No: the kernel package's own initramfs is never used (with_vcan_vm.sh builds a busybox one),
# and generating it took minutes on a loaded machine.
$SUDO env DEBIAN_FRONTEND=noninteractive INITRD=No apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "setup: done"
