#!/usr/bin/env bash
# FreeCAD workbench tests: headless App tests (pytest inside freecadcmd) and the GUI
# script (real FreeCAD under Xvfb). Prints pytest-style summary lines; exits non-zero on
# any failure. With CI=true a missing FreeCAD/Xvfb is a failure, otherwise a notice.
#
#   .ci/freecad_tests.sh            # from the repository root
#   ARTIFACTS=/tmp/fc .ci/freecad_tests.sh   # keep screenshots and results there
set -u
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$REPO"
export FAIRING_FREECAD_TESTS=1
SCRATCH="$(mktemp -d /tmp/fairing_fc.XXXXXX)"
ARTIFACTS="${ARTIFACTS:-$SCRATCH/artifacts}"
mkdir -p "$ARTIFACTS"

missing() {
    if [ "${CI:-}" = "true" ]; then
        echo "FAILED freecad: $1 not found (CI=true: install Debian's freecad-python3 and xvfb)"
        exit 1
    fi
    echo "SKIPPED freecad: $1 not found (not in CI)"
    exit 0
}
command -v freecadcmd >/dev/null || missing freecadcmd
command -v freecad >/dev/null || missing freecad
command -v xvfb-run >/dev/null || missing xvfb-run

# Sandbox FreeCAD's user folder, temp and cache; install the workbench with the documented
# command into it (symlink + .pth), so the GUI run also tests the install.
mkdir -p "$SCRATCH/home" "$SCRATCH/tmp" "$SCRATCH/cache" "$SCRATCH/xdg"
chmod 700 "$SCRATCH/xdg"
export FREECAD_USER_HOME="$SCRATCH/home" PYTHONUSERBASE="$SCRATCH/userbase"
export QTWEBENGINE_DISABLE_SANDBOX=1 TMPDIR="$SCRATCH/tmp"
export XDG_CACHE_HOME="$SCRATCH/cache" XDG_RUNTIME_DIR="$SCRATCH/xdg"
export FAIRING_REPO="$REPO" FAIRING_ARTIFACTS="$ARTIFACTS"
/usr/bin/python3 freecad_workbench/install.py || { echo "FAILED freecad: install.py"; exit 1; }

status=0
echo "== headless: freecadcmd + pytest tests/freecad/app"
timeout 900 freecadcmd -c "import sys, pytest; sys.exit(pytest.main(['-q', '-p', 'no:cacheprovider', 'tests/freecad/app']))" \
    </dev/null >"$ARTIFACTS/app_tests.log" 2>&1
app_rc=$?
grep -E "^(FAILED|ERROR)|[0-9]+ (passed|failed|error)" "$ARTIFACTS/app_tests.log" | tail -n 30
[ $app_rc -eq 0 ] || { echo "FAILED tests/freecad/app (rc=$app_rc, log $ARTIFACTS/app_tests.log)"; status=1; }

echo "== GUI: xvfb-run freecad tests/freecad/gui/gui_script.py"
timeout 300 xvfb-run -a -s "-screen 0 1600x1000x24" freecad tests/freecad/gui/gui_script.py \
    </dev/null >"$ARTIFACTS/gui_tests.log" 2>&1
gui_rc=$?
if [ -f "$ARTIFACTS/gui_results.json" ]; then
    /usr/bin/python3 - "$ARTIFACTS/gui_results.json" <<'PY'
import json, sys
results = json.load(open(sys.argv[1]))
for r in results:
    if not r["passed"]:
        print(f"FAILED gui::{r['name']} - {r['detail'][:400]}")
passed = sum(r["passed"] for r in results)
failed = len(results) - passed
print(f"{failed} failed, {passed} passed (gui)" if failed else f"{passed} passed (gui)")
for r in results:
    if "under 1 s" in r["name"]:
        print(f"timing: {r['name']}: {r['detail']}")
PY
else
    echo "FAILED gui: no results (rc=$gui_rc, log $ARTIFACTS/gui_tests.log)"
fi
[ $gui_rc -eq 0 ] || { echo "FAILED tests/freecad/gui (rc=$gui_rc)"; status=1; }
echo "artifacts: $ARTIFACTS"
exit $status
