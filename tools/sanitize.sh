#!/usr/bin/env bash
# Builds polyhex and its unit tests with AddressSanitizer + UndefinedBehaviorSanitizer (gcc, -O1, Eigen
# assertions on) in build-asan and runs the test suite there, without the slow end-to-end tests
# ([cli], [shared]) and the on-demand benchmarks (hidden tags, [.]) by default. The [.] exclusion is
# needed: in Catch2 v2 a spec of exclusions alone also selects the hidden tests.
#   tools/sanitize.sh                       unit tests under ASan+UBSan
#   tools/sanitize.sh "[robust]"            a Catch2 test spec instead
#   SANITIZE=thread tools/sanitize.sh       another -fsanitize= list (own build dir: build-thread)
# Environment: SANITIZE (default address,undefined), BUILD_DIR (default build-asan, or build-<list>
# for another list), JOBS (default 2).
# Exit status: the test runner's; also 1 when a sanitizer printed a report (UBSan reports do not stop
# the run, so every finding of one run is listed in BUILD_DIR/sanitize.log).
set -euo pipefail
cd "$(dirname "$0")/.."
SANITIZE=${SANITIZE:-address,undefined}
default_dir=build-asan
[ "$SANITIZE" != "address,undefined" ] && default_dir="build-${SANITIZE//,/-}"
BUILD_DIR=${BUILD_DIR:-$default_dir}
JOBS=${JOBS:-2}
SPEC=${1:-"~[cli]~[shared]~[.]"}

cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS_RELEASE="-O1" \
  -DPOLYHEX_SANITIZE="$SANITIZE" >/dev/null
cmake --build "$BUILD_DIR" -j "$JOBS" --target polyhex_tests polyhex

log="$BUILD_DIR/sanitize.log"
set +e
start=$SECONDS
# Suppressions (third-party code only, each explained in its file): tools/ubsan.supp, tools/lsan.supp.
# allocator_may_return_null: an allocation beyond the machine (tests/fixtures/fuzz) throws std::bad_alloc
# as in a normal build instead of aborting the run. UBSan reports do not stop the run (halt_on_error=0).
ASAN_OPTIONS=detect_leaks=1:abort_on_error=0:allocator_may_return_null=1:detect_stack_use_after_return=1 \
UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=0:suppressions=$PWD/tools/ubsan.supp \
LSAN_OPTIONS=suppressions=$PWD/tools/lsan.supp \
  "$BUILD_DIR/tests/polyhex_tests" "$SPEC" 2>&1 | tee "$log"
rc=${PIPESTATUS[0]}
set -e
findings=$(grep -c -E "runtime error:|ERROR: AddressSanitizer|ERROR: LeakSanitizer" "$log" || true)
echo "sanitize.sh: test runner exit $rc, sanitizer reports: $findings, tests took $((SECONDS - start)) s (log: $log)"
grep -E "runtime error:|ERROR: AddressSanitizer|ERROR: LeakSanitizer|SUMMARY:" "$log" | sort | uniq -c | head -40 || true
[ "$rc" -ne 0 ] && exit "$rc"
[ "$findings" -ne 0 ] && exit 1
exit 0
