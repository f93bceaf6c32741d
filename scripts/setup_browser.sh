#!/usr/bin/env bash
# Install Debian's chromium for the browser tests of the live view (test/viewer), when it is not
# there and this user may (root, apt-get). Playwright drives it as /usr/bin/chromium; it never
# downloads a browser of its own. Without it the browser tests are skipped with the reason.
set -uo pipefail
if command -v chromium >/dev/null 2>&1; then exit 0; fi
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
  echo "[setup] installing chromium (Debian package) for the browser tests"
  (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium) \
    >/tmp/px100_setup_browser.log 2>&1 \
    || echo "[setup] chromium could not be installed (see /tmp/px100_setup_browser.log);" \
            "browser tests will be skipped"
else
  echo "[setup] chromium not found and not root: browser tests will be skipped" \
       "(sudo apt-get install chromium)"
fi
exit 0
