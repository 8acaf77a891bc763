#!/usr/bin/env bash
# Installs the Debian 12 packages HandSteady needs that are missing.
# As root it runs apt-get; otherwise it prints the exact command and fails.
# Usage: scripts/deps.sh [build|test|all]   (default: all)
set -euo pipefail
what=${1:-all}
pkgs=(cmake g++ make pkg-config libeigen3-dev libfmt-dev libspdlog-dev nlohmann-json3-dev libcli11-dev
      libopenxr-dev libopenxr-loader1 libopenxr-utils openxr-layer-corevalidation)
case "$what" in
  build) ;;
  test|all) pkgs+=(doctest-dev libbenchmark-dev) ;;
  *) echo "usage: $0 [build|test|all]" >&2; exit 2 ;;
esac
# Extra package lists (one package per line); test-*.txt only for the tests.
for f in "$(dirname "$0")"/deps.d/*.txt; do
  case "$(basename "$f")" in test-*) [ "$what" = build ] && continue ;; esac
  [ -f "$f" ] && while read -r p; do [ -n "$p" ] && [ "${p#\#}" = "$p" ] && pkgs+=("$p"); done < "$f"
done
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
cmd="apt-get install -y --no-install-recommends ${missing[*]}"
if [ "$(id -u)" -eq 0 ]; then
  echo "deps: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq || true
  $cmd
else
  echo "deps: missing Debian packages; run as root:" >&2
  echo "  sudo $cmd" >&2
  exit 1
fi
