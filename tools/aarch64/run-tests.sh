#!/usr/bin/env bash
# Run rio-core's tests on aarch64 on an x86-64 Linux machine, under QEMU user-mode emulation.
# See docs/arm.md. On a real aarch64 machine (Jetson, Raspberry Pi) do not use this: the tests run
# natively there with uv (docs/arm.md gives the commands).
#
#   sudo tools/aarch64/run-tests.sh                          # the shared-memory tests (default)
#   sudo tools/aarch64/run-tests.sh rio-core/tests/test_conformance.py -x   # any pytest arguments
#   sudo tools/aarch64/run-tests.sh --python -m rio.conformance.ordering --samples 100000
#
# Idempotent. The first run installs qemu-user-static and debootstrap (apt), builds an arm64 Debian
# userland in $RIO_ARM64_ROOT (default /opt/rio-arm64, outside the repository) and a venv in it
# (/opt/venv inside) with rio-core's test dependencies as aarch64 wheels from PyPI, pinned from
# uv.lock when uv is on PATH, and rio-core itself installed editable from this checkout. Later runs
# only reinstall when the pins or the checkout's path change.
#
# Two ways to run the arm64 python; RIO_ARM64_MODE picks (default auto: chroot when possible):
#   chroot   binfmt_misc has a qemu-aarch64 entry: chroot into the userland (private mount
#            namespace: /proc, /sys, /dev, /dev/shm and this checkout at the same path), every
#            aarch64 exec, including multiprocessing's spawned children, is emulated by the kernel.
#   wrapper  no binfmt_misc (e.g. an unprivileged container): qemu-aarch64-static -L ROOT runs
#            the python; its argv[0] (-0) is a host shell script, so sys.executable is that script
#            and every child python spawned with sys.executable goes through qemu too. Needs no
#            root once the userland exists; without binfmt the userland is built with
#            `debootstrap --foreign` and the packages unpacked with dpkg-deb (no maintainer scripts).
#
# Environment: RIO_ARM64_ROOT, RIO_ARM64_MODE, RIO_ARM64_SUITE (Debian release, default: this host's
# if it is Debian, else bookworm), RIO_ARM64_MIRROR (default http://deb.debian.org/debian).
set -euo pipefail

REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd -P)
ROOT=${RIO_ARM64_ROOT:-/opt/rio-arm64}
MODE=${RIO_ARM64_MODE:-auto}
MIRROR=${RIO_ARM64_MIRROR:-http://deb.debian.org/debian}
if [[ -z ${RIO_ARM64_SUITE:-} ]]; then
    # shellcheck disable=SC1091
    RIO_ARM64_SUITE=$( (. /etc/os-release && [[ ${ID:-} == debian && -n ${VERSION_CODENAME:-} ]] \
                        && echo "$VERSION_CODENAME") 2>/dev/null || echo bookworm)
fi
SUITE=$RIO_ARM64_SUITE
VENV=/opt/venv                      # inside the userland
BINFMT=/proc/sys/fs/binfmt_misc
DEFAULT_TESTS=(rio-core/tests/test_buffers.py rio-core/tests/test_mw_shm.py rio-core/tests/test_shm_calls.py)
[[ -f $REPO/rio-core/tests/test_shm_ordering.py ]] && DEFAULT_TESTS+=(rio-core/tests/test_shm_ordering.py)

log() { echo "[aarch64] $*" >&2; }
die() { echo "[aarch64] error: $*" >&2; exit 1; }

case $(uname -m) in
    aarch64|arm64) die "this machine is aarch64 already: run the tests natively (docs/arm.md):
    uv sync && uv run pytest ${DEFAULT_TESTS[*]}" ;;
    x86_64) ;;
    *) log "untested host architecture $(uname -m); trying anyway" ;;
