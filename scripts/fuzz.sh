#!/usr/bin/env bash
# Fuzzes a loader with libFuzzer (Debian's clang), AddressSanitizer and UBSan:
#   scripts/fuzz.sh TARGET SECONDS [libFuzzer flags...]     TARGET: scene, obj, exr, vdb or all
# Configures and builds build-fuzz/ (only the fuzz targets and the parts of the core they use)
# when needed. Seeds come from fuzz/corpus/TARGET (committed); what the fuzzer finds on top
# goes to build-fuzz/corpus/TARGET, a failing input to build-fuzz/artifacts/. Prints one line
# per target: executions, seconds, crashes. Exit status 1 when a target found anything.
# A finding, once fixed, joins fuzz/corpus/TARGET so that CTest replays it (fuzz_corpus_TARGET).
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 2 ] || { echo "usage: scripts/fuzz.sh scene|obj|exr|vdb|all SECONDS [libFuzzer flags]" >&2; exit 2; }
what="$1" seconds="$2"
shift 2
# vdb: the loader walks each file's whole archive (header, metadata, descriptors, transforms,
# tree topology and buffers, blosc / zip chunk headers) before OpenVDB 10 reads it, so a length
# or count from the file never reaches OpenVDB's own allocations (media/vdb_file.cpp ArchiveScan,
# docs/reliability.md); its seeds are written by fuzz/vdb_corpus.cpp.
targets=(scene obj exr vdb)
[ "$what" = all ] || targets=("$what")

if [ ! -f build-fuzz/build.ninja ]; then
  CC=clang CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DGRADPHOTON_BUILD_FUZZ=ON -DGRADPHOTON_BUILD_TESTS=OFF -DGRADPHOTON_BUILD_PYTHON=OFF >/dev/null
fi
cmake --build build-fuzz --parallel "${GRADPHOTON_JOBS:-$(nproc)}" --target "${targets[@]/#/fuzz_}"

status=0
for t in "${targets[@]}"; do
  mkdir -p "build-fuzz/corpus/$t" build-fuzz/artifacts
  log="build-fuzz/fuzz_$t.log"
  # -timeout: one input taking 30 s is a hang (the corpus's Nishita sky seed takes 1 s in a release
  # build and 5-11 s under ASan on a loaded 2-core machine); -rss_limit_mb: libFuzzer's default cap.
  # vdb: OpenVDB 10 leaks the node it was reading when a corrupt file's topology throws
  # (tree/RootNode.h, readTopology: a `new` before the read that fails), inside the library;
  # one leak per failed load, so leak detection is off for that target (ASan/UBSan stay on):
  # libFuzzer's per-input check (-detect_leaks=0) and LeakSanitizer's at exit (ASAN_OPTIONS), which
  # otherwise reports the leaks of the run's corrupt inputs and fails it on the last input.
  extra=()
  asan=${ASAN_OPTIONS:-}
  [ "$t" = vdb ] && extra=(-detect_leaks=0) && asan="${asan:+$asan:}detect_leaks=0"
  if ASAN_OPTIONS="$asan" build-fuzz/fuzz/fuzz_"$t" -max_total_time="$seconds" -timeout=30 -rss_limit_mb=2048 "${extra[@]}" \
      -dict="fuzz/$t.dict" -artifact_prefix="build-fuzz/artifacts/$t-" -print_final_stats=1 "$@" \
      "build-fuzz/corpus/$t" "fuzz/corpus/$t" >"$log" 2>&1; then
    crashes=0
  else
    crashes=1
    status=1
  fi
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  # (|| true: a run that ends on a finding prints no "Done" line, and pipefail would end the script
  # before its report line.)
  secs=$(grep -o 'Done [0-9]* runs in [0-9]* second' "$log" | tail -1 | awk '{print $5}' || true)
  echo "fuzz $t: ${runs:-?} executions in ${secs:-$seconds} s, corpus $(ls "build-fuzz/corpus/$t" | wc -l) inputs, crashes: $crashes (log: $log)"
  if [ "$crashes" != 0 ]; then grep -E 'ERROR|SUMMARY|runtime error|artifact|error message' "$log" | head -20 >&2; fi
done
exit $status
