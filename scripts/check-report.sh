#!/bin/bash
# Renders a run's report.html (or any page: a sweep's index.html) in headless Chromium (Debian's `chromium`) and checks it:
# the page logs no console message, and the screenshot is not blank (its pixels do not
# compress below 1 % of their raw size, as an empty page's do).
# Usage: scripts/check-report.sh RUN_DIR|PAGE.html [SCREENSHOT.png]
#        (default: the page's name with .png, beside it)
set -euo pipefail
TARGET=${1:?usage: scripts/check-report.sh RUN_DIR|PAGE.html [SCREENSHOT.png]}
if [ -d "$TARGET" ]; then
    PAGE=$(cd "$TARGET" && pwd)/report.html
else
    PAGE=$(cd "$(dirname "$TARGET")" && pwd)/$(basename "$TARGET")
fi
SHOT=${2:-${PAGE%.html}.png}
[ -f "$PAGE" ] || { echo "check-report.sh: $PAGE: no such file" >&2; exit 1; }
command -v chromium >/dev/null || { echo "check-report.sh: needs chromium (apt-get install -y chromium)" >&2; exit 2; }
PROFILE=$(mktemp -d)
LOG=$(mktemp)
trap 'rm -rf "$PROFILE" "$LOG"' EXIT
timeout 120 chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
    --disable-background-networking --disable-component-update --disable-sync \
    --user-data-dir="$PROFILE" --enable-logging=stderr --v=0 --window-size=1200,2400 \
    --screenshot="$SHOT" "file://$PAGE" 2>"$LOG" >/dev/null
if grep -E 'CONSOLE|Uncaught' "$LOG"; then
    echo "check-report.sh: the page logged console messages (above)" >&2
    exit 1
fi
python3 - "$SHOT" <<'EOF'
import struct, sys, zlib
data = open(sys.argv[1], "rb").read()
assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
pos, idat, size = 8, b"", None
while pos < len(data):
    n, kind = struct.unpack(">I4s", data[pos:pos + 8])
    body = data[pos + 8:pos + 8 + n]
    if kind == b"IHDR":
        size = struct.unpack(">II", body[:8])
    elif kind == b"IDAT":
        idat += body
    pos += 12 + n
raw = zlib.decompress(idat)
ratio = len(zlib.compress(raw, 9)) / len(raw)
print(f"screenshot {sys.argv[1]}: {size[0]}x{size[1]}, compresses to {100 * ratio:.2f} % of its raw size")
sys.exit(0 if ratio > 0.01 else "the screenshot is blank")
EOF
