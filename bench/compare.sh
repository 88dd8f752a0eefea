#!/usr/bin/env bash
# Optional side-by-side timing of fringe3d against three peers, in one run, on the same rendered
# data (the sphere scene, 1280 x 1024, 8 bits, noise 1, the conventional 12-image set: 3 levels x
# 4 steps, scales 1 : 8 : 64):
#   - `fringes` (PyPI, numba): its decode(), in its default mode ("fast") and in "precise";
#   - a plain numpy pipeline written below: 4-step phase shifting per level, hierarchical
#     unwrapping coarse to fine, modulation threshold;
#   - OpenCV (opencv-contrib-python-headless): the finest level's wrapped phase, unwrapped
#     spatially by cv2.phase_unwrapping.HistogramPhaseUnwrapping.
# Each is timed in memory (images already loaded, warm) and as a whole process, and its phase is
# checked against fringe3d's before any ratio is printed. Not part of the tests. Needs python3
# with venv and network access to PyPI (two temporary virtual environments).
#
#   bash bench/compare.sh            # prints the times, the agreement and the ratios
set -euo pipefail
cd "$(dirname "$0")/.."
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
TIMEFORMAT=%R

echo "date: $(date '+%Y-%m-%d %H:%M:%S %Z'), commit $(git rev-parse --short HEAD)$(git diff --quiet HEAD -- core host || echo ' (core/host modified)')"
echo "machine: $(nproc) cores, $(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)"
echo "uptime before: $(uptime)"

cargo build --release -q -p fringe3d
cargo build --release -q -p fringe3d --example decode_timing
bin=target/release/fringe3d

# The pattern set: the 12-image preset with the default span (0.9 of a period across the 1024
# columns at the coarsest level), its phase zero at column (6π/7) / slope ≈ 487.6 rather than at
# the centre (511.5), so that `fringes` can describe it. `fringes` models level k as
# cos(2π·v_k·ξ/W + shift − p0), every level's phase zero at column 0 and one p0 for all levels.
# Here level k's phase at column 0 is −8^k·6π/7, the same for every k modulo 2π (8^k − 1 is a
# multiple of 7), so one p0 fits all three levels; with the zero at the centre no p0 does and
# `fringes` returns wrong positions. fringe3d needs the coarse level inside (−π, π): [−2.69, 2.96].
cat > "$work/set.toml" <<'EOF'
version = 1
convention = "sine"
preset = "twelve"
ratio = 8.0

[projector]
width = 1024
height = 768
bit_depth = 16

