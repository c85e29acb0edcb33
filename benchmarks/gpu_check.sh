#!/usr/bin/env bash
# GPU readiness check, for the first time a CUDA machine is available (under 5 minutes):
#   fieldmap verify on the device, then the grid, point and strapdown benchmarks on it,
#   and one summary table (step, exit status, seconds, headline lines).
# Nothing in CI depends on it.
#
# Usage: benchmarks/gpu_check.sh [--device cuda|cuda:N] [--quick] [--out DIR]
#        benchmarks/gpu_check.sh --device cpu --quick     # dry run of the same steps on the CPU
# Exit status: 0 all steps passed, 1 a step failed or timed out, 2 no such device.
set -uo pipefail
cd "$(dirname "$0")/.."

DEVICE=cuda
QUICK=0
OUT=""
while [ $# -gt 0 ]; do
  case "$1" in
    --device) DEVICE="$2"; shift 2 ;;
    --device=*) DEVICE="${1#*=}"; shift ;;
    --quick) QUICK=1; shift ;;
    --out) OUT="$2"; shift 2 ;;
    -h|--help) sed -n '2,9p' "$0"; exit 0 ;;
    *) echo "gpu_check: unknown option $1 (see --help)" >&2; exit 2 ;;
  esac
done

PY="${PYTHON:-}"
if [ -z "$PY" ]; then
  if [ -x .venv/bin/python ]; then PY=.venv/bin/python; else PY=python3; fi
fi
FIELDMAP=("$PY" -m fieldmap)
if ! "$PY" -c "import fieldmap.cli" 2>/dev/null; then
  echo "gpu_check: fieldmap is not importable with $PY (set PYTHON=...)" >&2
  exit 2
fi

# fail fast (seconds) when the device is absent
if ! "$PY" - "$DEVICE" <<'EOF'
import sys
from fieldmap import _warp
want = sys.argv[1]
names = _warp.devices()
if want.startswith("cuda"):
    if not any(n.startswith("cuda") for n in names):
        sys.exit(f"gpu_check: no CUDA device on this machine (Warp sees: {', '.join(names)})")
try:
    _warp.resolve_device(want)
except Exception as exc:  # DeviceError: one line
    sys.exit(f"gpu_check: {exc}")
EOF
then
  exit 2
fi

LOG="${OUT:-$(mktemp -d -t fieldmap-gpu-check.XXXXXX)}"
mkdir -p "$LOG"
if [ "$QUICK" = 1 ]; then
  Q=(--quick); LMAX=60; REP=2; PTS=2000; T=120
else
  Q=(); LMAX=240; REP=3; PTS=200000; T=150
fi

declare -a NAMES RCS SECS
run_step() {  # name, timeout (s), command...
  local name="$1" limit="$2"; shift 2
  local t0 t1 rc
  echo "== $name: $*"
  t0=$(date +%s.%N)
  timeout "$limit" "$@" >"$LOG/$name.log" 2>&1
  rc=$?
  t1=$(date +%s.%N)
  tail -n 4 "$LOG/$name.log" | sed 's/^/   /'
  NAMES+=("$name"); RCS+=("$rc"); SECS+=("$(awk "BEGIN{print $t1 - $t0}")")
}

run_step verify "$T" "${FIELDMAP[@]}" verify --device "$DEVICE" --lmax "$LMAX"
# the kernels' own tests on this device (their device-parametrised cases), grid kernels first:
# the eight-lane Legendre passes (scaled and extended-range) have never run on CUDA
run_step kernels "$T" "$PY" -m pytest -q -p no:cacheprovider -m "not slow" -k "${DEVICE%%:*}" \
  tests/test_grid_xrange.py tests/test_grid.py tests/test_any_degree.py tests/test_sh.py
run_step grid "$T" "$PY" benchmarks/bench_grid.py --device "$DEVICE" --repeat "$REP" "${Q[@]}"
run_step points "$T" "$PY" benchmarks/bench_points.py --device "$DEVICE" --repeats "$REP" \
  --points "$PTS" --tool-points 500 --pyshtools-points 50 --skip-cli
run_step strapdown "$T" "$PY" benchmarks/bench_strapdown.py --device "$DEVICE" --repeat "$REP" \
  "${Q[@]}"

echo
echo "GPU check on $DEVICE ($([ "$QUICK" = 1 ] && echo quick || echo full)); logs in $LOG"
printf '%-10s %-9s %8s  %s\n' step status seconds headline
status=0
for i in "${!NAMES[@]}"; do
  rc="${RCS[$i]}"
  case "$rc" in
    0) st=ok ;;
    124) st=TIMEOUT; status=1 ;;
    *) st="FAIL($rc)"; status=1 ;;
  esac
  head_line=$(grep -E 'checks within|ratio|FAIL|failed|passed|traj-steps/s|x$' \
    "$LOG/${NAMES[$i]}.log" | tail -n 1 | cut -c1-90)
  printf '%-10s %-9s %8.1f  %s\n' "${NAMES[$i]}" "$st" "${SECS[$i]}" "$head_line"
done
exit $status
