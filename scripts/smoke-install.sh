#!/usr/bin/env bash
# A plain `pip install meshplan`, as a new user gets it: build the wheel, install it with its
# declared dependencies only (no extras, no test tools) into a new bare virtual environment, and
# run the console script there. Catches an import that the package uses but does not declare,
# which the development environment (with every extra) cannot see.
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON="${PYTHON:-python3}"
work="$(mktemp -d "${TMPDIR:-/tmp}/meshplan-smoke.XXXXXX")"
trap 'rm -rf "$work"' EXIT
"$PYTHON" -m pip wheel --quiet --no-deps --no-build-isolation . -w "$work/dist" 2>/dev/null \
  || "$PYTHON" -m pip wheel --quiet --no-deps . -w "$work/dist"
"$PYTHON" -m venv "$work/venv"
"$work/venv/bin/python" -m pip install --quiet --disable-pip-version-check "$work"/dist/meshplan-*.whl
cd "$work"
bin="$work/venv/bin"
"$bin/meshplan" --version
"$bin/python" -m meshplan --version >/dev/null
"$bin/meshplan" synth --preset room --seed 1 -o room --quiet
"$bin/meshplan" run room/scan.obj -a room/annotations.json -o plans --quiet
test -s plans/plan.json && test -s plans/drafting-0.png && test -s plans/report.html
# a missing extra is refused at once, in one line, with exit status 2
set +e
err="$("$bin/meshplan" run room/scan.obj -o plans-ifc --ifc 2>&1 >/dev/null)"; rc=$?
set -e
if [ "$rc" != 2 ] || [ "$(printf '%s\n' "$err" | wc -l)" != 1 ] || [ -e plans-ifc ]; then
  echo "smoke: --ifc without ifcopenshell: expected one error line and exit 2, got $rc: $err" >&2
  exit 1
fi
echo "smoke: bare install works (meshplan --version, synth, run; --ifc refused without its extra)"
