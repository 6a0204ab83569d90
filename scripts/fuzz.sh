#!/usr/bin/env bash
# scripts/fuzz.sh — builds the libFuzzer harnesses of fuzz/ (clang-15, ASan + UBSan, into
# build-fuzz/) and fuzzes one target, or all of them one after the other.
#
#   scripts/fuzz.sh list                  the targets (fuzz/targets.txt)
#   scripts/fuzz.sh TARGET [SECONDS]      fuzz TARGET for SECONDS (default 240)
#   scripts/fuzz.sh all [SECONDS]         every target, SECONDS each
#   scripts/fuzz.sh A,B,C [SECONDS]       those targets, one after the other (all are built
#                                         first, so the sources may change while they run)
#   scripts/fuzz.sh TARGET -runs=N        stop after N executions instead (any other
#                                         libFuzzer flag after TARGET is passed on too)
#
# Environment: FUZZ_JOBS (default 1; parallel libFuzzer jobs), FUZZ_BUILD_DIR (default
# build-fuzz), FUZZ_CORPUS_DIR (default build-fuzz/corpus; one folder per target, kept
# between runs so a long campaign continues where the last one stopped).
#
# Prints the executions, the coverage (cov: edges) and every crash/leak/timeout/oom file;
# exits 1 when there was a finding (the files are under build-fuzz/findings/<target>/; a
# fixed one belongs in tests/data/fuzz/<target>/, which ctest replays). Needs clang-15 and
# libfuzzer-15-dev (Debian: apt-get install clang-15 libfuzzer-15-dev); the normal build
# and tests do not.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
build=${FUZZ_BUILD_DIR:-$root/build-fuzz}
corpus_root=${FUZZ_CORPUS_DIR:-$build/corpus}
jobs=${FUZZ_JOBS:-1}

targets() { grep -E '^[a-z]' "$root/fuzz/targets.txt" | awk '{print $1}'; }
target_line() { grep -E "^$1[[:space:]]" "$root/fuzz/targets.txt"; }

usage() { sed -n '2,21p' "$0" | sed 's/^# \{0,1\}//'; exit 2; }

[ $# -ge 1 ] || usage
case "$1" in
  -h|--help) usage ;;
  list) targets; exit 0 ;;
esac

