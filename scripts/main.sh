#!/usr/bin/env bash
# The main job: set-up, a headless capture of the default scene with every technique
# (image, heat map, dump), then the quick benchmark report.  Everything goes to ${1:-out}/.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
out="${1:-out}"
mkdir -p "$out/capture"
py=.venv/bin/python
for t in $($py -m app.capture --list | sed -n 's/^techniques: *//p'); do
    echo "capture: city / $t" >&2
    $py -m app.capture --scene city --technique "$t" --out "$out/capture/city-$t.png" \
        --heatmap "$out/capture/city-$t-heat.png" --dump "$out/capture/city-$t.npz" \
        > "$out/capture/city-$t.json"
done
$py -m app.capture --scene city --technique hybrid --classify "$out/capture/city-hybrid-classes.png" >/dev/null
if $py -c 'import app.bench' 2>/dev/null; then
    $py -m app.bench --quick --out "$out/bench"
fi
echo "done: images and numbers in $out/" >&2
