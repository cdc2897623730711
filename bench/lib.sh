# Shared by the Python benchmarks (installations, verdict, real): build tolles in release,
# then run bench/SCRIPT with a virtual environment holding PACKAGES (BENCH_VENV=DIR reuses
# DIR; otherwise a throwaway one).
#
#   source bench/lib.sh; run_python_bench SCRIPT.py "numpy scipy pandas" "$@"
run_python_bench() {
    local script="$1" packages="$2"
    shift 2
    local root
    root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
    cd "$root"
    echo "building tolles (release) ..." >&2
    cargo build --release --quiet -p tolles-cli
    local venv="${BENCH_VENV:-}"
    if [[ -z "$venv" ]]; then
        venv="$(mktemp -d "${TMPDIR:-/tmp}/tolles-bench-venv.XXXXXX")"
        trap "rm -rf '$venv'" EXIT
    fi
    if [[ ! -x "$venv/bin/python" ]]; then
        echo "creating a virtual environment in $venv ($packages) ..." >&2
        python3 -m venv "$venv"
        # shellcheck disable=SC2086
        "$venv/bin/pip" install --quiet --disable-pip-version-check $packages
    fi
    "$venv/bin/python" "$root/bench/$script" --tolles "$root/target/release/tolles" "$@"
}