if ! command -v clang++-15 >/dev/null || ! ls /usr/lib/llvm-15/lib/clang/*/lib/linux/libclang_rt.fuzzer-x86_64.a >/dev/null 2>&1; then
  echo "fuzz.sh: needs clang-15 and libFuzzer: apt-get install clang-15 libfuzzer-15-dev" >&2
  exit 2
fi

build_targets() {
  if [ ! -f "$build/build.ninja" ]; then
    launcher=()
    command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
    cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      -DCMAKE_CXX_COMPILER=clang++-15 "${launcher[@]}" -DTESSREF_FUZZ=ON \
      -DTESSREF_BUILD_TESTS=OFF -DTESSREF_BUILD_BENCH=OFF >/dev/null
  fi
  local names=()
  for t in "$@"; do names+=("fuzz_$t"); done
  # tessref_oiio: the OpenImageIO module, for inputs that are neither PNG nor PNM (TIFF).
  cmake --build "$build" -j "${FUZZ_BUILD_JOBS:-2}" --target "${names[@]}" tessref_oiio
}

# fuzz_one TARGET LIBFUZZER-ARGS...: returns 1 on a finding.
fuzz_one() {
  local target=$1; shift
  local line dict seeds corpus findings log
  line=$(target_line "$target") || { echo "fuzz.sh: unknown target '$target' (scripts/fuzz.sh list)" >&2; exit 2; }
  read -r _ dict seeds <<<"$line"
  corpus=$corpus_root/$target
  findings=$build/findings/$target
  log=$build/logs/$target.log
  mkdir -p "$corpus" "$findings" "$(dirname "$log")"
  # The seeds and the kept regression inputs join the working corpus (libFuzzer skips
  # duplicates when it loads it).
  (cd "$root" && for s in $seeds; do [ -f "$s" ] && cp -n "$s" "$corpus/" 2>/dev/null || true; done)
  [ -d "$root/tests/data/fuzz/$target" ] && cp -n "$root/tests/data/fuzz/$target"/* "$corpus/" 2>/dev/null || true
  local dict_args=()
  [ "$dict" != "-" ] && dict_args=(-dict="$root/fuzz/dict/$dict")
  local before
  before=$(find "$findings" -type f | wc -l)
  echo "fuzz.sh: $target: corpus $(find "$corpus" -type f | wc -l) files, log $log"
  set +e
  # Leaks inside system libraries that tessref cannot free are suppressed, each with its
  # reason, in the same file the sanitized test suite uses.
  export LSAN_OPTIONS="suppressions=$root/scripts/sanitizers/lsan.supp:print_suppressions=0"
  # The harnesses live in fuzz/, the OpenImageIO module beside the top-level targets.
  export TESSREF_OIIO_MODULE="$build/tessref_oiio.so"
  # -rss_limit_mb and -timeout make out-of-memory and hangs findings; the library's own
  # memory limit is set lower by the harness (fuzz/fuzz_common.h) so oversized inputs are
  # refused before libFuzzer's limit is reached. -jobs > 1 makes libFuzzer write
  # fuzz-<n>.log files in the current directory: run there in the logs folder.
  (cd "$(dirname "$log")" && "$build/fuzz/fuzz_$target" "$corpus" \
      -artifact_prefix="$findings/" -rss_limit_mb=2048 -timeout=10 -max_len=65536 \
      -print_final_stats=1 "${dict_args[@]}" \
      $([ "$jobs" -gt 1 ] && echo "-jobs=$jobs -workers=$jobs") "$@") >"$log" 2>&1
  local rc=$?
  set -e
  [ "$jobs" -gt 1 ] && cat "$(dirname "$log")"/fuzz-*.log >>"$log" 2>/dev/null && rm -f "$(dirname "$log")"/fuzz-*.log
  local execs cov
  execs=$(grep -aE '^stat::number_of_executed_units' "$log" | awk '{s += $2} END {print s + 0}')
  # A run stopped by a finding prints no final stats: take its last progress line.
  [ "$execs" -eq 0 ] && execs=$(grep -aoE '^#[0-9]+' "$log" | tail -1 | tr -d '#')
  cov=$(grep -aoE 'cov: [0-9]+' "$log" | tail -1 | awk '{print $2}')
  echo "fuzz.sh: $target: executions $execs, cov: edges ${cov:-?}, exit $rc"
  local after
  after=$(find "$findings" -type f | wc -l)
  if [ "$rc" -ne 0 ] || [ "$after" -gt "$before" ]; then
    echo "fuzz.sh: $target: FINDING(S):"
    find "$findings" -type f -newer "$log.start" 2>/dev/null | sed 's/^/  /' || true
    grep -aE '^==[0-9]+== ?ERROR|runtime error|SUMMARY|deadly signal|ALARM|Test unit written' "$log" | head -20 | sed 's/^/  /'
    return 1
  fi
  return 0
}

target=$1; shift
IFS=, read -ra list <<<"$target"
[ "$target" = all ] && mapfile -t list < <(targets)
for t in "${list[@]}"; do target_line "$t" >/dev/null || { echo "fuzz.sh: unknown target '$t' (scripts/fuzz.sh list)" >&2; exit 2; }; done

args=()
if [ $# -ge 1 ] && [[ "$1" =~ ^[0-9]+$ ]]; then args+=(-max_total_time="$1"); shift
elif [ $# -eq 0 ]; then args+=(-max_total_time=240); fi
args+=("$@")

build_targets "${list[@]}"
status=0
for t in "${list[@]}"; do
  mkdir -p "$build/logs" && touch "$build/logs/$t.log.start"
  fuzz_one "$t" "${args[@]}" || status=1
done
exit $status
