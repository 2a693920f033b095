#!/usr/bin/env bash
# Renders a `cargo xtask report` folder as a person sees it: headless Chromium screenshots of
# index.html and of one episode page (the first, or the one named), into PNG files.
#
#   tools/screenshot_report.sh REPORT_DIR [OUT_DIR] [EPISODE_PAGE]
#
# REPORT_DIR: what `cargo xtask report ... --out REPORT_DIR` wrote. OUT_DIR (default
# REPORT_DIR/screenshots) receives index.png (the top: the tables), index-figures.png and
# index-episodes.png (further down: headless Chromium ignores a URL's #fragment, so these frame
# index.html#figures and #episodes in a small wrapper page), episode.png and one PNG per figure. EPISODE_PAGE: a path under
# REPORT_DIR (default: the first episode page, in sorted order). Needs Debian's `chromium`
# (`apt-get install -y chromium`); set CHROMIUM to use another binary.
set -euo pipefail

report=${1:?usage: tools/screenshot_report.sh REPORT_DIR [OUT_DIR] [EPISODE_PAGE]}
out=${2:-$report/screenshots}
chromium=${CHROMIUM:-chromium}
if ! command -v "$chromium" >/dev/null; then
    echo "error: $chromium not found; install it with: apt-get install -y chromium" >&2
    exit 2
fi
if [[ ! -f $report/index.html ]]; then
    echo "error: $report/index.html not found; run cargo xtask report RECORDS --out $report first" >&2
    exit 2
fi
report=$(cd "$report" && pwd)
mkdir -p "$out"
out=$(cd "$out" && pwd)
# (awk, not head: head exits after one line, and with thousands of pages sort then dies of
# SIGPIPE, which pipefail and set -e turn into a silent exit of this script)
episode=${3:-$(cd "$report" && find episodes -name '*.html' | sort | awk 'NR == 1')}
if [[ -z $episode || ! -f $report/$episode ]]; then
    echo "error: no episode page ${episode:-(none found)} under $report" >&2
    exit 2
fi

shoot() {
    local page=$1 png=$2 size=$3
    # A throwaway profile: no state shared with other runs; --no-sandbox where run as root.
    local profile
    profile=$(mktemp -d)
    "$chromium" --headless --disable-gpu --no-sandbox --hide-scrollbars --user-data-dir="$profile" \
        --window-size="$size" --screenshot="$png" "file://$page" >/dev/null 2>&1
    rm -rf "$profile"
    echo "$png  <-  $page"
}

shoot "$report/index.html" "$out/index.png" 1280,2000
for anchor in figures episodes; do
    wrapper="$out/index-$anchor.html"
    printf '<!DOCTYPE html><html><body style="margin:0"><iframe src="file://%s/index.html#%s" style="width:1280px;height:2000px;border:0"></iframe></body></html>\n' \
        "$report" "$anchor" > "$wrapper"
    shoot "$wrapper" "$out/index-$anchor.png" 1280,2000
    rm -f "$wrapper"
done
shoot "$report/$episode" "$out/episode.png" 1280,2000
for svg in "$report"/*.svg; do
    [[ -f $svg ]] || continue
    name=$(basename "$svg" .svg)
    height=$(sed -n 's/.*<svg [^>]*height="\([0-9.]*\)".*/\1/p' "$svg" | awk 'NR == 1')
    shoot "$svg" "$out/figure-$name.png" "1000,${height%.*}"
done
