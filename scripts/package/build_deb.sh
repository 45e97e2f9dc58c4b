#!/usr/bin/env bash
# Builds the Debian package (issue 26, docs/install.md) from the release build in build/:
#   scripts/package/build_deb.sh
# Builds only what the package holds (emadiag, and emadiag_docs: its manual pages and completion
# scripts generated from the CLI's definitions), runs CPack's DEB generator (dependencies from
# dpkg-shlibdeps) and lintian on the result when it is installed. Prints the package's path last.
set -euo pipefail
cd "$(dirname "$0")/../.."
scripts/build.sh release emadiag emadiag_docs >/dev/null
mkdir -p build/package
rm -f build/package/emadiag_*.deb
(cd build && cpack -G DEB >package/cpack.log 2>&1) || { cat build/package/cpack.log >&2; echo "build_deb: cpack failed" >&2; exit 1; }
deb=$(ls build/package/emadiag_*_amd64.deb)
echo "build_deb: $deb ($(stat -c %s "$deb") bytes)"
dpkg-deb --field "$deb" Package Version Architecture Installed-Size Depends Recommends Suggests
if command -v lintian >/dev/null; then
  echo "build_deb: lintian $(lintian --version | awk '{print $2}'):"
  # Exit status 0 = no error or warning tag; the tags left are explained in docs/install.md.
  lint_rc=0
  lintian --display-info "$deb" >build/package/lintian.log 2>&1 || lint_rc=$?
  grep -v "running with root privileges" build/package/lintian.log || true
  [ "$lint_rc" -eq 0 ] || { echo "build_deb: lintian reported errors or warnings (above)" >&2; exit 1; }
  echo "build_deb: lintian done"
fi
echo "$PWD/$deb"
