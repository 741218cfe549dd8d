#!/usr/bin/env bash
# System packages the tests and `jointwear serve`'s checks need, from Debian:
#   prometheus  the real server and promtool (alert rules checked, the service scraped)
#   chromium    headless browser that loads the plant page (tests, screenshot)
# Installs only what is missing; quiet and non-interactive. Needs root (CI and the
# project's machines run as root); as another user it says what to install and exits 0,
# and the tests that need the package then fail with that instruction.
set -euo pipefail
need=()
command -v prometheus >/dev/null 2>&1 && command -v promtool >/dev/null 2>&1 || need+=(prometheus)
command -v chromium >/dev/null 2>&1 || need+=(chromium)
[ ${#need[@]} -eq 0 ] && exit 0
if [ "$(id -u)" != 0 ] || ! command -v apt-get >/dev/null 2>&1; then
  echo "install_system_deps: missing ${need[*]}: install them as root (apt-get install ${need[*]})" >&2
  exit 0
fi
echo "installing Debian packages: ${need[*]} (first run: ~1 min)"
export DEBIAN_FRONTEND=noninteractive
if ! { apt-get update -qq >/dev/null && apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null; }; then
  # the rest of the suite still runs; the tests that need these fail and say how to install them
  echo "install_system_deps: apt-get could not install ${need[*]}; the Prometheus and browser tests will fail" >&2
  exit 0
fi
# the Debian package starts a prometheus service where systemd runs; the tests start their own
if command -v systemctl >/dev/null 2>&1 && systemctl is-active --quiet prometheus 2>/dev/null; then
  systemctl stop prometheus >/dev/null 2>&1 || true
  systemctl disable prometheus >/dev/null 2>&1 || true
fi
