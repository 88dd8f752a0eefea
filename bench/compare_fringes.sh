#!/usr/bin/env bash
# Optional side-by-side timing of fringe3d against the `fringes` Python package (PyPI) on the same
# data: a rendered 1280x1024 scan with the conventional 12-image set (3 levels x 4 steps), which
# both can decode. Not part of the tests. Needs python3 with venv and network access to PyPI.
#
#   bash bench/compare_fringes.sh            # prints both times and the ratio
set -euo pipefail
cd "$(dirname "$0")/.."
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

cargo build --release -q -p fringe3d
bin=target/release/fringe3d

# The sphere scene with the 12-image preset instead of the paper's 8.
$bin render --scene sphere --print | sed 's/^preset = "paper8"/preset = "twelve"/' > "$work/scene.toml"
$bin render -q --scene "$work/scene.toml" --out "$work/ds" --bits 8 --noise 1

python3 -m venv "$work/venv"
"$work/venv/bin/pip" install -q fringes numpy pillow

# fringe3d: whole process, images on disk to a point cloud (and to a phase map alone).
# Its in-memory decode (images already loaded, as fringes' decode() below: decoder set-up, output
# allocation, all cores), warm, best of 5: host/examples/decode_timing.rs.
cargo build --release -q -p fringe3d --example decode_timing
t_mem=$(target/release/examples/decode_timing "$work/ds/patterns.toml" "$work/ds" 5)
TIMEFORMAT=%R
t_scan=$( { time $bin scan -q --patterns "$work/ds/patterns.toml" \
    --calibration "$work/ds/calibration.toml" "$work/ds" -o "$work/cloud.ply"; } 2>&1 )
t_decode=$( { time $bin decode -q --patterns "$work/ds/patterns.toml" "$work/ds" \
    --out "$work/dec"; } 2>&1 )

# The set's image order, as fringe3d reads it: (level, shift) of each image file. The built-in
# order of the 12-image preset is the finest level first (levels with a DC term, finest first;
# docs/formats.md), while `fringes` takes its frames set by set in the order of its frequencies
# `v`, declared ascending below: the images are handed over coarse to fine, each level's shifts
# in order, from this list (handing the files in name order gave `fringes` the finest level as
# its coarsest).
$bin --json info "$work/ds/patterns.toml" > "$work/set.json"

# fringes, configured once for both timings below: the 12 images of the dataset, loaded coarse to
# fine, and a decoder for them.
cat > "$work/fringes_setup.py" <<'PY'
import sys, json, os, numpy as np
from PIL import Image
import fringes as frng

def load(folder):
    info = json.load(open(os.path.join(os.path.dirname(folder), "set.json")))
    # (level, shift) -> file; levels are numbered coarse (0) to fine (2).
    by_id = {tuple(o): f for o, f in zip(info["order"], info["image_files"])}
    files = [by_id[k] for k in sorted(by_id)]
    assert len(files) == 12 and sorted(by_id)[0] == (0, 0), sorted(by_id)
    I = np.stack([np.asarray(Image.open(f)) for f in files])[..., None]   # (T, Y, X, 1)
    f = frng.Fringes()
    f.X, f.Y = I.shape[2], I.shape[1]
    f.D = 1                  # one direction (vertical fringes); the default 2 expects 24 frames
    f.K, f.N = 3, 4
    f.v = [0.9, 7.2, 57.6]   # periods across the projector, coarse to fine, as the frames above
    assert f.T == I.shape[0], (f.T, I.shape)
    return f, I
PY

# fringes: decode the same 12 images (loading excluded: only its decode() is timed).
t_fringes=$(PYTHONPATH="$work" "$work/venv/bin/python" - "$work/ds" <<'PY'
import sys, time
from fringes_setup import load
f, I = load(sys.argv[1])
t = time.perf_counter()
f.decode(I)              # the first call compiles decode() (numba, cached on disk afterwards)
first = time.perf_counter() - t
best = float("inf")
for _ in range(3):
    t = time.perf_counter()
    f.decode(I)
    best = min(best, time.perf_counter() - t)
print(f"{best:.3f} {first:.3f}")
PY
)
read -r t_fringes t_first <<<"$t_fringes"

# fringes as a command-line user runs it, like the fringe3d processes above: a fresh Python
# process that imports it, loads the PNGs and decodes once (its numba cache is warm by now).
cat > "$work/fringes_once.py" <<'PY'
import sys
from fringes_setup import load
f, I = load(sys.argv[1])
f.decode(I)
PY
t_proc=$(for _ in 1 2 3; do { time PYTHONPATH="$work" "$work/venv/bin/python" "$work/fringes_once.py" "$work/ds" >/dev/null; } 2>&1; done | sort -g | head -1)
echo "uptime: $(uptime)"
echo "fringe3d scan (whole process, 12 PNGs -> binary PLY): ${t_scan} s"
echo "fringe3d decode (whole process, 12 PNGs -> float TIFFs): ${t_decode} s"
echo "fringe3d decode in memory (images already loaded, all cores, warm, best of 5): ${t_mem} s"
echo "fringes decode() (in Python, images already loaded, compiled, best of 3): ${t_fringes} s"
echo "fringes decode() first call (includes its numba compilation): ${t_first} s"
echo "fringes whole process (fresh python: import, load 12 PNGs, decode; numba cache warm; best of 3): ${t_proc} s"
python3 -c "print(f'ratio, decode in memory, fringes (compiled) / fringe3d: {float(\"$t_fringes\") / float(\"$t_mem\"):.1f}x')"
python3 -c "print(f'ratio fringes decode (compiled) / fringe3d whole-process scan: {float(\"$t_fringes\") / float(\"$t_scan\"):.1f}x; first call: {float(\"$t_first\") / float(\"$t_scan\"):.1f}x')"
python3 -c "print(f'ratio, whole process, fringes / fringe3d scan: {float(\"$t_proc\") / float(\"$t_scan\"):.1f}x')"
