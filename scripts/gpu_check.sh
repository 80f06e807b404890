#!/usr/bin/env bash
# The one prepared device check (issue 71): on a lent GPU machine, Warp trials per minute at 2,048, 8,192 and 32,768
# worlds and their trial-by-trial agreement with the CPU on the quick grid, in one JSON, inside a budget of seconds
# (`bench_trials.py device-check`, `studies.trial_speed.device_check`). The machine reaches no package registry: it
# installs what it lacks from the packed wheels. Here, once:
#     bash ../shared/tools/device-warp-wheels        # mujoco, mujoco-warp, warp-lang -> .devwheels/a, .devwheels/b
#     echo /.whl/ >> .git/info/exclude && python3 -m pip download --no-deps -d .whl trimesh   # the one more it lacks
# then two device calls back to back (the first only copies):
#     carry [".devwheels/a"]          mkdir -p /tmp/dw && cp .devwheels/a/* /tmp/dw/
#     carry [".devwheels/b", ".whl"]  cp .devwheels/b/* /tmp/dw/ && PYTHONUNBUFFERED=1 bash scripts/gpu_check.sh --json $OUT/gpu_check.json
# `--dry-run`: a few worlds on Warp's CPU device, with what is installed (tests/test_scale.py runs it).
set -euo pipefail
cd "$(dirname "$0")/.."
if ! python3 -c "import mujoco_warp" 2>/dev/null; then
    if [ -d /tmp/dw ] && [ ! -d /tmp/site/mujoco_warp ]; then
        mkdir -p /tmp/site && cat /tmp/dw/part-* | xz -d | tar -x -C /tmp/site
    fi
    if compgen -G ".whl/*.whl" >/dev/null; then
        python3 -m pip install -q --no-index --no-deps --no-compile --upgrade --target /tmp/site .whl/*.whl
    fi
    export PYTHONPATH="/tmp/site${PYTHONPATH:+:$PYTHONPATH}"
fi
python3 -c "import graspmanifold" 2>/dev/null || export PYTHONPATH="$PWD/src${PYTHONPATH:+:$PYTHONPATH}"
exec python3 scripts/bench_trials.py --out "${OUT:-.}/study-gpu-check" device-check "$@"
