#!/usr/bin/env bash
# Builds every fuzz target and runs each for SECONDS (default 60), on stable
# Rust: `cargo fuzz ... --sanitizer none` needs no nightly flag.
#
#   fuzz/run.sh [SECONDS] [TARGET...]
#   fuzz/run.sh --long [TARGET...]      # 600 s each (every target: about 2 h)
#
# New inputs that reach new code are added to fuzz/corpus/<target>/ (they are
# git-ignored; commit only a hand-picked or `cargo fuzz cmin`ed few). Crashes
# land in fuzz/artifacts/<target>/ and make the script exit 1 after every
# target has run. Each target runs under a 4 GiB address-space cap, so an
# allocation sized by a lying header is a crash (without a sanitizer,
# libFuzzer's -malloc_limit_mb cannot see allocations). Prints executions and
# exec/s per target.
set -uo pipefail
cd "$(dirname "$0")"
secs=${1:-60}
[ "$secs" = --long ] && secs=600
shift || true
case $secs in
    '' | *[!0-9]*)
        echo "usage: fuzz/run.sh [SECONDS | --long] [TARGET...]" >&2
        exit 2
        ;;
esac
command -v cargo-fuzz >/dev/null || {
    echo "cargo-fuzz missing: cargo install cargo-fuzz --locked" >&2
    exit 2
}
# The build users run: release without overflow checks. FUZZ_DEBUG_ASSERTIONS=1
# adds them (deeper local runs): then third-party decoders also stop on integer
# overflows that wrap harmlessly in the shipped build (laz 0.13 point0.rs does,
# inside its own rayon workers, where no catch can reach it).
flags=(--sanitizer none --release)
[ "${FUZZ_DEBUG_ASSERTIONS:-0}" = 1 ] && flags=(--sanitizer none --debug-assertions)
cargo fuzz build "${flags[@]}" || exit 1
targets=("$@")
[ ${#targets[@]} -gt 0 ] || mapfile -t targets < <(cargo fuzz list)
mkdir -p logs
status=0
printf '%-10s %12s %10s %s\n' target executions exec/s result
for t in "${targets[@]}"; do
    mkdir -p "corpus/$t"
    log="logs/$t.log"
    (
        ulimit -v $((4 << 20))
        cargo fuzz run "${flags[@]}" "$t" "corpus/$t" -- \
            -max_total_time="$secs" -timeout=10 -rss_limit_mb=3072 \
            -max_len=65536 -print_final_stats=1
    ) >"$log" 2>&1
    rc=$?
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
    rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
    if [ $rc -eq 0 ]; then
        result=ok
    else
        result="CRASH (exit $rc, see fuzz/$log and fuzz/artifacts/$t/)"
        status=1
    fi
    printf '%-10s %12s %10s %s\n' "$t" "${execs:-?}" "${rate:-?}" "$result"
done
exit $status
