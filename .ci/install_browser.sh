#!/usr/bin/env bash
# Install headless Chromium and its WebDriver (Debian packages `chromium`, `chromium-driver`) for
# tests/test_browser.py, when they are missing.  Never fails the CI run: without a browser those tests skip
# with the reason.
set -u
have() { command -v "$1" >/dev/null 2>&1; }
if { have chromium || have chromium-browser; } && have chromedriver; then
  echo "install_browser: chromium and chromedriver present"
  exit 0
fi
SUDO=""
if [ "$(id -u)" != "0" ]; then
  if have sudo && sudo -n true 2>/dev/null; then SUDO="sudo -n"; else
    echo "install_browser: not root and no sudo: browser tests will skip"; exit 0; fi
fi
if ! have apt-get; then
  echo "install_browser: no apt-get: browser tests will skip"; exit 0
fi
export DEBIAN_FRONTEND=noninteractive
if $SUDO apt-get update -qq >/dev/null 2>&1 && \
   $SUDO apt-get install -y -qq --no-install-recommends chromium chromium-driver fonts-liberation >/dev/null 2>&1; then
  echo "install_browser: installed $(chromium --version 2>/dev/null | head -1)"
else
  echo "install_browser: apt-get install chromium chromium-driver failed: browser tests will skip"
fi
exit 0
