#!/usr/bin/env bash
# FreeCAD workbench tests: headless App tests (pytest inside freecadcmd) and the GUI
# script (real FreeCAD under Xvfb) on the FreeCAD found on PATH. The GUI run uses the
# workbench as the Addon Manager installs it (a git clone of the repository's files in
# FreeCAD's Mod folder). Prints pytest-style summary lines labelled with FreeCAD's version;
# exits non-zero on any failure. With CI=true a missing FreeCAD/Xvfb/git is a failure,
# otherwise a notice. .ci/freecad1_tests.sh runs this same script on FreeCAD 1.0.
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
        echo "FAILED freecad: $1 not found (CI=true: install Debian's freecad-python3, xvfb and git)"
        exit 1
    fi
    echo "SKIPPED freecad: $1 not found (not in CI)"
    exit 0
}
command -v freecadcmd >/dev/null || missing freecadcmd
command -v freecad >/dev/null || missing freecad
command -v xvfb-run >/dev/null || missing xvfb-run
command -v git >/dev/null || missing git

# Sandbox FreeCAD's user folder, temp and cache; nothing of the user's Python leaks in.
mkdir -p "$SCRATCH/home" "$SCRATCH/tmp" "$SCRATCH/cache" "$SCRATCH/xdg"
chmod 700 "$SCRATCH/xdg"
unset PYTHONPATH
export FREECAD_USER_HOME="$SCRATCH/home" PYTHONNOUSERSITE=1
export QTWEBENGINE_DISABLE_SANDBOX=1 TMPDIR="$SCRATCH/tmp"
export XDG_CACHE_HOME="$SCRATCH/cache" XDG_RUNTIME_DIR="$SCRATCH/xdg"
export FAIRING_REPO="$REPO" FAIRING_ARTIFACTS="$ARTIFACTS"
read -r VERSION PYTHON_VERSION < <(freecadcmd -c "import sys, FreeCAD; print('.'.join(FreeCAD.Version()[:3]), sys.version.split()[0])" </dev/null | tail -n 1)
echo "== FreeCAD $VERSION on Python $PYTHON_VERSION"

# The repository's files as a one-commit git repository, cloned into Mod/ by the tests
# (headless) and here (GUI) the way the Addon Manager clones an addon.
if [ -z "${FAIRING_ADDON_URL:-}" ]; then
    FAIRING_ADDON_URL="$(python3 tests/freecad/addon.py publish "$REPO" "$SCRATCH/published")" \
        || { echo "FAILED freecad: publishing the repository as a git repository"; exit 1; }
fi
export FAIRING_ADDON_URL

status=0
echo "== headless: freecadcmd + pytest tests/freecad/app"
timeout 1800 freecadcmd -c "import sys, pytest; sys.exit(pytest.main(['-q', '-p', 'no:cacheprovider', '--junitxml=$ARTIFACTS/app.xml', 'tests/freecad/app']))" \
    </dev/null >"$ARTIFACTS/app_tests.log" 2>&1
app_rc=$?
grep -E "^(FAILED|ERROR)" "$ARTIFACTS/app_tests.log" | tail -n 30
if [ -f "$ARTIFACTS/app.xml" ]; then
    python3 .ci/junit_summary.py "$ARTIFACTS/app.xml" "headless, FreeCAD $VERSION"
fi
[ $app_rc -eq 0 ] || { echo "FAILED tests/freecad/app on FreeCAD $VERSION (rc=$app_rc, log $ARTIFACTS/app_tests.log)"; status=1; }

echo "== GUI: xvfb-run freecad tests/freecad/gui/gui_script.py (workbench cloned into Mod/)"
FAIRING_ADDON="$(python3 tests/freecad/addon.py clone "$FAIRING_ADDON_URL" "$FREECAD_USER_HOME/Mod")" \
    || { echo "FAILED freecad: git clone into Mod/"; exit 1; }
export FAIRING_ADDON
timeout 300 xvfb-run -a -s "-screen 0 1600x1000x24" freecad tests/freecad/gui/gui_script.py \
    </dev/null >"$ARTIFACTS/gui_tests.log" 2>&1
gui_rc=$?
if [ -f "$ARTIFACTS/gui_results.json" ]; then
    python3 - "$ARTIFACTS/gui_results.json" "gui, FreeCAD $VERSION" "$ARTIFACTS/gui_timings.json" <<'PY'
import json, os, sys
results, label = json.load(open(sys.argv[1])), sys.argv[2]
for r in results:
    if not r["passed"]:
        print(f"FAILED gui::{r['name']} - {r['detail'][:400]}")
passed = sum(r["passed"] for r in results)
failed = len(results) - passed
print(f"{failed} failed, {passed} passed ({label})" if failed else f"{passed} passed ({label})")
timings = json.load(open(sys.argv[3])) if os.path.exists(sys.argv[3]) else []
for t in timings:   # figures for the log; the targets live in benchmarks/bench_workbench.py
    print(f"timing: {t['name']}: {t['detail']}")
PY
else
    echo "FAILED gui on FreeCAD $VERSION: no results (rc=$gui_rc, log $ARTIFACTS/gui_tests.log)"
fi
[ $gui_rc -eq 0 ] || { echo "FAILED tests/freecad/gui on FreeCAD $VERSION (rc=$gui_rc)"; status=1; }
echo "artifacts: $ARTIFACTS"
exit $status
