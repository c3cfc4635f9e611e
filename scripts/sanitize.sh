#!/usr/bin/env bash
# The native tests under sanitizers (docs/reliability.md, "Sanitizers"):
#   scripts/sanitize.sh asan [ctest args...]   AddressSanitizer + UndefinedBehaviorSanitizer, build-asan/
#   scripts/sanitize.sh tsan [ctest args...]   ThreadSanitizer (the parallel passes), build-tsan/
#   scripts/sanitize.sh all                    both
# Debian's gcc, -O1 -g1; any report fails the test that caused it (-fno-sanitize-recover=all,
# halt_on_error). Configures and builds what is missing; the Python module is not built.
# GRADPHOTON_JOBS sets the build's parallelism (default: all cores). Extra arguments go to ctest,
# e.g. `scripts/sanitize.sh tsan -R 'Sppm|Gpm'`.
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 1 ] || { echo "usage: scripts/sanitize.sh asan|tsan|all [ctest args]" >&2; exit 2; }
kind="$1"
shift
kinds=("$kind")
[ "$kind" = all ] && kinds=(asan tsan)

status=0
for k in "${kinds[@]}"; do
  case "$k" in
    asan) flags="address,undefined"; extra=() ;;
    tsan) flags="thread"; extra=(-DGRADPHOTON_PARALLEL=threads) ;;  # std::thread back-end: TSan sees every hand-over
    *) echo "unknown sanitizer build '$k' (asan, tsan, all)" >&2; exit 2 ;;
  esac
  dir="build-$k"
  if [ ! -f "$dir/build.ninja" ]; then
    cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release -DGRADPHOTON_SANITIZE="$flags" \
      -DGRADPHOTON_BUILD_PYTHON=OFF "${extra[@]}" >/dev/null
  fi
  cmake --build "$dir" --parallel "${GRADPHOTON_JOBS:-$(nproc)}"
  echo "== native tests under $flags ($dir) =="
  # Embree and oneTBB are not instrumented: scripts/sanitizers.supp lists what they report on
  # their own (nothing of gradphoton's is suppressed).
  export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1:abort_on_error=1:strict_string_checks=1"
  export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
  export LSAN_OPTIONS="suppressions=$PWD/scripts/lsan.supp"
  export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$PWD/scripts/tsan.supp"
  start=$(date +%s)
  if ctest --test-dir "$dir" --output-on-failure --timeout 1800 --parallel "$(nproc)" "$@"; then
    echo "$k: all tests passed in $(( $(date +%s) - start )) s"
  else
    echo "$k: failures (above)"
    status=1
  fi
done
exit $status
