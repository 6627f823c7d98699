#!/usr/bin/env bash
# The long fuzz run (docs/fuzzing.md): builds the libFuzzer harnesses (clang, ASan + UBSan) and
# fuzzes each for SECONDS (default 600) from its seeds, its regression inputs and the corpus
# grown by earlier runs (kept in <build dir>/fuzz/long/<harness>/corpus). Runs in libFuzzer's fork
# mode, so a crash is saved and fuzzing goes on; prints per harness the executions, coverage and
# corpus size, and fails when any harness crashed, ran out of memory or timed out.
#
#   scripts/fuzz.sh [seconds-per-harness]       FUZZ_BUILD_DIR (default build-fuzz), FUZZ_JOBS (build)
set -euo pipefail
cd "$(dirname "$0")/.."

seconds=${1:-600}
dir=${FUZZ_BUILD_DIR:-build-fuzz}
jobs=${FUZZ_JOBS:-$(nproc)}
harnesses=(app_files vector_reader polyhedra cache_readers)

cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DSTENCIL_GIS_SANITIZE=ON -DSTENCIL_GIS_FUZZ=ON -DSTENCIL_GIS_BUILD_TESTS=OFF -DSTENCIL_GIS_BUILD_GL_TESTS=OFF \
  -DSTENCIL_GIS_WITH_VIEWER=OFF >/dev/null
cmake --build "$dir" -j "$jobs" --target stencil_gis_fuzzers

summary=()
failed=0
for h in "${harnesses[@]}"; do
  work="$dir/fuzz/long/$h"
  mkdir -p "$work/corpus" "$work/artifacts"
  cp -n fuzz/corpus/"$h"/* "$work/corpus/"
  if compgen -G "fuzz/regressions/$h/*" >/dev/null; then cp -n fuzz/regressions/"$h"/* "$work/corpus/"; fi
  before=$(find "$work/artifacts" -type f | wc -l)
  echo "fuzz: $h for $seconds s (log: $work/log.txt)"
  # -fork=1: one fuzzing job at a time in a child process; crashes, OOMs and timeouts are
  # written to artifacts/ and the run goes on.
  "$dir/fuzz/${h}_fuzzer" -fork=1 -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1 \
    -max_total_time="$seconds" -rss_limit_mb=4096 -timeout=20 -artifact_prefix="$work/artifacts/" \
    "$work/corpus" >"$work/log.txt" 2>&1 || true
  # The last status line: "#<execs>: cov: <edges> ft: <features> corp: <files> exec/s <n> oom/timeout/crash: a/b/c ..."
  last=$(grep -E '^#[0-9]+: cov:' "$work/log.txt" | tail -n 1 || true)
  execs=$(sed -E 's/^#([0-9]+):.*/\1/' <<<"$last")
  cov=$(sed -E 's/.* cov: ([0-9]+).*/\1/' <<<"$last")
  ft=$(sed -E 's/.* ft: ([0-9]+).*/\1/' <<<"$last")
  problems=$(sed -E 's|.*oom/timeout/crash: ([0-9/]+).*|\1|' <<<"$last")
  files=$(find "$work/corpus" -type f | wc -l)
  bytes=$(du -sk "$work/corpus" | cut -f1)
  found=$(($(find "$work/artifacts" -type f | wc -l) - before))
  rate=$((${execs:-0} / (seconds > 0 ? seconds : 1)))
  summary+=("$(printf '%-14s %6ss %12s execs %7s/s  cov %6s  ft %7s  corpus %6s files %7s KiB  oom/timeout/crash %s' \
    "$h" "$seconds" "${execs:-?}" "$rate" "${cov:-?}" "${ft:-?}" "$files" "$bytes" "${problems:-?}")")
  if [ "$found" -gt 0 ]; then
    failed=1
    summary+=("               $found new reproducer(s) in $work/artifacts/")
  fi
done

echo
echo "fuzz: summary"
printf '%s\n' "${summary[@]}"
exit "$failed"
