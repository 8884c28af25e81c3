#!/usr/bin/env bash
# The report's browser test (tests/test_report.py) opens results/ci/report.html in Debian's
# chromium, headless. make test-pipeline installs it when it is missing and this is a Debian root shell
# (an 81 MB package; 13 s here, the package lists already fetched); otherwise it says why the
# browser test will be skipped.
set -euo pipefail
if command -v chromium > /dev/null; then
    exit 0
fi
if [ "$(id -u)" -eq 0 ] && command -v apt-get > /dev/null; then
    echo "installing Debian's chromium for the report's browser test"
    if ! { apt-get update -qq > /dev/null && \
           DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends chromium > /dev/null; }; then
        echo "installing chromium failed: the report's browser test will be skipped (pytest lists the skip)"
    fi
else
    echo "chromium missing and no root apt-get: the report's browser test will be skipped (apt-get install chromium)"
fi
