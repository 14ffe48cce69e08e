#!/usr/bin/env bash
# ctest entry of a browser test (report_check.mjs: `imuqual report`;
# web_check.mjs: `imuqual serve`; live_check.mjs: `imuqual serve --bus`
# during a soak): checks that what it needs is there,
# saying how to get what is not, then runs it.
# Usage: run_check.sh CHECK.mjs path/to/imuqual
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
check="${1:?usage: run_check.sh CHECK.mjs path/to/imuqual}"
imuqual="${2:?usage: run_check.sh CHECK.mjs path/to/imuqual}"
chromium="${CHROMIUM:-/usr/bin/chromium}"

die() {
  echo "${check%.mjs}: FAIL: $*" >&2
  exit 1
}
deps="scripts/browser-deps installs it"
command -v node >/dev/null 2>&1 || die "node is not installed; $deps"
node_major="$(node -p 'process.versions.node.split(".")[0]')"
[ "$node_major" -ge 18 ] || die "node $(node --version) is too old (need 18 or newer)"
[ -x "$chromium" ] || die "no Chromium at $chromium (set CHROMIUM for another); $deps"
[ -f "$here/node_modules/playwright-core/package.json" ] ||
  die "playwright-core is not installed in tests/browser; $deps (npm ci)"
command -v sqlite3 >/dev/null 2>&1 || die "the sqlite3 shell is not installed; scripts/bootstrap installs it"
command -v openssl >/dev/null 2>&1 || die "the openssl command is not installed; scripts/bootstrap installs it"
[ -x "$imuqual" ] || die "no imuqual binary at $imuqual"

[ -f "$here/$check" ] || die "no check $here/$check"
exec node "$here/$check" --imuqual "$imuqual" --chromium "$chromium"
