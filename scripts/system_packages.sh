#!/usr/bin/env bash
# Debian packages the tests use beyond Python: valgrind (tests/test_process_exit.py and
# tests/test_native_fmus.py run FMUs under it; without it those tests skip with a reason), gcc and
# binutils (the native C core is compiled for the ctypes tests; nm checks for global state; the
# native FMUs themselves build with zig from the ziglang wheel when gcc is absent), wine and wine64
# (tests/test_native_windows.py runs the win64 binaries under wine: wine64 holds the 64-bit loader, wine the
# `wine` launcher; without their recommends, which add 97 desktop packages a console .exe does not need:
# 24 packages, 105 MB, about 10 s on Debian 12). Installed when missing, with apt-get as root; elsewhere a
# note says what to install, and nothing fails.
set -u
missing=()
command -v valgrind >/dev/null 2>&1 || missing+=(valgrind)
command -v gcc >/dev/null 2>&1 || missing+=(gcc)
command -v nm >/dev/null 2>&1 || missing+=(binutils)
lean=()  # installed without recommends
command -v wine64 >/dev/null 2>&1 || { command -v wine >/dev/null 2>&1 && [ -x /usr/lib/wine/wine64 ]; } \
  || lean+=(wine wine64)
[ ${#missing[@]} -eq 0 ] && [ ${#lean[@]} -eq 0 ] && exit 0
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
  export DEBIAN_FRONTEND=noninteractive
  if apt-get update -qq \
    && { [ ${#missing[@]} -eq 0 ] || apt-get install -y -qq "${missing[@]}" >/dev/null; } \
    && { [ ${#lean[@]} -eq 0 ] || apt-get install -y -qq --no-install-recommends "${lean[@]}" >/dev/null; }; then
    echo "installed: ${missing[*]}${missing[*]:+ }${lean[*]}"
    exit 0
  fi
fi
missing+=("${lean[@]}")
echo "note: ${missing[*]} not installed (as root on Debian: apt-get update && apt-get install -y ${missing[*]}); the tests that need it will be skipped" >&2
exit 0