esac
[[ $ROOT == /* && $ROOT != / ]] || die "RIO_ARM64_ROOT must be an absolute path other than /"
ROOT=${ROOT%/}
[[ $MODE == auto || $MODE == chroot || $MODE == wrapper ]] || die "RIO_ARM64_MODE: auto, chroot or wrapper"

# ---- host tools --------------------------------------------------------------------------------
need_root() { [[ $(id -u) == 0 ]] || die "$1: run as root (sudo $0 ...)"; }
APT_UPDATED=
apt_install() {
    need_root "installing $*"
    command -v apt-get >/dev/null || die "install $* with your package manager"
    [[ -n $APT_UPDATED ]] || { timeout 600 apt-get update -q >&2; APT_UPDATED=1; }
    DEBIAN_FRONTEND=noninteractive timeout 900 apt-get install -y -q "$@" >&2
}
command -v qemu-aarch64-static >/dev/null || apt_install qemu-user-static
QEMU=$(command -v qemu-aarch64-static)

binfmt_enabled() { [[ -r $BINFMT/qemu-aarch64 ]] && [[ $(head -n1 "$BINFMT/qemu-aarch64") == enabled ]]; }
if [[ $MODE != wrapper && $(id -u) == 0 ]] && ! binfmt_enabled; then
    # register qemu-aarch64 if the kernel allows it; an entry someone disabled is left alone
    [[ -w $BINFMT/register ]] || mount -t binfmt_misc binfmt_misc "$BINFMT" 2>/dev/null || true
    if [[ -w $BINFMT/register && ! -e $BINFMT/qemu-aarch64 ]]; then
        if [[ -f /usr/lib/binfmt.d/qemu-aarch64.conf ]]; then
            cat /usr/lib/binfmt.d/qemu-aarch64.conf > "$BINFMT/register" 2>/dev/null || true
        elif command -v update-binfmts >/dev/null; then
            update-binfmts --enable qemu-aarch64 2>/dev/null || true
        fi
    fi
fi
if [[ $MODE == auto ]]; then
    if binfmt_enabled && [[ $(id -u) == 0 ]]; then MODE=chroot; else MODE=wrapper; fi
fi
[[ $MODE == wrapper ]] || binfmt_enabled || die "RIO_ARM64_MODE=chroot needs a qemu-aarch64 binfmt_misc entry"
[[ $MODE == wrapper ]] || need_root "chroot mode"
if [[ $MODE == chroot ]] && ! grep -q '^flags:.*F' "$BINFMT/qemu-aarch64"; then
    die "the qemu-aarch64 binfmt_misc entry lacks the F (fix-binary) flag, so the kernel would look for
    qemu inside the chroot: re-register it with flags OCF/OPF (Debian's qemu-user-static does) or use
    RIO_ARM64_MODE=wrapper"
fi
log "mode: $MODE, userland: $ROOT (Debian $SUITE arm64)"

# ---- running things in the userland -------------------------------------------------------------
# test_shm_ordering.py's stress test: its default 1 000 000 samples take ~17 s natively on x86 but did
# not finish within the test's limits under QEMU (100 000 took ~1 min). Set RIO_STRESS_SAMPLES to override.
RIO_STRESS_SAMPLES=${RIO_STRESS_SAMPLES:-100000}
GUEST_ENV=("PATH=$VENV/bin:/usr/bin:/bin" HOME=/root LANG=C.UTF-8 "TERM=${TERM:-dumb}"
           PYTHONDONTWRITEBYTECODE=1 PIP_CONFIG_FILE=/dev/null PIP_DISABLE_PIP_VERSION_CHECK=1
           PIP_CERT=/etc/ssl/host-ca-bundle.crt)
for v in http_proxy https_proxy no_proxy HTTP_PROXY HTTPS_PROXY NO_PROXY PYTEST_ADDOPTS RIO_STRESS_SAMPLES; do
    [[ -n ${!v:-} ]] && GUEST_ENV+=("$v=${!v}")
done
# guest ARGS...: run ARGS (a guest path first) in the userland, from the checkout's directory
# shellcheck disable=SC2016  # the single-quoted scripts get their values as arguments
guest() {
    if [[ $MODE == chroot ]]; then
        # the checkout's mount point, made for this command and removed after it: an empty
        # $ROOT$REPO left behind would hide the checkout from qemu -L in wrapper mode
        local d=$ROOT$REPO made=() rc=0
        while [[ ! -e $d ]]; do made+=("$d"); d=$(dirname "$d"); done
        mkdir -p "$ROOT$REPO"
        # a private mount namespace: the mounts vanish with the command
        unshare --mount --propagation private /bin/sh -ec '
            root=$1 repo=$2; shift 2
            mount -t proc proc "$root/proc"
            mount --bind /sys "$root/sys"
            mount --bind /dev "$root/dev"
            mount --bind /dev/pts "$root/dev/pts"
            mount --bind /dev/shm "$root/dev/shm"
            mount --bind "$repo" "$root$repo"
            exec chroot "$root" /usr/bin/env -i "$@"' sh "$ROOT" "$REPO" "${GUEST_ENV[@]}" \
            /bin/sh -c 'cd "$0" && exec "$@"' "$REPO" "$@" || rc=$?
        for d in "${made[@]}"; do rmdir "$d" 2>/dev/null || break; done
        return $rc
    else
        local exe=$1; shift
        case $exe in
            $VENV/bin/python*) exe=$ROOT$VENV/bin/python-qemu ;;
            *) set -- -L "$ROOT" "$ROOT$exe" "$@"; exe=$QEMU ;;
        esac
        (cd "$REPO" && exec env -i "${GUEST_ENV[@]}" "$exe" "$@")
    fi
}

if [[ $MODE == wrapper && -d $ROOT$REPO ]]; then
    # an empty mount point (left by an interrupted chroot-mode run) hides the checkout from qemu -L
    d=$ROOT$REPO
    while [[ $d != "$ROOT" ]] && rmdir "$d" 2>/dev/null; do d=$(dirname "$d"); done
    [[ -d $ROOT$REPO ]] && die "$ROOT$REPO exists: qemu -L would show it instead of the checkout; remove it"
fi

# ---- the userland ---------------------------------------------------------------------------------
if [[ ! -f $ROOT/.rio-rootfs-ok ]]; then
    need_root "building $ROOT"
    command -v debootstrap >/dev/null || apt_install debootstrap
    [[ -e $ROOT ]] && die "$ROOT exists but is not a finished userland (no .rio-rootfs-ok): remove it"
    tmp=$ROOT.partial
    grep -q " $tmp/" /proc/mounts && die "something is mounted under $tmp: unmount it first"
    rm -rf "$tmp"
    pkgs=python3,python3-venv,ca-certificates
    start=$SECONDS
    if [[ $MODE == chroot ]]; then
        log "debootstrap $SUITE arm64 into $tmp (both stages, emulated; ~5 min)"
        timeout 1800 unshare --mount --propagation private \
            debootstrap --arch=arm64 --variant=minbase --include=$pkgs "$SUITE" "$tmp" "$MIRROR" >&2
    else
        # no binfmt: the second stage cannot run; unpack every downloaded package instead
        log "debootstrap --foreign $SUITE arm64 into $tmp, then unpack the packages (no binfmt_misc)"
        timeout 1800 debootstrap --foreign --arch=arm64 --variant=minbase --include=$pkgs \
            "$SUITE" "$tmp" "$MIRROR" >&2
        for deb in "$tmp"/var/cache/apt/archives/*.deb; do dpkg-deb -x "$deb" "$tmp"; done
        [[ -e $tmp/etc/passwd ]] || cp "$tmp/usr/share/base-passwd/passwd.master" "$tmp/etc/passwd"
        [[ -e $tmp/etc/group ]] || cp "$tmp/usr/share/base-passwd/group.master" "$tmp/etc/group"
    fi
    rm -f "$tmp"/var/cache/apt/archives/*.deb
    touch "$tmp/.rio-rootfs-ok"
    mv "$tmp" "$ROOT"
    log "userland built in $((SECONDS - start)) s"
fi

if [[ $(id -u) == 0 ]]; then
    # name resolution and the host's CA bundle (a TLS-intercepting proxy's CA included) for pip
    cp -L /etc/resolv.conf "$ROOT/etc/resolv.conf" 2>/dev/null || true
    ca=${PIP_CERT:-${SSL_CERT_FILE:-/etc/ssl/certs/ca-certificates.crt}}
    [[ -f $ca ]] && cp -L "$ca" "$ROOT/etc/ssl/host-ca-bundle.crt"
fi
[[ -f $ROOT/etc/ssl/host-ca-bundle.crt ]] || ln -sf certs/ca-certificates.crt "$ROOT/etc/ssl/host-ca-bundle.crt" 2>/dev/null || true

# ---- the venv -------------------------------------------------------------------------------------
if [[ ! -f $ROOT$VENV/.rio-venv-ok ]]; then
    mkdir -p "$ROOT/opt" 2>/dev/null || true
    [[ -w $ROOT/opt ]] || die "cannot write $ROOT/opt: run as root"
    rm -rf "$ROOT$VENV"
    log "creating the venv $VENV in the userland"
    if [[ $MODE == chroot ]]; then
        guest /usr/bin/python3 -m venv --without-pip $VENV
    else
        guest /usr/bin/python3 -m venv --without-pip "$ROOT$VENV"
        # made from outside: point it at the userland's own paths so it works in both modes
        sed -i "s|^home = .*|home = /usr/bin|; s|$ROOT/|/|g" "$ROOT$VENV/pyvenv.cfg"
        ln -sfn /usr/bin/python3 "$ROOT$VENV/bin/python3"
    fi
fi
# host-side launcher for wrapper mode (it names ROOT and qemu's path: rewritten when they change)
launcher="#!/bin/sh
# x86 launcher of the arm64 python (tools/aarch64/run-tests.sh, wrapper mode). -0 \"\$0\" makes the
# guest's sys.executable this script, so multiprocessing's spawned children are emulated too.
exec $QEMU -L $ROOT -0 \"\$0\" $ROOT/usr/bin/python3 \"\$@\""
if [[ $(cat "$ROOT$VENV/bin/python-qemu" 2>/dev/null) != "$launcher" ]]; then
    printf '%s\n' "$launcher" > "$ROOT$VENV/bin/python-qemu"
    chmod 755 "$ROOT$VENV/bin/python-qemu"
fi
if [[ ! -f $ROOT$VENV/.rio-venv-ok ]]; then
    guest $VENV/bin/python -m ensurepip >/dev/null
    touch "$ROOT$VENV/.rio-venv-ok"
fi

# ---- dependencies ---------------------------------------------------------------------------------
req=$(mktemp)
trap 'rm -f "$req"' EXIT
# uv pins the versions from uv.lock; under sudo, PATH may have lost the invoking user's uv
UV=${UV:-$(command -v uv || true)}
if [[ -z $UV && -n ${SUDO_USER:-} ]]; then
    user_home=$(getent passwd "$SUDO_USER" | cut -d: -f6)
    for c in "$user_home/.local/bin/uv" "$user_home/.cargo/bin/uv"; do [[ -x $c ]] && { UV=$c; break; }; done
fi
if [[ -n $UV && -f $REPO/uv.lock ]] \
   && (cd "$REPO" && "$UV" export --frozen --no-hashes --no-header --no-annotate --no-emit-workspace \
           --package rio-core --extra zenoh --extra portal \
       && "$UV" export --frozen --no-hashes --no-header --no-annotate --no-emit-workspace --only-group dev \
           | grep -vE '^(mypy|mypy-extensions|ruff|librt|ast-serialize|pathspec)==') > "$req" 2>/dev/null; then
    log "dependencies pinned from uv.lock"
else
    log "uv (or its uv.lock export) not available: dependencies from version ranges"
    printf '%s\n' "numpy>=1.24" "pluggy>=1.5" "pydantic>=2.6" "msgpack>=1.0" "xxhash>=3.0" "pyzmq>=25" \
        "typer>=0.12" "rich>=13" "tomli>=2.0; python_version < '3.11'" "eclipse-zenoh>=1.0,<2" \
        "portal>=3.5" "pytest>=8" "pytest-timeout>=2.3" "psutil>=5.9" > "$req"
fi
echo "# rio-core editable from $REPO" >> "$req"
stamp=$ROOT$VENV/.rio-requirements.txt
if ! cmp -s "$req" "$stamp" && [[ ! -w $ROOT$VENV && -f $stamp ]]; then
    log "the venv is not writable here: using it as installed (run as root to update it)"
elif ! cmp -s "$req" "$stamp"; then
    [[ -w $ROOT$VENV ]] || die "cannot write the venv: run as root"
    start=$SECONDS
    log "installing the aarch64 wheels (pip, emulated; ~2 min the first time)"
    cp "$req" "$ROOT/tmp/rio-requirements.txt"
    guest $VENV/bin/python -m pip install -q --only-binary=:all: -r /tmp/rio-requirements.txt >&2
    guest $VENV/bin/python -m pip install -q --no-deps -e "$REPO/rio-core" >&2
    cp "$req" "$stamp"
    log "installed in $((SECONDS - start)) s"
fi

# ---- run ------------------------------------------------------------------------------------------
guest $VENV/bin/python -c 'import platform, sys
print("[aarch64] python", platform.python_version(), "on", platform.machine(), file=sys.stderr)
sys.exit(sys.version_info < (3, 10) or platform.machine() != "aarch64")' \
    || die "the userland's python is not aarch64 python >= 3.10 (rio-core needs 3.10; bookworm has 3.11)"
if [[ ${1:-} == --python ]]; then
    shift
    start=$SECONDS; rc=0
    guest $VENV/bin/python "$@" || rc=$?
else
    # no test path among the arguments (only options, e.g. -x -q): the default tests
    has_path=
    for a in "$@"; do [[ $a != -* && -e $REPO/${a%%::*} ]] && has_path=1; done
    [[ -n $has_path ]] || set -- "$@" "${DEFAULT_TESTS[@]}"
    log "RIO_STRESS_SAMPLES=$RIO_STRESS_SAMPLES"
    start=$SECONDS; rc=0
    # -p no:cacheprovider: no root-owned .pytest_cache in the checkout
    guest $VENV/bin/python -m pytest -p no:cacheprovider "$@" || rc=$?
fi
log "exit $rc after $((SECONDS - start)) s (mode $MODE)"
exit $rc
