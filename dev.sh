#!/usr/bin/env bash
# glrender's two set-up commands, for a fresh Debian 12 machine with python3:
#
#   ./dev.sh render [OPTIONS]   install what is missing, render the default scene, print the path
#   ./dev.sh test [PYTEST ARGS] install what is missing (with the test extras), run the test suite
#
# Both are safe to rerun: they install system packages (EGL + Mesa llvmpipe, python3-venv)
# only when missing, create .venv once and reinstall the package only when pyproject.toml or
# setup.py changed.
set -euo pipefail
cd "$(dirname "$0")"
root=$PWD

log() { printf '[dev.sh] %s\n' "$*" >&2; }

apt_install() {
    local sudo=""
    if [ "$(id -u)" != 0 ]; then
        if command -v sudo >/dev/null 2>&1; then sudo="sudo"; else
            log "missing system packages: $*; install them as root: apt-get install -y $*"; exit 1
        fi
    fi
    log "installing system packages: $*"
    $sudo env DEBIAN_FRONTEND=noninteractive apt-get update -qq
    $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "$@" >/dev/null
}

system_packages() {
    local missing=()
    # EGL (glvnd) + Mesa's EGL vendor and software rasteriser (llvmpipe) + libGL for GL entry points
    ldconfig -p 2>/dev/null | grep -q 'libEGL.so.1 ' || missing+=(libegl1)
    ldconfig -p 2>/dev/null | grep -q 'libGL.so.1 ' || missing+=(libgl1)
    ls /usr/share/glvnd/egl_vendor.d/*mesa*.json >/dev/null 2>&1 || missing+=(libegl-mesa0)
    ls /usr/lib/*/dri/swrast_dri.so >/dev/null 2>&1 || missing+=(libgl1-mesa-dri)
    python3 -c 'import ensurepip, venv' >/dev/null 2>&1 || missing+=(python3-venv)
    if [ "${1:-}" = test ]; then
        command -v Xvfb >/dev/null 2>&1 || missing+=(xvfb)
        command -v xdotool >/dev/null 2>&1 || missing+=(xdotool)
        # the docs test opens the built site in headless Chromium (the small headless shell)
        command -v chromium-headless-shell >/dev/null 2>&1 || command -v chromium >/dev/null 2>&1 ||
            missing+=(chromium-headless-shell)
    fi
    if [ ${#missing[@]} -gt 0 ]; then apt_install "${missing[@]}"; fi
}

# Mesa 25 from bookworm-backports, unpacked into .venv/mesa (the system's Mesa is not touched):
# its llvmpipe measured 1.8x faster than Debian 12's Mesa 22.3 (see glrender/gl/mesa.py).
# Best effort: without it glrender runs on the system's Mesa.
MESA_PACKAGES="mesa-libgallium libegl-mesa0 libgbm1 libdrm2 libdrm-amdgpu1 libdrm-intel1"
bundled_mesa() {
    local dest=.venv/mesa
    [ -f "$dest/.complete" ] && return 0
    [ "${GLRENDER_MESA:-}" = system ] && return 0
    grep -q '^VERSION_CODENAME=bookworm' /etc/os-release 2>/dev/null || return 0
    command -v apt-get >/dev/null 2>&1 || return 0
    log "fetching Mesa 25 (bookworm-backports) into $dest"
    local tmp
    tmp=$(mktemp -d)
    mkdir -p "$tmp/lists/partial" "$tmp/archives/partial" "$tmp/debs"
    echo "deb http://deb.debian.org/debian bookworm-backports main" > "$tmp/sources.list"
    local opts=(-o "Dir::Etc::SourceList=$tmp/sources.list" -o "Dir::Etc::SourceParts=/nonexistent"
                -o "Dir::State::Lists=$tmp/lists" -o "Dir::Cache::Archives=$tmp/archives"
                -o "Debug::NoLocking=1" -o "APT::Sandbox::User=root")
    if apt-get "${opts[@]}" -qq update >/dev/null 2>&1 &&
       (cd "$tmp/debs" && apt-get "${opts[@]}" -qq download $MESA_PACKAGES >/dev/null 2>&1); then
        rm -rf "$dest" && mkdir -p "$dest"
        for deb in "$tmp"/debs/*.deb; do dpkg -x "$deb" "$dest"; done
        touch "$dest/.complete"
    else
        log "could not fetch Mesa 25; using the system's Mesa (slower)"
    fi
    rm -rf "$tmp"
}

python_env() {
    local extras=$1 stamp=.venv/.glrender-installed
    if [ ! -x .venv/bin/python ]; then
        log "creating .venv"
        python3 -m venv .venv
    fi
    local want
    want="$extras $(cat pyproject.toml setup.py | sha256sum | cut -c1-16)"
    if [ ! -f "$stamp" ] || ! grep -qxF -- "$want" "$stamp"; then
        log "installing glrender[$extras] into .venv"
        .venv/bin/python -m pip install -q --upgrade pip >/dev/null
        .venv/bin/python -m pip install -q -e ".[$extras]"
        printf '%s\n' "$want" >> "$stamp"
    fi
    bundled_mesa
}

cmd=${1:-}
shift || true
case "$cmd" in
    render)
        system_packages render
        python_env exr
        mkdir -p out
        out=out/cornell-box.png
        .venv/bin/python -m glrender render scenes/cornell-box/scene.toml -o "$out" "$@"
        printf '%s\n' "$root/$out"
        ;;
    test)
        system_packages test
        python_env test,exr,preview,lab,distributed,denoise,docs
        # pytest exits 5 when it collects no tests: that is a failure here too. Two workers
        # (pytest-xdist), each test file whole in one of them (its module fixtures made once):
        # shader compilation is single-threaded, so two cores compile two kernels at once.
        # GLRENDER_TEST_WORKERS=0 (or "-n 0" among the arguments) runs in one process.
        exec .venv/bin/python -m pytest -n "${GLRENDER_TEST_WORKERS:-2}" --dist loadfile "$@"
        ;;
    *)
        echo "usage: ./dev.sh render [glrender render options] | ./dev.sh test [pytest args]" >&2
        exit 2
        ;;
esac
