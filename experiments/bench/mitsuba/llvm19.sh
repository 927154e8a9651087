#!/bin/sh
# Prints the libLLVM-19.so that Mitsuba's llvm_ad_rgb should load (DRJIT_LIBLLVM_PATH), or nothing
# with the reason on stderr; installs Debian's libllvm19 when missing and we are root. LLVM 19 because
# Debian 12's default LLVM 14 crashes Dr.Jit. Used by `make bench-compare` and `make crosscheck`:
#   DRJIT_LIBLLVM_PATH="$(sh experiments/bench/mitsuba/llvm19.sh TARGET)" python -m ...
# TARGET only prefixes the messages. The Python side (scene.find_libllvm) says why once more and skips.
tag="${1:-llvm19}"
find19() { ls /usr/lib/llvm-19/lib/libLLVM-19.so /usr/lib/*-linux-gnu/libLLVM-19.so 2>/dev/null | head -n 1; }
llvm="${DRJIT_LIBLLVM_PATH:-}"
[ -n "$llvm" ] || llvm=$(find19)
if [ -z "$llvm" ]; then
  why=""
  if [ "$(id -u)" != 0 ]; then
    why="not root, so libllvm19 cannot be apt-get installed here: install it (Debian 12+) or set DRJIT_LIBLLVM_PATH to a libLLVM-19.so"
  elif ! command -v apt-get >/dev/null 2>&1; then
    why="no apt-get on this system: install LLVM 19 and set DRJIT_LIBLLVM_PATH to its libLLVM-19.so"
  else
    echo "$tag: apt-get install -y libllvm19 (for Dr.Jit's LLVM backend)" >&2
    export DEBIAN_FRONTEND=noninteractive
    { apt-get install -y -qq libllvm19 >/dev/null 2>&1 || { apt-get update -qq >/dev/null 2>&1 && apt-get install -y -qq libllvm19 >/dev/null 2>&1; }; } \
      || why="apt-get install libllvm19 failed (not in this system's package lists?): set DRJIT_LIBLLVM_PATH to a libLLVM-19.so"
    llvm=$(find19)
  fi
  [ -n "$llvm" ] || echo "$tag: no LLVM 19 for Mitsuba's llvm_ad_rgb: ${why:-libllvm19 is installed but no libLLVM-19.so was found}" >&2
fi
echo "$llvm"
