#!/usr/bin/env bash
# The main job: set-up; a first look within about a minute (a headless capture of the default
# scene with every technique: image, heat map, dump; then one page, summary.md + summary.png,
# with every technique's heat map and the exactness line); then the quick benchmark report,
# with its progress.  Everything goes to ${1:-out}/.
#
# LAB_FIRST_LOOK_SIZE (default 480x270) is the first look's capture size; the captures run one
# a core.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
out="${1:-out}"
size="${LAB_FIRST_LOOK_SIZE:-480x270}"
mkdir -p "$out/capture"
py=.venv/bin/python
start=$(date +%s)

capture() {     # one technique: image, heat map, dump, and its summary line (JSON)
    local t="$1" extra=()
    [ "$t" = hybrid ] && extra=(--classify "$out/capture/city-$t-classes.png")
    if ! $py -m app.capture --scene city --size "$size" --technique "$t" \
            --out "$out/capture/city-$t.png" --heatmap "$out/capture/city-$t-heat.png" \
            --dump "$out/capture/city-$t.npz" "${extra[@]}" \
            > "$out/capture/city-$t.json" 2> "$out/capture/city-$t.log"; then
        cat "$out/capture/city-$t.log" >&2
        return 1
    fi
    echo "capture: city / $t at $size ($(( $(date +%s) - start )) s)" >&2
}
export -f capture
export out size py start

techniques=$($py -m app.capture --list | sed -n 's/^techniques: *//p')
rm -f "$out"/capture/city-*.npz          # the summary reads every dump in the folder
# one capture a core; brute (the reference) comes first in the list
if ! printf '%s\n' $techniques | xargs -P "$(nproc 2>/dev/null || echo 2)" -I{} bash -c 'capture "$1"' _ {}; then
    echo "error: a capture failed (its error is above; logs in $out/capture/)" >&2
    exit 1
fi

exact=0
$py -m app.summary "$out/capture" --out "$out/summary" || exact=1
echo "first look ($(( $(date +%s) - start )) s): open $out/summary.md or $out/summary.png; captures in $out/capture/" >&2

if $py -c 'import app.bench' 2>/dev/null; then
    echo "now the quick benchmark report (about six minutes on 2 cores) in $out/bench/" >&2
    $py -m app.bench --quick --out "$out/bench"
fi
echo "done: images and numbers in $out/ (first look: $out/summary.md)" >&2
if [ "$exact" != 0 ]; then
    echo "error: the first look's exactness line above says a technique differs from brute" >&2
    exit 1
fi
