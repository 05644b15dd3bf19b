#!/usr/bin/env bash
# Opens a local HTML page in headless Chromium, offline, with software WebGL (SwiftShader: no GPU
# needed), and prints its DOM after its scripts ran, or writes a screenshot. The report test
# (tests/tools/test_report.cpp) and docs/report.png use this one command.
#   tools/headless_page.sh dom PAGE.html              the DOM on stdout, Chromium's log on stderr
#   tools/headless_page.sh screenshot PAGE.html OUT.png
#   PAGE.html#fragment                                 the page opened at that fragment (report.html#clip=z,0.5)
# Environment: CHROMIUM (default: chromium on PATH), WINDOW (default 1120,860).
# Exit 127 when Chromium is missing; otherwise Chromium's exit status.
set -euo pipefail
mode=${1:?usage: headless_page.sh dom|screenshot PAGE.html [OUT.png]}
page=${2:?usage: headless_page.sh dom|screenshot PAGE.html [OUT.png]}
chromium=${CHROMIUM:-$(command -v chromium || command -v chromium-browser || true)}
if [ -z "$chromium" ] || ! [ -x "$chromium" ]; then
  echo "headless_page.sh: chromium not found (Debian package chromium; tools/setup.sh installs it)" >&2
  exit 127
fi
# PAGE may end in a fragment (report.html#clip=z,0.5): the file is the part before '#'.
file=${page%%#*}
url="file://$(realpath "$file")${page#"$file"}"
# A throw-away profile, no network (every host resolves to nothing), a fixed window; the virtual time
# budget lets the page's scripts finish before the DOM or the pixels are taken.
profile=$(mktemp -d)
trap 'rm -rf "$profile"' EXIT
flags=(--headless --no-sandbox --disable-dev-shm-usage --disable-gpu --use-angle=swiftshader --enable-unsafe-swiftshader
       --user-data-dir="$profile" --no-first-run --no-default-browser-check --disable-extensions
       --host-resolver-rules="MAP * ~NOTFOUND" --no-proxy-server
       --window-size="${WINDOW:-1120,860}" --hide-scrollbars --force-device-scale-factor=1
       --enable-logging=stderr --v=0 --virtual-time-budget=15000)
case "$mode" in
  dom) exec "$chromium" "${flags[@]}" --dump-dom "$url" ;;
  screenshot) exec "$chromium" "${flags[@]}" --screenshot="$(realpath -m "${3:?screenshot needs OUT.png}")" "$url" ;;
  *) echo "headless_page.sh: unknown mode $mode (dom or screenshot)" >&2; exit 2 ;;
esac
