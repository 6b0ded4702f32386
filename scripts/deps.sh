#!/usr/bin/env bash
# make deps: install everything imu-allan needs on a Debian machine.
# Idempotent, and quick when everything is already present.
#   - the AVR toolchain, simavr and build tools from Debian's packages;
#   - optiboot's source (Debian's arduino-core-avr: make bootloader builds
#     it for the board into build/optiboot; nothing of it is committed);
#   - Unity 2.5 from Debian's ntpsec source package (or UNITY_DIR=);
#   - the host Python package (host_scripts/) with its test extras (pytest,
#     allantools, hypothesis, and make lint's ruff and mypy); make lint's
#     clang-format is one of the Debian packages.
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD=${BUILD:-$ROOT/build}
PYTHON=${PYTHON:-python3}
export DEBIAN_FRONTEND=noninteractive

SUDO=
if [ "$(id -u)" != 0 ]; then SUDO=sudo; fi

say() { printf 'deps: %s\n' "$*"; }
die() { printf 'deps: error: %s\n' "$*" >&2; exit 1; }

# ---- Debian packages ------------------------------------------------------
APT_PKGS=(gcc-avr avr-libc binutils-avr avrdude simavr libsimavr-dev libelf-dev
          cmake make gcc pkg-config xz-utils clang libclang-rt-14-dev tmux
          arduino-core-avr clang-format)
APT_UPDATED=0
apt_update() {
  if [ "$APT_UPDATED" = 0 ]; then
    $SUDO apt-get update -q >/dev/null
    APT_UPDATED=1
  fi
}

missing=()
for p in "${APT_PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'ok installed' || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  say "installing ${missing[*]}"
  apt_update
  $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}" >/dev/null
else
  say "Debian packages present"
fi

# ---- Unity ----------------------------------------------------------------
# Unmodified Unity 2.5.1 as carried by ntpsec under tests/unity/.  Only the
# three files the tests compile are pinned and copied; nothing is committed.
UNITY_SHA256="2e3a0610268455520a5796345b503d00c34a47fe97ed3750349cbd4b2b1990f3  unity.c
681ac98a63ac11effb11e59d580f6ca82abca1bd34069465c38e3b15344256c0  unity.h
adfd612c217e59468c5ebe978640e77e5f539e820ffc0c195a98c5a36f0ac868  unity_internals.h"

unity_ok() { (cd "$1" 2>/dev/null && printf '%s\n' "$UNITY_SHA256" | sha256sum --quiet -c - >/dev/null 2>&1); }

# Add a deb-src entry for the distribution's own suite, derived from the
# machine's existing apt sources (no mirror is named in this repository).
ensure_deb_src() {
  local list=/etc/apt/sources.list.d/imu-allan-deb-src.list
  [ -f "$list" ] && return 0
  local codename entries
  codename=$(. /etc/os-release && echo "${VERSION_CODENAME:-}")
  [ -n "$codename" ] || die "cannot tell the Debian release from /etc/os-release"
  entries=$("$PYTHON" - "$codename" <<'EOF'
import glob, re, sys
codename = sys.argv[1]
out = []
def emit(uris, suites, comps, signed):
    if codename in suites:
        opt = f" [signed-by={signed}]" if signed else ""
        for u in uris:
            out.append(f"deb-src{opt} {u} {codename} {' '.join(comps)}")
for path in sorted(glob.glob("/etc/apt/sources.list.d/*.sources")):
    for stanza in re.split(r"\n\s*\n", open(path).read()):
        f = {}
        for line in stanza.splitlines():
            if line.startswith("#") or ":" not in line:
                continue
            k, v = line.split(":", 1)
            f[k.strip().lower()] = v.split()
        if "deb" in f.get("types", []) and f.get("enabled", ["yes"])[0] != "no":
            emit(f.get("uris", []), f.get("suites", []), f.get("components", []),
                 (f.get("signed-by") or [""])[0])
for path in ["/etc/apt/sources.list"] + sorted(glob.glob("/etc/apt/sources.list.d/*.list")):
    try:
        lines = open(path).read().splitlines()
    except OSError:
        continue
    for line in lines:
        m = re.match(r"\s*deb\s+(\[[^]]*\]\s+)?(\S+)\s+(\S+)\s+(.*)", line)
        if m:
            signed = re.search(r"signed-by=(\S+?)[\] ]", m.group(1) or "")
            emit([m.group(2)], [m.group(3)], m.group(4).split(), signed.group(1) if signed else "")
print("\n".join(dict.fromkeys(out)))
EOF
)
  [ -n "$entries" ] || die "no apt source for '$codename' to derive a deb-src entry from"
  say "adding deb-src for $codename (derived from the existing apt sources)"
  printf '# added by imu-allan make deps: source packages (Unity from ntpsec)\n%s\n' "$entries" \
    | $SUDO tee "$list" >/dev/null
  APT_UPDATED=0
}

if [ -n "${UNITY_DIR:-}" ]; then
  for f in unity.c unity.h unity_internals.h; do
    [ -f "$UNITY_DIR/$f" ] || die "UNITY_DIR=$UNITY_DIR has no $f"
  done
  say "using Unity from UNITY_DIR=$UNITY_DIR"
elif unity_ok "$BUILD/unity"; then
  say "Unity 2.5.1 present in build/unity"
else
  say "fetching Unity from Debian's ntpsec source package"
  ensure_deb_src
  apt_update
  work="$BUILD/deps/ntpsec"
  rm -rf "$work" && mkdir -p "$work"
  # apt verifies the download against the signed Sources index.
  (cd "$work" && apt-get source --download-only -q ntpsec >/dev/null 2>&1) \
    || die "apt-get source --download-only ntpsec failed (is a deb-src entry reachable?)"
  orig=$(ls "$work"/ntpsec_*.orig.tar.* 2>/dev/null | head -n 1)
  [ -n "$orig" ] || die "ntpsec source download has no orig tarball"
  tar -xf "$orig" -C "$work" --wildcards '*/tests/unity/*'
  src=$(dirname "$(ls "$work"/*/tests/unity/unity.c)")
  unity_ok "$src" || die "Unity in $(basename "$orig") is not the pinned Unity 2.5.1 (set UNITY_DIR= to your own checkout)"
  mkdir -p "$BUILD/unity"
  cp "$src"/unity.c "$src"/unity.h "$src"/unity_internals.h "$BUILD/unity/"
  rm -rf "$work"
  say "Unity 2.5.1 unpacked into build/unity"
fi

# ---- Python host package ----------------------------------------------------
stamp="$BUILD/.pydeps-$(sha256sum "$ROOT/host_scripts/pyproject.toml" | cut -c1-16)"
if [ -f "$stamp" ] && "$PYTHON" -c 'import imu_allan, numpy, scipy, pandas, pyarrow, rosbags, matplotlib, serial, allantools, pytest, hypothesis, ruff, mypy' 2>/dev/null; then
  say "Python package present"
else
  say "installing the host package (host_scripts) with its test extras"
  "$PYTHON" -m pip install -q --disable-pip-version-check --root-user-action=ignore \
    -e "$ROOT/host_scripts[test]" || die "pip install of host_scripts failed"
  mkdir -p "$BUILD" && rm -f "$BUILD"/.pydeps-* && touch "$stamp"
fi
say "all present"
