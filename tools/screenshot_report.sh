#!/usr/bin/env bash
# Screenshot of a compare report as a browser shows it: tools/screenshot_report.sh REPORT_DIR OUT.png
# Checks that every <img> of REPORT_DIR/report.html exists there, renders the page with headless Chromium
# (Debian's chromium; tools/setup.sh installs it) at 1400x2400, and fails unless the screenshot has the
# window's size and is not blank. Environment: CHROMIUM (default chromium), SCREENSHOT_SIZE (W,H).
set -euo pipefail

if [ $# -ne 2 ]; then
  echo "usage: $0 REPORT_DIR OUT.png" >&2
  exit 2
fi
dir=$(cd "$1" && pwd) || { echo "screenshot: no such folder: $1" >&2; exit 1; }
out=$2
html="$dir/report.html"
[ -f "$html" ] || { echo "screenshot: $html does not exist (run coneshadow compare first)" >&2; exit 1; }
case "$out" in /*) ;; *) out="$PWD/$out" ;; esac
size=${SCREENSHOT_SIZE:-1400,2400}
browser=${CHROMIUM:-chromium}
command -v "$browser" >/dev/null || {
  echo "screenshot: $browser not found (Debian package chromium; tools/setup.sh installs it)" >&2; exit 1; }

# The report is self-contained: every image it shows lies beside it.
missing=0
while read -r src; do
  [ -f "$dir/$src" ] || { echo "screenshot: report.html shows $src, which is not in $dir" >&2; missing=1; }
done < <(grep -o '<img[^>]*src="[^"]*"' "$html" | sed 's/.*src="\([^"]*\)"/\1/')
[ "$missing" -eq 0 ] || exit 1

profile=$(mktemp -d)
trap 'rm -rf "$profile"' EXIT
rm -f "$out"
# --no-sandbox: containers run as root without user namespaces; --disable-gpu: no GPU process.
if ! timeout 120 "$browser" --headless --no-sandbox --disable-gpu --hide-scrollbars --user-data-dir="$profile" \
    --window-size="$size" --screenshot="$out" "file://$html" >"$profile/log" 2>&1 || [ ! -s "$out" ]; then
  grep -v -i dbus "$profile/log" | tail -5 >&2
  echo "screenshot: $browser wrote no screenshot" >&2
  rm -f "$out"
  exit 1
fi

# Not blank: the PNG's size is the window's, and its pixel data holds many distinct byte values (a blank
# page compresses to runs of one value). PNG parsed with the standard library only.
python3 - "$out" "$size" <<'EOF' || { rm -f "$out"; exit 1; }
import struct, sys, zlib
path, size = sys.argv[1], sys.argv[2]
data = open(path, "rb").read()
if data[:8] != b"\x89PNG\r\n\x1a\n":
    sys.exit(f"screenshot: {path} is not a PNG")
pos, idat, w = 8, b"", 0
while pos < len(data):
    n, kind = struct.unpack(">I4s", data[pos:pos + 8])
    body = data[pos + 8:pos + 8 + n]
    if kind == b"IHDR":
        w, h = struct.unpack(">II", body[:8])
    elif kind == b"IDAT":
        idat += body
    pos += 12 + n
want = tuple(int(v) for v in size.split(","))
if (w, h) != want:
    sys.exit(f"screenshot: {path} is {w}x{h}, the window is {want[0]}x{want[1]}")
pixels = zlib.decompress(idat)
distinct = len(set(pixels))
if distinct < 32:
    sys.exit(f"screenshot: {path} looks blank ({distinct} distinct byte values)")
print(f"screenshot: {path} {w}x{h}, {distinct} distinct byte values")
EOF
