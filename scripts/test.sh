#!/usr/bin/env bash
# Sets everything up and runs all tests: installs the Debian packages, checks formatting, builds
# the release configuration and the AddressSanitizer + UndefinedBehaviorSanitizer configuration,
# runs every test (unit, headless GL, program runs, the fuzzing harnesses' saved inputs) under the
# sanitizers and, in the release build, the benchmark and the tests that differ there.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/install-deps.sh
bash scripts/check-format.sh

jobs=$(nproc)
# A compiler cache shared by the three build directories and by later runs of this script
# (paths made relative to the checkout, so another clone of the project hits it too).
launcher=()
if command -v ccache >/dev/null; then
  export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=true CCACHE_MAXSIZE=${CCACHE_MAXSIZE:-8G}
  launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
# Line tables only (-g1): stack traces and profiles keep files and lines, and the builds take about
# a quarter less time than with full debug information (measured on a CGAL source: 62 s against
# 86 s), objects a quarter the size.
flags=(-DCMAKE_C_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG")
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "${flags[@]}" "${launcher[@]}"
# Only what the release suite runs (target stencil_gis_release_suite, tests/CMakeLists.txt): the
# other tests run in the sanitizer build; building them here too cost 6-7 of a fresh machine's
# minutes (817 of 1,775 s of compile and link time in .ninja_log, 2026-12-02).
cmake --build build -j "$jobs" --target stencil_gis_release_suite
# The release suite: every benchmark run (labels "bench" and "release"), the tests whose sizes
# differ under the sanitizers (the million-vertex stress polygons), the main job's program and the
# GIS clients built against the installed package (label "release"). Every other test runs once,
# in the sanitizer suite below, whose checks are a superset: running them twice cost 10 of CI's
# 45-85 minutes on this 2-core machine (docs/measurements.md). The library runs the same
# arithmetic at -O1 and -O2 (SSE2 doubles, no -ffast-math, no FMA contraction without -march).
# A test that fails is run once more before the suite fails (as in the sanitizer suite below): a
# fault that is there fails twice; a race of a test with the machine's load shows once, and its
# output is kept in the log to be fixed (the last one, 2026-12-01: a test read a state file the
# viewer was still writing; files polled by other processes are now written whole or not at all).
ctest --test-dir build --output-on-failure -j "$jobs" --repeat until-pass:2 -L 'bench|release'

# Sanitizers (ASan, UBSan, libstdc++ bounds checks) over the whole suite, the viewer under Xvfb
# included, but for the benchmark's longer modes (label "bench": 11 min of test time there, 5.5 of
# the suite at two jobs; they run in the release suite above, the short modes run here too) and
# the tests only the release build has.
# At -O1, as the sanitizers' own documentation advises: the build's compile time is a quarter less
# (2,745 against 3,634 s of compile time in .ninja_log, 2026-12-02), the tests' time 8 % more
# (docs/measurements.md).
asan_flags=(-DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG")
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSTENCIL_GIS_SANITIZE=ON \
  -DSTENCIL_GIS_WITH_VIEWER=ON "${asan_flags[@]}" "${launcher[@]}"
cmake --build build-asan -j "$jobs"
# Failing tests run twice here too: the viewer's tests drive X with xdotool beside other GL tests,
# where a slow frame has exposed races in the tests themselves.
ctest --test-dir build-asan --output-on-failure -j "$jobs" --repeat until-pass:2 -LE bench

# The fuzzing harnesses' seeds and every saved crash are replayed by the sanitizer suite above
# (fuzz_<name>_corpus, the harnesses linked with fuzz/replay_main.cpp). Fuzzing itself needs a
# clang build of every library of its own (455 s from nothing, 2026-12-02) and 2 min of runs for
# 45 s of fuzzing per harness: it is scripts/fuzz.sh's, run apart from CI (docs/fuzzing.md).
