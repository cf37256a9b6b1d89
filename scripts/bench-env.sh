#!/bin/sh
# The Python environment of the render benches: NVIDIA's FLIP metric and
# Blender's bpy wheel (current Cycles with Open Image Denoise), kept apart from
# the system in target/bench-py. About 1 GB; run once.
set -eu
cd "$(dirname "$0")/.."
if [ ! -x target/bench-py/bin/python ]; then
    python3 -m venv target/bench-py
fi
target/bench-py/bin/pip install --quiet --disable-pip-version-check "flip-evaluator==1.7" numpy "bpy==5.0.1"
target/bench-py/bin/python -c "import flip_evaluator, bpy; print('bench environment ready: flip-evaluator, bpy', bpy.app.version_string)"
