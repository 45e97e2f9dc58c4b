#!/usr/bin/env bash
# README command (a): set up, build, and run the main job.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh release
mkdir -p out
echo "== emadiag simulate: the reference EMA, DYN sequence, case B (in flight), datasheet health =="
./build/src/emadiag simulate --case B --sequence dyn --out out/reference_dyn_B.csv
echo
echo "== emadiag test-run: the technician's test run on the ramp, against the simulated EMA on vcan0 =="
echo "   (scripts/vcan/with_vcan.sh boots user-mode Linux when this kernel has no vcan)"
rm -rf out/test-run
scripts/vcan/with_vcan.sh out/test-run/uml scripts/test-run-demo.sh "$PWD/build" "$PWD/out/test-run"
