#!/usr/bin/env bash
# Sanitizer run of the test suite, independent of CI (docs/sanitizers.md).
#   scripts/sanitize.sh address|thread [ctest args...]
# Configures build-<kind> (LOCI_SANITIZE=<kind>, every test's timeout 2400 s), builds it (only
# $TARGETS when set, e.g. TARGETS=common_test), runs ctest with the sanitizer's options and
# collects every process's reports (children included) in build-<kind>/sanitizer-logs.
# Prints the number of reports; exits non-zero if there is any, or if ctest failed.
# Run it under `nice -n 19` on a shared machine; JOBS (default 2) sets the build's -j.
set -euo pipefail

kind=${1:-}
case "$kind" in
  address | thread) shift ;;
  *) echo "usage: $0 address|thread [ctest args...]" >&2; exit 2 ;;
esac
root=$(cd "$(dirname "$0")/.." && pwd)
build=$root/build-$kind
logs=$build/sanitizer-logs

cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DLOCI_SANITIZE="$kind" \
  -DLOCI_TEST_TIMEOUT=2400
# shellcheck disable=SC2086  # TARGETS is a list of target names
cmake --build "$build" -j"${JOBS:-2}" ${TARGETS:+--target $TARGETS}

rm -rf "$logs" && mkdir -p "$logs"
if [[ $kind == address ]]; then
  export ASAN_OPTIONS="detect_leaks=1 log_path=$logs/asan log_exe_name=1"
  # GCC's libubsan writes its reports to stderr even with log_path (docs/sanitizers.md); they
  # abort the process (-fno-sanitize-recover=undefined) and are counted from the test output.
  export UBSAN_OPTIONS="print_stacktrace=1 log_path=$logs/ubsan log_exe_name=1"
else
  export TSAN_OPTIONS="halt_on_error=0 second_deadlock_stack=1 log_path=$logs/tsan log_exe_name=1 suppressions=$root/tests/sanitizers/tsan.supp"
fi

status=0
(cd "$build" && ctest --output-on-failure --no-tests=error "$@") || status=$?

# One SUMMARY line per ASan/TSan/UBSan report (LeakSanitizer: one per process with leaks).
shopt -s nullglob  # no report file: count 0
reports=$(cat "$logs"/* /dev/null | grep -c '^SUMMARY: ' || true)
ubsan=$(grep -c 'runtime error: ' "$build/Testing/Temporary/LastTest.log" 2>/dev/null || true)
echo "sanitize.sh $kind: ctest exit $status, ${reports:-0} report(s) in $logs," \
  "${ubsan:-0} UBSan 'runtime error' line(s) in the test output"
ls "$logs"
if ((status != 0 || ${reports:-0} > 0 || ${ubsan:-0} > 0)); then exit 1; fi
