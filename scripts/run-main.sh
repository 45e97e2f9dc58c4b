#!/usr/bin/env bash
# README command (a): set up, build, and run the main job.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh release
mkdir -p out
echo "== emadiag simulate: the reference EMA, DYN sequence, case B (in flight), datasheet health =="
./build/src/emadiag simulate --case B --sequence dyn --out out/reference_dyn_B.csv
