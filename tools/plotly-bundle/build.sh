#!/usr/bin/env bash
# Rebuild the dashboard's partial plotly.js from npm's plotly.js, reproducibly:
#   bash tools/plotly-bundle/build.sh [OUTPUT_DIR]
# npm ci installs exactly the versions in package-lock.json (plotly.js at the version that the pinned plotly
# Python package ships, and esbuild); esbuild bundles index.js, minified, as the global `Plotly`. Writes
# plotly-dashboard.min.js and its manifest plotly-dashboard.json (plotly.js version, trace types, sha256),
# which backend/api/static.py reads, into OUTPUT_DIR (default frontend/vendor). Node is needed here only, never
# at install. The one style sheet plotly.js imports is maplibre's, for map subplots, which the dashboard
# has none of: CSS imports are left out (plotly.js injects its own styles from its JavaScript).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
out="$(realpath -m "${1:-$here/../../frontend/vendor}")"
TRACES='["scatter", "bar", "heatmap"]'
cd "$here"
npm ci --no-audit --no-fund --ignore-scripts --loglevel=error
version="$(node -p 'require("plotly.js/package.json").version')"
mkdir -p "$out"
node_modules/.bin/esbuild index.js --bundle --minify --format=iife --global-name=Plotly --target=es2016 \
    --define:global=window --legal-comments=none --log-level=warning \
    --loader:.css=empty \
    --banner:js="/* plotly.js v$version (MIT, Plotly, Inc.): partial bundle of the mgrao dashboard, traces $TRACES; built by tools/plotly-bundle/build.sh */" \
    --outfile="$out/plotly-dashboard.min.js"
sha="$(sha256sum "$out/plotly-dashboard.min.js" | cut -d' ' -f1)"
printf '{"plotly_js": "%s", "traces": %s, "sha256": "%s"}\n' "$version" "$TRACES" "$sha" > "$out/plotly-dashboard.json"
echo "built $out/plotly-dashboard.min.js: plotly.js $version, traces $TRACES, $(wc -c < "$out/plotly-dashboard.min.js") bytes, sha256 $sha"
