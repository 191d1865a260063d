#!/usr/bin/env bash
# CTest paraview.OpensResults: runs case 4.4 coarse (contact, friction and crack growth, so
# every field is written) and opens its results with ParaView's readers (open_results.py).
#   run_test.sh PERISTAT PVPYTHON SOURCE_DIR WORK_DIR
set -euo pipefail
peristat="$1" pvpython="$2" src="$3" work="$4"
if [[ "$pvpython" == *NOTFOUND* || ! -x "$pvpython" ]]; then
  echo "pvpython not found: install Debian's python3-paraview (scripts/install-deps does), then re-run cmake" >&2
  exit 1
fi
rm -rf "$work"
"$peristat" run "$src/cases/paper_4_4_crack_growth/scene.yaml" --set discretization.spacing=0.05 \
  --out "$work" --quiet
# ParaView needs no display to read files; its offscreen setting keeps it away from X.
"$pvpython" --force-offscreen-rendering "$src/tests/paraview/open_results.py" \
  "$work/paper_4_4_crack_growth.xdmf" "$work/summary.json" \
  displacement damage contact_force contact_state volume body fictitious
