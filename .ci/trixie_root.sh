#!/usr/bin/env bash
# Build (once) a Debian 13 "trixie" root with FreeCAD 1.0 and the test tools, from Debian's
# packages: debootstrap, then apt-get inside the root. The root is cached in a fixed folder
# outside the repository and reused when complete: a stamp file marks the finished
# debootstrap, another lists the installed packages (a changed list installs the difference;
# an unfinished debootstrap starts again). Prints the root's path on the last line.
#
#   .ci/trixie_root.sh                      # root in /var/cache/cq-fairing/trixie-root
#   TRIXIE_ROOT=/srv/trixie .ci/trixie_root.sh
#
# Needs root (debootstrap, chroot). Any failure exits non-zero.
set -euo pipefail
ROOT="${TRIXIE_ROOT:-/var/cache/cq-fairing/trixie-root}"
PACKAGES="freecad-python3 python3-numpy python3-scipy python3-pytest python3-hypothesis xvfb xauth git"
BASE_STAMP="$ROOT/.cq-fairing-base"
PACKAGES_STAMP="$ROOT/.cq-fairing-packages"

log() { echo "== trixie root: $*" >&2; }

install_debootstrap() {
    command -v debootstrap >/dev/null && return
    log "installing debootstrap"
    export DEBIAN_FRONTEND=noninteractive
    apt-get install -y -qq --no-install-recommends debootstrap >/dev/null 2>&1 \
        || { apt-get update -qq && apt-get install -y -qq --no-install-recommends debootstrap >/dev/null; }
}

bootstrap() {
    if [ -e "$ROOT" ]; then
        if grep -q " $ROOT/" /proc/mounts; then
            echo "error: $ROOT is unfinished and has mounts inside it; unmount them first" >&2
            exit 1
        fi
        log "removing the unfinished $ROOT"
        rm -rf --one-file-system "$ROOT"
    fi
    install_debootstrap
    local mirror
    mirror="$(awk '/^URIs:/{print $2; exit}' /etc/apt/sources.list.d/debian.sources 2>/dev/null || true)"
    mirror="${mirror:-http://deb.debian.org/debian}"
    log "debootstrap trixie from $mirror into $ROOT"
    debootstrap --variant=minbase trixie "$ROOT" "$mirror" >"$ROOT.debootstrap.log" 2>&1 \
        || { echo "error: debootstrap failed, see $ROOT.debootstrap.log" >&2; exit 1; }
    touch "$BASE_STAMP"
}

install_packages() {
    log "apt-get install $PACKAGES"
    cp /etc/resolv.conf "$ROOT/etc/resolv.conf"
    chroot "$ROOT" env DEBIAN_FRONTEND=noninteractive bash -c \
        "apt-get update -qq && apt-get install -y -qq --no-install-recommends $PACKAGES && apt-get clean" \
        >"$ROOT.apt.log" 2>&1 \
        || { echo "error: apt-get inside the root failed, see $ROOT.apt.log" >&2; exit 1; }
    echo "$PACKAGES" >"$PACKAGES_STAMP"
}

mkdir -p "$(dirname "$ROOT")"
exec 9>"$ROOT.lock"
flock 9
start=$SECONDS
[ -f "$BASE_STAMP" ] || bootstrap
if [ -f "$PACKAGES_STAMP" ] && [ "$(cat "$PACKAGES_STAMP")" = "$PACKAGES" ]; then
    log "cached in $ROOT"
else
    install_packages
    log "built in $((SECONDS - start)) s"
fi
echo "$ROOT"
