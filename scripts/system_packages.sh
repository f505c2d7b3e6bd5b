#!/usr/bin/env bash
# The Debian packages some tests use beyond Python, and why:
#   valgrind   tests/test_process_exit.py and tests/test_native_fmus.py run FMUs under it
#   gcc        compiles the native C core for the ctypes tests and the C hosts of the native FMUs, and
#              builds the Linux binaries of the native FMUs (without it, zig from the ziglang wheel does)
#   binutils   nm and objdump: no global state in the C objects, exported symbols, glibc versions
#   wine wine64  tests/test_native_windows.py runs the win64 binaries under wine (wine64 holds the 64-bit
#              loader, wine the `wine` launcher); without their recommends, which add 97 desktop packages
#              a console .exe does not need: 24 packages, 105 MB, about 10 s on Debian 12
#   libtbb12   Intel's oneTBB runtime, which the Ecos engine of the ecospy wheel links against
#              (tests/test_ecos.py)
#   chromium   a real headless browser opens a study's report.html (tests/test_study.py), without its
#              recommends
# Without them the tests that need them skip, each with its reason.
#
#   scripts/system_packages.sh          install what is missing (as root, apt-get; what .ci/run and
#                                       `make system-packages` run); exits 1 if it cannot
#   scripts/system_packages.sh --check  install nothing: one note naming what is missing, what skips
#                                       and how to install it (what `make test` prints); exits 0
set -u
missing=()
command -v valgrind >/dev/null 2>&1 || missing+=(valgrind)
command -v gcc >/dev/null 2>&1 || missing+=(gcc)
{ command -v nm >/dev/null 2>&1 && command -v objdump >/dev/null 2>&1; } || missing+=(binutils)
{ /sbin/ldconfig -p 2>/dev/null || ldconfig -p 2>/dev/null; } | grep -q 'libtbb\.so\.12 ' || missing+=(libtbb12)
lean=()  # installed without recommends
command -v wine64 >/dev/null 2>&1 || { command -v wine >/dev/null 2>&1 && [ -x /usr/lib/wine/wine64 ]; } \
  || lean+=(wine wine64)
[ -x /usr/bin/chromium ] || lean+=(chromium)
all=("${missing[@]}" "${lean[@]}")
[ ${#all[@]} -eq 0 ] && exit 0
cmds="apt-get update"
[ ${#missing[@]} -eq 0 ] || cmds+=" && apt-get install -y ${missing[*]}"
[ ${#lean[@]} -eq 0 ] || cmds+=" && apt-get install -y --no-install-recommends ${lean[*]}"
how="as root on Debian: make system-packages, or ${cmds}"
if [ "${1:-}" = --check ]; then
  echo "note: ${all[*]} not installed: the tests that need them will be skipped (${how})"
  exit 0
fi
if [ "$(id -u)" != 0 ] || ! command -v apt-get >/dev/null 2>&1; then
  echo "cannot install ${all[*]} here (needs root and apt-get); ${how#as root on Debian: }" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
echo "system packages for the tests (see scripts/system_packages.sh for why each): installing ${all[*]}"
set -e
apt-get update -qq
[ ${#missing[@]} -eq 0 ] || apt-get install -y -qq "${missing[@]}" >/dev/null
[ ${#lean[@]} -eq 0 ] || apt-get install -y -qq --no-install-recommends "${lean[@]}" >/dev/null
echo "installed: ${all[*]}"
