#!/usr/bin/env bash
# The workbench on FreeCAD 1.0 (Debian 13 "trixie": Python 3.13, numpy 2, scipy 1.15): the
# same headless and GUI suites as on the machine's FreeCAD (.ci/freecad_tests.sh), plus the
# numerical core's tests on that Python. The trixie root comes from .ci/trixie_root.sh
# (built once, cached); the repository is bind-mounted into it in a private mount namespace,
# so every mount ends with the run. Prints pytest-style summary lines labelled with the
# FreeCAD version; exits non-zero on any failure. With CI=true a root that cannot be built
# is a failure, otherwise a notice.
#
#   .ci/freecad1_tests.sh                       # from the repository root, as root
#   ARTIFACTS=/tmp/fc1 .ci/freecad1_tests.sh    # keep screenshots and logs there
set -u
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
ARTIFACTS="${ARTIFACTS:-$(mktemp -d /tmp/fairing_fc1.XXXXXX)}"
mkdir -p "$ARTIFACTS"

start=$SECONDS
if ! ROOT="$(bash "$REPO/.ci/trixie_root.sh" | tail -n 1)" || [ -z "$ROOT" ]; then
    if [ "${CI:-}" = "true" ]; then
        echo "FAILED freecad 1.0: the trixie root could not be built (see the messages above)"
        exit 1
    fi
    echo "SKIPPED freecad 1.0: the trixie root could not be built (not in CI)"
    exit 0
fi
echo "timing: trixie root ready in $((SECONDS - start)) s"

# The repository's files as a git repository for the Addon-Manager-style clones (git
# cannot read a work tree whose .git lives outside the bind-mounted folder).
rm -rf "$ARTIFACTS/published"
python3 "$REPO/tests/freecad/addon.py" publish "$REPO" "$ARTIFACTS/published" >/dev/null \
    || { echo "FAILED freecad 1.0: publishing the repository as a git repository"; exit 1; }

# Runs inside the root: the workbench suites, then the core on the root's python3.
INSIDE='
cd /mnt/cq-fairing
ARTIFACTS=/mnt/artifacts bash .ci/freecad_tests.sh
status=$?
echo "== numerical core on FreeCAD 1.0'"'"'s Python ($(python3 -c "import sys, numpy, scipy; print(sys.version.split()[0], numpy.__version__, scipy.__version__)"))"
PYTHONPATH=$PWD python3 -m pytest -q -p no:cacheprovider --junitxml=/mnt/artifacts/core.xml \
    tests/core >/mnt/artifacts/core_tests.log 2>&1 || status=1
grep -E "^(FAILED|ERROR)" /mnt/artifacts/core_tests.log | tail -n 30
python3 .ci/junit_summary.py /mnt/artifacts/core.xml "core, Python $(python3 -c "import sys; print(sys.version.split()[0])")"
exit $status
'

# Mount what FreeCAD, Xvfb and Qt need, plus the repository and the artifacts folder, in a
# private mount namespace; a tmpfs on /tmp keeps scratch files out of the cached root.
MOUNT='
set -e
mkdir -p "$ROOT/mnt/cq-fairing" "$ROOT/mnt/artifacts"
mount -t proc proc "$ROOT/proc"
mount --rbind /dev "$ROOT/dev"
mount --bind /sys "$ROOT/sys"
mount -t tmpfs tmpfs "$ROOT/dev/shm"
mount -t tmpfs tmpfs "$ROOT/tmp"
mount --bind "$REPO" "$ROOT/mnt/cq-fairing"
mount --bind "$ARTIFACTS" "$ROOT/mnt/artifacts"
set +e
chroot "$ROOT" env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin HOME=/root LANG=C.UTF-8 \
    CI="${CI:-}" PYTHONDONTWRITEBYTECODE=1 FAIRING_ADDON_URL=/mnt/artifacts/published \
    bash -c "$INSIDE"
'
run_start=$SECONDS
ROOT="$ROOT" REPO="$REPO" ARTIFACTS="$ARTIFACTS" INSIDE="$INSIDE" \
    unshare --mount --propagation private bash -c "$MOUNT"
status=$?
echo "timing: FreeCAD 1.0 suites ran in $((SECONDS - run_start)) s"
echo "artifacts: $ARTIFACTS"
exit $status