[phase]
axis = "xi"
kind = "linear"
slope = 0.005522330836388308   # 0.9·2π / 1024
origin = 487.6190476190476     # (6π/7) / slope
EOF
# The sphere scene with that set instead of its [patterns] shorthand (the paper's 8 images).
$bin render --scene sphere --print |
    awk '/^\[patterns\]$/ { print; print "file = \"set.toml\"\n"; skip = 1; next }
         skip && /^\[/ { skip = 0 }
         !skip' > "$work/scene.toml"
$bin render -q --scene "$work/scene.toml" --out "$work/ds" --bits 8 --noise 1
# The set as fringe3d reads it: levels, scales, shifts, phase range, and the (level, shift) of each
# image file (the files are in the built-in order, the finest level first: docs/formats.md).
$bin --json info "$work/ds/patterns.toml" > "$work/set.json"

# fringes pulls in opencv-contrib-python (with GUI), which installs into the same cv2/ folder as
# the headless wheel: each gets a virtual environment of its own. The numpy pipeline runs in
# OpenCV's (numpy and pillow only).
python3 -m venv "$work/venv-fringes"
"$work/venv-fringes/bin/pip" install -q fringes pillow
python3 -m venv "$work/venv-cv"
"$work/venv-cv/bin/pip" install -q opencv-contrib-python-headless numpy pillow
versions='from importlib.metadata import version as v; import sys
print(" ".join(f"{p} {v(p)}" for p in sys.argv[1:]))'
echo "venv-fringes: $("$work/venv-fringes/bin/python" -c "$versions" fringes numba numpy pillow opencv-contrib-python)"
echo "venv-cv:      $("$work/venv-cv/bin/python" -c "$versions" numpy pillow opencv-contrib-python-headless)"

# The peers: for each, load() reads the images it uses, decode() turns them into its result and
# phase() that into the finest level's unwrapped phase (radians, NaN where invalid), fringe3d's
# phase.tif. Each imports its packages inside load(), so that a whole-process run pays for them.
cat > "$work/peers.py" <<'PY'
import json, math, os
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SET = json.load(open(os.path.join(HERE, "set.json")))
SCALES = [level["scale"] for level in SET["levels"]]       # coarse to fine
W, H = SET["projector"]["width"], SET["projector"]["height"]
MIN_MOD = 12.0      # minimum modulation B, 8-bit codes: fringe3d's default for 8-bit images
TWO_PI = np.float32(2 * np.pi)
# What the three pipelines below assume: 4 steps of π/2 on every level, I = A + B·sin(φ + δ).
assert SET["convention"] == "Sine" and SET["phase_offset_rad"] == 0
assert all(np.allclose(l["shifts_rad"], np.arange(4) * np.pi / 2) for l in SET["levels"])

def files(levels):
    """The image files of these levels, each level's shifts in order."""
    by_id = {tuple(o): f for o, f in zip(SET["order"], SET["image_files"])}
    return [by_id[(k, n)] for k in levels for n in range(4)]

def identity(_state, result):
    return result

# numpy: the 12 images, 4-step phase shifting per level, hierarchical unwrapping coarse to fine.
def numpy_load():
    from PIL import Image
    return np.stack([np.asarray(Image.open(f)) for f in files(range(len(SCALES)))])

def numpy_decode(I):
    I = I.astype(np.float32).reshape(len(SCALES), 4, *I.shape[1:])
    s = I[:, 0] - I[:, 2]                   # 2B·sin φ, each level
    c = I[:, 1] - I[:, 3]                   # 2B·cos φ
    wrapped = np.arctan2(s, c)              # (−π, π]
    valid = (np.hypot(s, c) >= 2 * MIN_MOD).all(axis=0)
    phase = wrapped[0]                      # the coarsest level spans less than a period
    for k in range(1, len(SCALES)):         # each level's fringe order from the one before
        ratio = np.float32(SCALES[k] / SCALES[k - 1])
        phase = wrapped[k] + TWO_PI * np.round((ratio * phase - wrapped[k]) / TWO_PI)
    phase[~valid] = np.nan
    return phase

# OpenCV: the finest level's 4 images (all that spatial unwrapping uses), its wrapped phase by
# numpy, unwrapped by HistogramPhaseUnwrapping with the modulation threshold as shadow mask. The
# result is relative: one unknown multiple of 2π for each region the unwrapping connects.
# Not cv2.structured_light.SinusoidalPattern (methodId PSP): its computePhaseMap is 3-step only
# (three images of equal shift: fed 3 of our 4 images, shifts π/2, 0, π with shiftValue π/2, it
# returns −φ), and it band-pass filters each image around the fringe carrier in the Fourier
# domain (a 42 x 42-bin window, meant to remove its cross markers), which bends the phase on this
# scene: only 50 % of the pixels agreed with fringe3d within 0.1 rad (median error 0.1 rad, 99th
# percentile 1.4 rad) against 100 % (modulo 2π) for the 4-step phase here. Its unwrapPhaseMap is
# the same HistogramPhaseUnwrapping with default parameters.
def opencv_load():
    import cv2
    images = [cv2.imread(f, cv2.IMREAD_UNCHANGED) for f in files([len(SCALES) - 1])]
    assert all(i is not None for i in images), "cv2.imread could not read an image"
    return np.stack(images)

def opencv_decode(I):
    import cv2
    I = I.astype(np.float32)
    s, c = I[0] - I[2], I[1] - I[3]
    wrapped = np.arctan2(s, c)
    mask = np.where(np.hypot(s, c) >= 2 * MIN_MOD, 255, 0).astype(np.uint8)
    params = cv2.phase_unwrapping.HistogramPhaseUnwrapping.Params()
    params.height, params.width = wrapped.shape
    unwrapping = cv2.phase_unwrapping.HistogramPhaseUnwrapping.create(params)
    phase = unwrapping.unwrapPhaseMap(wrapped, shadowMask=mask)
    phase[mask == 0] = np.nan
    return phase

# fringes: the 12 images coarse to fine (it takes its frames set by set in the order of its
# frequencies v), and a decoder for them. Level k's phase at column ξ is rel_k·(lo + slope·ξ)
# (rel_k = scale_k / scale_0, lo the coarse phase at column 0) and its images are
# A + B·sin(phase + n·π/2) = A + B·cos(phase + 2π·n/4 − π/2); `fringes` with reverse = True (its
# shifts increasing, as ours) encodes A + B·cos(2π·v_k·x/W + 2π·n/4 − p0), x = ξ when its coding
# length X is the projector's width. So v_k = rel_k·slope·W/2π and p0 = π/2 − rel_k·lo for all k.
def fringes_load(mode="fast"):
    import fringes as frng
    from PIL import Image
    I = np.stack([np.asarray(Image.open(f)) for f in files(range(len(SCALES)))])[..., None]
    lo, hi = SET["coarse_phase_range_rad"]       # at the projector's first and last column
    slope = (hi - lo) / (W - 1)
    rel = [s / SCALES[0] for s in SCALES]
    p0 = [(math.pi / 2 - r * lo) % (2 * math.pi) for r in rel]
    assert np.allclose(np.exp(1j * np.array(p0)), np.exp(1j * p0[0])), \
        f"fringes needs one p0 for all levels (modulo 2π), this set gives {p0}"
    f = frng.Fringes()
    f.X, f.Y = W, H
    f.D = 1                  # one direction (vertical fringes); the default 2 expects 24 frames
    f.K, f.N = len(SCALES), 4
    f.v = [r * slope * W / (2 * math.pi) for r in rel]    # [0.9, 7.2, 57.6] periods across
    f.p0 = p0[0]
    f.reverse = True
    f.mode = mode
    assert f.T == I.shape[0] and f.Lext == W and f.v[0] < 1, (f.T, f.Lext, f.v)
    finest = (rel[-1] * lo, rel[-1] * slope)               # its position x -> our phase
    return f, I, finest

def fringes_decode(state):
    f, I, _ = state
    return f.decode(I, bmin=MIN_MOD)  # bmin: pixels below the same modulation are left invalid

def fringes_phase(state, result):
    a, b = state[2]
    return a + b * result.x[0, ..., 0]

PEERS = {
    "numpy": (numpy_load, numpy_decode, identity),
    "opencv": (opencv_load, opencv_decode, identity),
    "fringes": (fringes_load, fringes_decode, fringes_phase),
    "fringes-precise": (lambda: fringes_load("precise"), fringes_decode, fringes_phase),
}
PY

# In memory: the images loaded once, then decode() warm (the first call is timed apart: for
# fringes it compiles decode() with numba, cached on disk afterwards), best of 3. The phase of the
# last call is kept for the check below.
cat > "$work/in_memory.py" <<'PY'
import sys, time
import numpy as np
import peers
name = sys.argv[1]
load, decode, phase = peers.PEERS[name]
state = load()
t = time.perf_counter()
decode(state)
first = time.perf_counter() - t
best = float("inf")
for _ in range(3):
    t = time.perf_counter()
    result = decode(state)
    best = min(best, time.perf_counter() - t)
np.save(f"{peers.HERE}/{name}.npy", phase(state, result))
print(f"{best:.4f} {first:.3f}")
PY

# Whole process, as a command-line user runs it: a fresh python that imports, loads the images and
# decodes once.
cat > "$work/once.py" <<'PY'
import sys
import peers
load, decode, _ = peers.PEERS[sys.argv[1]]
decode(load())
PY

# Wall seconds of the fastest of three runs of a command, its output discarded.
best_of_3() {
    local t best=
    for _ in 1 2 3; do
        t=$( { time "$@" >/dev/null 2>"$work/stderr"; } 2>&1 ) || { cat "$work/stderr" >&2; return 1; }
        best=$(printf '%s\n' $best "$t" | sort -g | head -1)
    done
    echo "$best"
}

# fringe3d: in memory (host/examples/decode_timing.rs: images loaded, decoder set-up and output
# allocation included, all cores, warm, best of 5), and whole processes from the PNGs on disk.
f3d_mem=$(target/release/examples/decode_timing "$work/ds/patterns.toml" "$work/ds" 5)
f3d_scan=$(best_of_3 $bin scan -q --patterns "$work/ds/patterns.toml" \
    --calibration "$work/ds/calibration.toml" "$work/ds" -o "$work/cloud.ply")
f3d_decode=$(best_of_3 $bin decode -q --overwrite --patterns "$work/ds/patterns.toml" "$work/ds" \
    --out "$work/dec")

declare -A venv=([numpy]=venv-cv [opencv]=venv-cv [fringes]=venv-fringes [fringes-precise]=venv-fringes)
declare -A mem first proc
for peer in fringes fringes-precise numpy opencv; do
    py="$work/${venv[$peer]}/bin/python"
    out=$(PYTHONPATH="$work" "$py" "$work/in_memory.py" "$peer" 2>"$work/stderr") ||
        { cat "$work/stderr" >&2; exit 1; }
    read -r mem[$peer] first[$peer] <<<"$(tail -n 1 <<<"$out")"
    proc[$peer]=$(PYTHONPATH="$work" best_of_3 "$py" "$work/once.py" "$peer")
done

echo "uptime after: $(uptime)"
echo
echo "fringe3d decode in memory (images loaded, all cores, warm, best of 5): $f3d_mem s"
echo "fringe3d scan, whole process (12 PNGs -> binary PLY, best of 3): $f3d_scan s"
echo "fringe3d decode, whole process (12 PNGs -> float TIFFs + preview, best of 3): $f3d_decode s"
echo "fringes decode() first call in the run (includes its numba compilation): ${first[fringes]} s"

# Agreement with fringe3d's phase.tif: of the pixels fringe3d finds valid, the share the peer
# decodes too, and the share whose phase agrees within 0.1 rad (1/63 of a period) after removing
# the median difference (0 for an absolute phase; a multiple of 2π for OpenCV's relative one),
# and the share agreeing modulo 2π (wrong fringe orders apart). Then the table and the ratios.
"$work/venv-cv/bin/python" - "$work" "$f3d_mem" "$f3d_scan" "$f3d_decode" \
    "fringes ${mem[fringes]} ${proc[fringes]}" \
    "fringes-precise ${mem[fringes-precise]} ${proc[fringes-precise]}" \
    "numpy ${mem[numpy]} ${proc[numpy]}" "opencv ${mem[opencv]} ${proc[opencv]}" <<'PY'
import sys
import numpy as np
from PIL import Image
work, f3d_mem, f3d_scan, f3d_decode = sys.argv[1], *map(float, sys.argv[2:5])
what = {
    "fringes": "fringes decode(), default mode (fast), 12 images",
    "fringes-precise": "fringes decode(), mode precise, 12 images",
    "numpy": "numpy: 4-step + hierarchical unwrapping, 12 images",
    "opencv": "OpenCV: 4-step (numpy) + HistogramPhaseUnwrapping, 4 images",
}
ref = np.asarray(Image.open(f"{work}/dec/phase.tif"))
ok_ref = np.isfinite(ref)
n = ok_ref.sum()
print(f"\nagreement with fringe3d's unwrapped phase ({n} valid pixels), within 0.1 rad:")
rows = []
for arg in sys.argv[5:]:
    name, mem, proc = arg.split()
    phase = np.load(f"{work}/{name}.npy")
    both = ok_ref & np.isfinite(phase)
    d = ref[both] - phase[both]
    offset = np.median(d)
    d -= offset
    mod = np.abs((d + np.pi) % (2 * np.pi) - np.pi)
    extra = (np.isfinite(phase) & ~ok_ref).sum()
    print(f"  {name:16} {(np.abs(d) < 0.1).sum() / n:8.3%}   modulo 2π {(mod < 0.1).sum() / n:8.3%}   "
          f"decoded {both.sum() / n:8.3%} (+{extra} pixels fringe3d rejects)   "
          f"offset {offset:+.3f} rad = {offset / (2 * np.pi):+.2f}·2π")
    rows.append((name, float(mem), float(proc)))
print(f"\n{'':62} {'in memory':>10} {'whole process':>14}")
print(f"{'fringe3d (decode_timing | scan, decode)':62} {f3d_mem:9.4f}s {f3d_scan:7.3f}s, {f3d_decode:.3f}s")
for name, mem, proc in rows:
    print(f"{what[name]:62} {mem:9.4f}s {proc:13.3f}s")
print(f"\nratios peer / fringe3d: {'in memory':>10} {'whole process / scan':>21} {'/ decode':>9}")
for name, mem, proc in rows:
    print(f"  {name:21} {mem / f3d_mem:9.1f}x {proc / f3d_scan:20.1f}x {proc / f3d_decode:8.1f}x")
PY
