#!/usr/bin/env bash
# The test command: installs what is missing, builds, and runs the whole suite with ctest.
#
#   scripts/test.sh [ctest arguments...]                        plain build in build/
#   scripts/test.sh --sanitize address,undefined [ctest args]   ASan + UBSan in build-asan/
#   scripts/test.sh --sanitize thread [ctest args]              TSan in build-tsan/
#   TESSREF_TEST_SUITES="test_hostile;test_scene" scripts/test.sh ...   those suites only
#
# Sanitized builds leave out the benchmarks and run the same suite; any sanitizer report
# fails the test that caused it (the tessref executable the end-to-end tests start is
# sanitized too). Suppressions, each with its reason, are in scripts/sanitizers/.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

sanitize=""
if [[ "${1:-}" == "--sanitize" ]]; then
  sanitize=${2:?"--sanitize needs address,undefined or thread"}
  shift 2
elif [[ "${1:-}" == --sanitize=* ]]; then
  sanitize=${1#--sanitize=}
  shift
fi

case "$sanitize" in
  "") ;;
  address,undefined|undefined,address)
    export BUILD_DIR=${BUILD_DIR:-build-asan}
    export CMAKE_ARGS="${CMAKE_ARGS:-} -DTESSREF_SANITIZE=address,undefined -DTESSREF_BUILD_BENCH=OFF"
    # intercept_tls_get_addr=0: GCC 12's sanitizer runtime takes a dynamic TLS block whose
    # address is 16 past a page boundary for one with a glibc 2.19 header, reads the two words
    # before it as an address and a length, and LeakSanitizer's exit-time tracer then dies
    # scanning that range ("Tracer caught signal 11", exit 1, no report). OpenImageIO's module
    # pulls in some 200 libraries with TLS, so about 1 in 15 sanitized EXR-writing processes
    # hit it (10 of 190 runs; 0 of 120 with this option). The cost: LeakSanitizer no longer
    # scans dlopen'd libraries' thread_local blocks as roots, which can only add reports.
    export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1:strict_string_checks=1:detect_stack_use_after_return=1:intercept_tls_get_addr=0"
    export LSAN_OPTIONS="suppressions=$root/scripts/sanitizers/lsan.supp:print_suppressions=0"
    export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1:suppressions=$root/scripts/sanitizers/ubsan.supp"
    ;;
  thread)
    export BUILD_DIR=${BUILD_DIR:-build-tsan}
    export CMAKE_ARGS="${CMAKE_ARGS:-} -DTESSREF_SANITIZE=thread -DTESSREF_BUILD_BENCH=OFF"
    # history_size=7: the largest memory of earlier accesses, so that the other side of a
    # report has its stack; a report whose earlier access TSan "failed to restore the stack"
    # of cannot be matched against the oneTBB suppressions in tsan.supp (seen on the
    # caller's stack-held wait node, reused by the next frame: tsan.supp says why).
    export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:history_size=7:suppressions=$root/scripts/sanitizers/tsan.supp"
    ;;
  *)
    echo "test.sh: --sanitize takes address,undefined or thread, not '$sanitize'" >&2
    exit 2
    ;;
esac

# TESSREF_TEST_SUITES="test_a;test_b" builds and runs only those suites (and the fuzz
# replays); empty or unset: everything. Passed every time, so a build directory never keeps
# an earlier run's subset.
export CMAKE_ARGS="${CMAKE_ARGS:-} -DTESSREF_TEST_SUITES=${TESSREF_TEST_SUITES:-}"

scripts/install-deps.sh
scripts/build.sh
BUILD_DIR=${BUILD_DIR:-build}
ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$(nproc)" "$@"
