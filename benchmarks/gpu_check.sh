#!/usr/bin/env bash
# The GPU checks of docs/benchmarks.md, prepared to run on a lent device machine (the `device`
# tool's `run`: one NVIDIA GPU, 16 cores, an image with torch and torch-geometric but none of
# tleaf's other packages, nothing reachable from it). Each part ends well inside one call's
# 10 minutes; results land in $OUT (the device's, else out/gpu-check).
#
#   bash benchmarks/gpu_check.sh wheels   # here, once: the packages the image lacks, as wheels
#                                         # for its Python 3.12 in .whl/ (git-ignored locally)
#   bash benchmarks/gpu_check.sh speed    # there (carry .whl): tests/test_devices.py on cuda,
#                                         # then speed.py --devices cpu cuda (~6 min)
#   bash benchmarks/gpu_check.sh table1   # there (carry .whl): the Table I pipeline's best
#                                         # and syntax rows, 3 tiers x 3 seeds, on cuda, timed
#   DEVICE=cpu SMALL=1 bash benchmarks/gpu_check.sh table1   # the same steps, tiny, anywhere
set -euo pipefail
cd "$(dirname "$0")/.."
OUT="${OUT:-out/gpu-check}"
mkdir -p "$OUT"
# what the device image lacks (its own torch, torch-geometric, numpy, pyarrow, ... are used)
WHEELS="ltlf2dfa==2.0.0 lark==1.3.1 gymnasium==1.4.0 farama-notifications==0.0.6
stable-baselines3==2.9.2 sb3-contrib==2.9.2 rapidfuzz==3.14.6 typer==0.29.2 rich==15.0.0"

setup() {
    if ! python3 -c "import ltlf2dfa, gymnasium, rapidfuzz, typer" 2>/dev/null; then
        python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
            --target /tmp/site .whl/*.whl
    fi
    export PYTHONPATH="/tmp/site:$PWD" PYTHONUNBUFFERED=1
    mkdir -p /tmp/bin
    printf '#!/bin/sh\nexec python3 -c "from tleaf_cli.cli import main; main()" "$@"\n' \
        > /tmp/bin/tleaf
    chmod +x /tmp/bin/tleaf
    export PATH="/tmp/bin:$PATH"
    {
        nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader || true
        python3 -c "import torch; print('torch', torch.__version__, torch.cuda.is_available())"
        lscpu | grep -E 'Model name|^CPU\(s\)'
    } | tee "$OUT/machine.txt"
}

case "${1:-}" in
wheels)
    mkdir -p .whl
    grep -qx '/.whl/' .git/info/exclude 2>/dev/null || echo '/.whl/' >> .git/info/exclude
    # shellcheck disable=SC2086
    python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 \
        --implementation cp --platform manylinux_2_28_x86_64 --platform manylinux_2_17_x86_64 \
        --platform manylinux2014_x86_64 -d .whl $WHEELS
    ls .whl
    ;;
speed)
    setup
    python3 -m pytest -q -p no:cacheprovider tests/test_devices.py 2>&1 | tail -5 | tee "$OUT/tests.txt"
    python3 benchmarks/speed.py --devices cpu cuda --out /tmp/speed 2>&1 | tee "$OUT/speed.txt"
    cp /tmp/speed/speed.json "$OUT/"
    ;;
table1)
    setup
    start=$(date +%s.%N)
    rm -rf /tmp/mc
    make -f pipelines/model_checking.mk ROWS="dfa syntax" DEVICE="${DEVICE:-cuda}" \
        SMALL="${SMALL:-0}" OUT=/tmp/mc -j 16 2>&1 | tail -20
    end=$(date +%s.%N)
    python3 -c "print(f'Table I pipeline (best and syntax rows) on ${DEVICE:-cuda}: \
{$end - $start:.0f} s wall')" | tee "$OUT/table1.txt"
    cp /tmp/mc/results.md "$OUT/"
    ;;
*)
    echo "usage: bash benchmarks/gpu_check.sh wheels|speed|table1" >&2
    exit 2
    ;;
esac
